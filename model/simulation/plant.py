"""The disturbed plant: the scenario's own vehicle model with the disturbances of the contract.

The equations are the vehicle's SymPy dynamics (written once in ``model.vehicles``), changed by
substitution only (docs/closed-loop-format.md):

- ``u1 -> g u1`` in every state derivative (g = ``speed_gain``; u1 the vehicle's ``roles.speed``);
- ``phi -> phi + b`` in every state derivative except ``phi'`` itself (b = ``steering_bias``; phi
  the ``roles.steering``); the unicycle has no steering angle, so it takes no bias (the parser
  refuses one);
- ``+ w_x``, ``+ w_y`` on the derivatives of the position states (w = ``drift``);
- the length parameters (d, and for the trailer L, h) at the plant's true values.

One sample is integrated with the controls held (zero-order hold) by ``scipy.integrate.solve_ivp``
(DOP853, rtol = atol = 1e-10).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from model.problem.closed_loop import Disturbance
from model.vehicles import Vehicle, expression, sym

RTOL = ATOL = 1e-10
METHOD = "DOP853"
HEADING_NOISE = 0.1  # the measured heading's (roles.heading) noise is noise / 10 rad


def plant_parameters(vehicle: Vehicle, disturbance: Disturbance) -> dict[str, float]:
    """The plant's true parameter values by symbol name: the model's, overridden by ``disturbance.wheelbase``."""
    values = dict(vehicle.parameters())
    by_key = {key: name for name, key in vehicle.parameter_keys.items()}
    for key, val in disturbance.wheelbase.items():
        if key not in by_key:
            raise ValueError(f"the {vehicle.model} model has no parameter {key!r}")
        values[by_key[key]] = float(val)
    return values


def plant_rhs(vehicle: Vehicle, disturbance: Disturbance) -> list[sp.Expr]:
    """The plant's state derivatives in state order (SymPy, parameters substituted).

    Raises
    ------
    ValueError
        For a steering bias on a model without a steering angle ``phi``.
    """
    f, r = vehicle.dynamics(), vehicle.roles
    u1 = sym(r.speed)
    if disturbance.steering_bias != 0 and r.steering is None:
        raise ValueError(f"the {vehicle.model} model has no steering angle phi: a steering bias cannot apply")
    params = {sym(k): v for k, v in plant_parameters(vehicle, disturbance).items()}
    drift = dict(zip(vehicle.position, disturbance.drift, strict=True))
    out = []
    for name in vehicle.states:
        expr = expression(f[name]).subs(u1, disturbance.speed_gain * u1, simultaneous=True)
        if r.steering is not None and name != r.steering:
            expr = expr.subs(sym(r.steering), sym(r.steering) + disturbance.steering_bias)
        out.append(expr.subs(params) + drift.get(name, 0.0))
    return out


class Plant:
    """The scenario's vehicle model with the contract's disturbances, one sample at a time.

    Parameters
    ----------
    vehicle : Vehicle
        The model the controllers use (truck, unicycle, tricycle, tractor-trailer).
    disturbance : Disturbance
        How the plant differs from it (speed gain, steering bias, drift, true lengths); the
        delay and the noise act in the loop and in ``measure``.
    sample_time : float
        The zero-order hold's sample time h, s.

    Examples
    --------
    >>> plant = Plant(Truck(wheelbase=5.0), Disturbance(speed_gain=0.95), 0.1)   # doctest: +SKIP
    >>> plant.step(np.zeros(4), np.array([10.0, 0.0]))                           # doctest: +SKIP
    array([0.95, 0.  , 0.  , 0.  ])
    """

    def __init__(self, vehicle: Vehicle, disturbance: Disturbance, sample_time: float):
        self.vehicle = vehicle
        self.disturbance = disturbance
        self.sample_time = float(sample_time)
        self.expressions = plant_rhs(vehicle, disturbance)
        args = vehicle.state_symbols() + vehicle.control_symbols()
        self._f = sp.lambdify(args, self.expressions, "numpy")
        self._n = len(vehicle.states)
        self._noise_scale = np.array([_noise_scale(vehicle, s) for s in vehicle.states])

    def rhs(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The plant's state derivative at state ``x`` under controls ``u``."""
        return np.array(self._f(*x, *u), dtype=float)

    def step(self, x: np.ndarray, u: np.ndarray, duration: float | None = None) -> np.ndarray:
        """The state after one sample (``duration``, default the sample time) with ``u`` held."""
        return held_step(self.rhs, x, u, self.sample_time if duration is None else float(duration))

    def start(self, x: np.ndarray) -> np.ndarray:
        """The plant's state at the model's state ``x``: the same (a plant of another model converts it)."""
        return np.asarray(x, dtype=float).copy()

    def state(self, z: np.ndarray) -> np.ndarray:
        """The model's state at the plant's state ``z``: the same."""
        return np.asarray(z, dtype=float).copy()

    def extras(self, z: np.ndarray, u: np.ndarray) -> dict[str, float]:
        """Quantities of the plant beyond the model's state (closed_loop.csv's ``plant_*`` columns): none."""
        return {}

    def measure(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The measured state: x, y with noise of std ``noise`` (m), theta with ``noise / 10`` (rad).

        The other states (steering angle, trailer heading) are measured exactly. Without noise the
        generator is not drawn from.
        """
        x = np.asarray(x, dtype=float)
        if self.disturbance.noise == 0:
            return x.copy()
        return x + self.disturbance.noise * self._noise_scale * rng.standard_normal(self._n)


def _noise_scale(vehicle: Vehicle, state: str) -> float:
    if state in vehicle.position:
        return 1.0
    return HEADING_NOISE if state == vehicle.roles.heading else 0.0


__all__ = ["Plant", "plant_parameters", "plant_rhs"]


def held_step(rhs, x: np.ndarray, u: np.ndarray, h: float, tol: float = RTOL) -> np.ndarray:
    """The state ``x`` after ``h`` seconds of ``rhs(x, u)`` with ``u`` held (DOP853, rtol = atol = ``tol``)."""
    from scipy.integrate import solve_ivp

    x, u = np.asarray(x, dtype=float), np.asarray(u, dtype=float)
    if h <= 0:
        return x.copy()
    sol = solve_ivp(lambda _t, z: rhs(z, u), (0.0, h), x, method=METHOD, rtol=tol, atol=tol)
    if not sol.success:
        raise RuntimeError(f"plant integration failed: {sol.message}")
    return sol.y[:, -1]
