"""The vehicle base class: state and control names plus SymPy dynamics, written once.

A new vehicle is one small subclass; the Pyomo transcription, the validator and
the Pontryagin engine all read ``states``, ``controls`` and ``dynamics()``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp


def sym(name: str) -> sp.Symbol:
    """The project's one way of naming a real SymPy symbol."""
    return sp.Symbol(name, real=True)


class Vehicle:
    """Base class: subclasses set ``states``, ``controls`` and ``dynamics``."""

    model: str = ""
    states: tuple[str, ...] = ()
    controls: tuple[str, ...] = ()
    position: tuple[str, str] = ("x", "y")
    parameter_keys: dict[str, str] = {}  # parameter symbol -> its key in a scenario's [vehicle]
    positive_parameters: tuple[str, ...] | None = None  # symbols that must be > 0 (None: all of them)

    def parameters(self) -> dict[str, float]:
        """Numeric values of the model's parameters, keyed by symbol name."""
        return {}

    def dynamics(self) -> dict[str, sp.Expr]:
        """State derivatives as SymPy expressions of state, control, parameter symbols."""
        raise NotImplementedError

    def outputs(self) -> dict[str, sp.Expr]:
        """Named functions of the state that ``[bounds]`` may limit (e.g. the articulation angle)."""
        return {}

    @property
    def lateral_acceleration(self) -> sp.Expr | None:
        """The signed lateral acceleration of the reference point, m/s^2, as a SymPy expression.

        Speed along the path times the yaw rate (> 0 turning left), a function of the states,
        the controls and the parameters; ``[bounds] lateral_acceleration`` limits it at every node.
        None for a model that does not define it (such a bound is then an input error).
        """
        return None

    def path_outputs(self) -> dict[str, sp.Expr]:
        """Named functions of the state and the control that ``[bounds]`` may limit (``lateral_acceleration``)."""
        a_lat = self.lateral_acceleration
        return {} if a_lat is None else {"lateral_acceleration": a_lat}

    def path_function(self, exprs: list[sp.Expr]):
        """Numpy evaluation of expressions of the state and the control (parameters substituted).

        Returns a function of a mapping name -> array (states and controls) giving one float array
        per expression, broadcast to the shape of the first state.
        """
        return self._numeric(self.states + self.controls, exprs)

    def body_poses(self) -> dict[str, tuple[sp.Expr, sp.Expr, sp.Expr]]:
        """Reference point (x, y) and heading of each body that can be attached, by body name."""
        px, py = self.position
        return {"vehicle": (sym(px), sym(py), sym("theta"))}

    # -- derived helpers ---------------------------------------------------
    def state_symbols(self) -> list[sp.Symbol]:
        return [sym(s) for s in self.states]

    def control_symbols(self) -> list[sp.Symbol]:
        return [sym(c) for c in self.controls]

    def parameter_symbols(self) -> dict[str, sp.Symbol]:
        return {k: sym(k) for k in self.parameters()}

    def state_function(self, exprs: list[sp.Expr]):
        """Numpy evaluation of expressions of the state (parameters substituted) on arrays of node values.

        Returns a function of a mapping state name -> array giving one float array per expression.
        """
        return self._numeric(self.states, exprs)

    def _numeric(self, names: list[str], exprs: list[sp.Expr]):
        """Expressions of the named variables (parameters substituted) as one numpy function of a mapping
        name -> array; each result broadcast to the shape of the first state. Strict sympify: no string."""
        values = {sym(k): v for k, v in self.parameters().items()}
        fn = sp.lambdify([sym(n) for n in names], [sp.sympify(e, strict=True).subs(values) for e in exprs], "numpy")

        def evaluate(columns) -> list[np.ndarray]:
            shape = np.shape(columns[self.states[0]])
            return [np.broadcast_to(np.asarray(a, float), shape) for a in fn(*[columns[n] for n in names])]

        return evaluate

    def rhs_function(self):
        """f(x, u) of the dynamics (parameters substituted) as a NumPy function of a state and a control array."""
        fn = sp.lambdify(self.state_symbols() + self.control_symbols(), self.rhs(numeric=True), "numpy")
        n = len(self.states)

        def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
            return np.array(fn(*x[:n], *u), dtype=float)

        return f

    def rhs(self, numeric: bool = True) -> list[sp.Expr]:
        """Dynamics in state order; with ``numeric`` the parameters are substituted."""
        f = self.dynamics()
        exprs = [f[s] for s in self.states]
        if numeric:
            subs = {sym(k): v for k, v in self.parameters().items()}
            exprs = [(e if isinstance(e, sp.Basic) else sp.Float(e)).subs(subs) for e in exprs]
        return exprs
