"""The vehicle base class: state and control names, their roles, and SymPy dynamics, written once.

A new vehicle is one small subclass; the Pyomo transcription, the validator and
the Pontryagin engine all read ``states``, ``controls`` and ``dynamics()``. Everything that
needs to know *which* state is the heading or which control the speed (the guesses, the
smooth routes, the plant's disturbances, the tracking controller, the plots) reads the
vehicle's ``roles`` (``Roles``), never a literal name, so a model may name and order its
states and controls as it likes.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import lru_cache
from typing import ClassVar

import numpy as np
import sympy as sp


@dataclass(frozen=True)
class Roles:
    """What each of a vehicle's states and controls means, by name; None where the model has none.

    The defaults are the seed paper's truck's names, so a model that uses them declares nothing.

    Parameters
    ----------
    x, y : str
        The states of the reference point's position, m (the rear axle centre).
    heading : str or None
        The state of the reference body's heading, rad (it wraps: an angle compared modulo 2 pi).
    steering : str or None
        The state of the steering angle, rad (None: the model does not steer, e.g. the unicycle).
    speed : str or None
        The control that sets the speed along the path (the rear axle's, or the steered wheel's); with
        longitudinal dynamics (``Longitudinal``) the state ``v`` that is that speed.
    steering_rate : str or None
        The control that is the steering angle's rate, rad/s.
    turn_rate : str or None
        The control that is the heading's rate, rad/s, for a model without a steering angle.
    trailers : tuple of str
        The states of the trailers' headings, rad, first trailer first.
    acceleration : str or None
        The speed's rate, m/s^2: a control, or with a jerk limit a state (None: the speed is a control).
    jerk : str or None
        The control that is the acceleration's rate, m/s^3 (None: no jerk limit).
    """

    x: str = "x"
    y: str = "y"
    heading: str | None = "theta"
    steering: str | None = "phi"
    speed: str | None = "u1"
    steering_rate: str | None = "u2"
    turn_rate: str | None = None
    trailers: tuple[str, ...] = ()
    acceleration: str | None = None
    jerk: str | None = None

    CONTROL_ROLES: ClassVar[tuple[str, ...]] = ("speed", "steering_rate", "turn_rate", "jerk")
    INTEGRATED_BY: ClassVar[dict[str, str]] = {"speed": "acceleration", "acceleration": "jerk"}

    @property
    def position(self) -> tuple[str, str]:
        """(x, y): the reference point's position states."""
        return (self.x, self.y)

    @property
    def integrated(self) -> tuple[str, ...]:
        """The states that longitudinal dynamics add, in order: the speed (with ``acceleration`` set), then the
        acceleration (with ``jerk`` set); () while the speed is a control.

        One rule for them everywhere (docs/dynamics-format.md): free at either end unless a scenario states them,
        and part of no pose (no body's position or heading depends on them).
        """
        driven = (("speed", "acceleration"), ("acceleration", "jerk"))
        return tuple(getattr(self, state) for state, by in driven if getattr(self, by) is not None)

    @property
    def turning(self) -> str | None:
        """The control that turns the vehicle: the steering rate, else the turn rate (None: neither)."""
        return self.steering_rate if self.steering_rate is not None else self.turn_rate

    @property
    def headings(self) -> tuple[str, ...]:
        """The heading states, the vehicle's and each trailer's: the states that are angles modulo 2 pi."""
        return tuple(s for s in (self.heading, *self.trailers) if s is not None)

    def check(self, states: tuple[str, ...], controls: tuple[str, ...]) -> None:
        """Raise TypeError naming the first role that is not one of the model's states or controls,
        or that names what another role names."""
        seen: dict[str, str] = {}
        for role in fields(self):
            names = getattr(self, role.name)
            kind = controls if role.name in self.CONTROL_ROLES else states
            for name in names if isinstance(names, tuple) else (names,):
                if name is None:
                    continue
                if role.name in self.INTEGRATED_BY:  # a state when the role that drives it is set
                    kind = states if getattr(self, self.INTEGRATED_BY[role.name]) is not None else controls
                if name not in kind:
                    which = "controls" if kind is controls else "states"
                    raise TypeError(f"Roles.{role.name} = {name!r} is not one of the {which} {kind}")
                if name in seen:
                    raise TypeError(f"Roles.{role.name} = {name!r} is already Roles.{seen[name]}")
                seen[name] = role.name


def sym(name: str) -> sp.Symbol:
    """The project's one way of naming a real SymPy symbol."""
    return sp.Symbol(name, real=True)


def expression(value: object) -> sp.Expr:
    """A SymPy expression from a SymPy object or a number, never from a string (nothing is parsed).

    Raises
    ------
    sympy.SympifyError
        For anything else (a string included): expressions are built by the vehicles and costs, never read.
    """
    if isinstance(value, sp.Basic):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise sp.SympifyError(value, "not a SymPy expression or a number (nothing is parsed)")
    return sp.Integer(value) if isinstance(value, int) else sp.Float(value)


class Vehicle:
    """Base class: subclasses set ``states``, ``controls``, ``dynamics`` and (other names) ``roles``.

    ``roles`` says which state is the position, the heading, the steering angle and each
    trailer's heading, and which control the speed and the steering (or turn) rate; it is
    checked against ``states`` and ``controls`` when the subclass is defined (TypeError).
    """

    model: str = ""
    states: tuple[str, ...] = ()
    controls: tuple[str, ...] = ()
    roles: Roles = Roles()
    parameter_keys: dict[str, str] = {}  # parameter symbol -> its key in a scenario's [vehicle]
    positive_parameters: tuple[str, ...] | None = None  # symbols that must be > 0 (None: all of them)

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if cls.states:
            cls.roles.check(cls.states, cls.controls)

    @property
    def position(self) -> tuple[str, str]:
        """The reference point's position states, ``roles.position``."""
        return self.roles.position

    @property
    def integrated_states(self) -> tuple[str, ...]:
        """The longitudinal dynamics' states (``roles.integrated``: v, and a with a jerk limit); () without them."""
        return tuple(s for s in self.roles.integrated if s in self.states)

    @property
    def pose_states(self) -> tuple[str, ...]:
        """Every state but ``integrated_states``, in state order: what a start fixes (the position, the headings,
        the steering angle and any other state of the model)."""
        return tuple(s for s in self.states if s not in self.roles.integrated)

    def parameters(self) -> dict[str, float]:
        """Numeric values of the model's parameters, keyed by symbol name."""
        return {}

    def parameter_values(self) -> dict[str, float]:
        """The parameters' values by their scenario keys (``wheelbase``, ``hitch_offset``,
        ``trailer_wheelbase``): what a guess or a study asks for, whatever the model's symbols."""
        values = self.parameters()
        return {key: values[name] for name, key in self.parameter_keys.items()}

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
        """Reference point (x, y) and heading of each body that can be attached, by body name (none
        without a heading)."""
        if self.roles.heading is None:
            return {}
        px, py = self.position
        return {"vehicle": (sym(px), sym(py), sym(self.roles.heading))}

    def reference_speed(self) -> sp.Expr:
        """The reference point's speed per unit of the speed control: |(x', y')| with ``roles.speed`` = 1
        and the other controls 0, simplified; a SymPy expression of the states and the parameters
        (1 for the truck, |cos(phi)| for the tricycle, whose speed control is the front wheel's)."""
        f, r = self.dynamics(), self.roles
        others = {sym(c): 0 for c in self.controls if c != r.speed}
        return _speed_norm(f[r.x].subs(others), f[r.y].subs(others), sym(r.speed))

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
        name -> array; each result broadcast to the shape of the first state. Nothing is parsed (``expression``)."""
        values = {sym(k): v for k, v in self.parameters().items()}
        fn = sp.lambdify([sym(n) for n in names], [expression(e).subs(values) for e in exprs], "numpy")

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


@lru_cache(maxsize=64)
def _speed_norm(fx: sp.Expr, fy: sp.Expr, speed: sp.Symbol) -> sp.Expr:
    """sqrt(fx^2 + fy^2) at ``speed`` = 1, the square trigonometrically simplified (cached).

    ``trigsimp`` of the square, not ``simplify`` of the root: the same 1 or |cos(phi)| for every vehicle
    model here, in 0.05 s instead of 0.35 s of a solve process (``simplify`` imports sympy.physics.units).
    """
    return sp.sqrt(sp.trigsimp((fx**2 + fy**2).subs(speed, 1)))  # SymPy expressions (``.subs`` made them)
