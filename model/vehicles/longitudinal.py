"""Longitudinal dynamics for any vehicle: its speed control becomes the state ``v``, driven by ``a``.

docs/dynamics-format.md: for every registered model the speed control (``roles.speed``) is
replaced by the state ``v`` in the model's dynamics, and ``v' = a``; with a jerk limit also
``a' = j``. States: the model's own, in its order, then ``v`` (then ``a``); controls: ``a`` (or
``j``) in place of the speed control, the other controls unchanged. Everything else (parameters,
bodies, outputs, the lateral acceleration) is the model's, with ``v`` for its speed control.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
import sympy as sp

from model.vehicles.base import Vehicle, expression, sym

SPEED, ACCELERATION, JERK = "v", "a", "j"  # the contract's names
SPEED_RAMP = 0.25  # of the duration: the share at each end over which a guess's speed blends into a stated end speed


@dataclass(frozen=True)
class Longitudinal(Vehicle):
    """``base`` with the speed as the state ``v`` and the acceleration ``a`` (with ``jerk``, ``j``) as control.

    Parameters
    ----------
    base : Vehicle
        A model with a speed control (``roles.speed`` one of its controls).
    jerk : bool
        True: the acceleration is a state too, and the jerk ``j`` the control.

    Raises
    ------
    ValueError
        If ``base`` has no speed control, or already names a state or control ``v``, ``a`` or ``j``.
    """

    base: Vehicle
    jerk: bool = False

    def __post_init__(self) -> None:
        base, r = self.base, self.base.roles
        if r.speed is None or r.speed not in base.controls:
            raise ValueError(f"the {base.model} model has no speed control to integrate")
        taken = {SPEED, ACCELERATION, JERK} & (set(base.states) | set(base.controls))
        if taken:
            raise ValueError(f"the {base.model} model already names {sorted(taken)}")
        control = JERK if self.jerk else ACCELERATION
        added = (SPEED, ACCELERATION) if self.jerk else (SPEED,)
        fields = {
            "model": base.model,
            "states": base.states + added,
            "controls": tuple(control if c == r.speed else c for c in base.controls),
            "roles": replace(r, speed=SPEED, acceleration=ACCELERATION, jerk=JERK if self.jerk else None),
            "parameter_keys": base.parameter_keys,
            "positive_parameters": base.positive_parameters,
        }
        for name, value in fields.items():
            object.__setattr__(self, name, value)
        self.roles.check(self.states, self.controls)

    def _integrated(self, expr: sp.Expr) -> sp.Expr:
        """A base expression with its speed control replaced by the state ``v``."""
        return expression(expr).subs(sym(self.base.roles.speed), sym(SPEED))

    def parameters(self) -> dict[str, float]:
        return self.base.parameters()

    def dynamics(self) -> dict[str, sp.Expr]:
        out = {name: self._integrated(e) for name, e in self.base.dynamics().items()}
        out[SPEED] = sym(ACCELERATION)
        if self.jerk:
            out[ACCELERATION] = sym(JERK)
        return out

    def outputs(self) -> dict[str, sp.Expr]:
        return self.base.outputs()

    @property
    def lateral_acceleration(self) -> sp.Expr | None:
        a_lat = self.base.lateral_acceleration
        return None if a_lat is None else self._integrated(a_lat)

    def body_poses(self) -> dict[str, tuple[sp.Expr, sp.Expr, sp.Expr]]:
        return self.base.body_poses()


def integrated_speed(
    vehicle: Vehicle, speed: np.ndarray, t: np.ndarray, initial: Mapping[str, float], final: Mapping[str, float]
) -> dict[str, np.ndarray]:
    """The speed and its rates on a guess: ``roles.speed`` v, with longitudinal dynamics ``roles.acceleration`` a
    and (with a jerk limit) ``roles.jerk`` j.

    The one way every guess fills the longitudinal states (``Roles.integrated``), whichever search makes it.

    Parameters
    ----------
    vehicle : Vehicle
        Any model; without longitudinal dynamics only its speed control is returned.
    speed : ndarray
        The signed speed along the guess at the node times ``t``.
    t : ndarray
        The node times, s, increasing.
    initial, final : mapping
        The end values; where one states the speed, the guess's speed blends linearly into it over
        ``SPEED_RAMP`` of the duration at that end (a free end speed is left as ``speed`` has it).

    Returns
    -------
    dict of ndarray
        v, blended into the stated end speeds and through 0 within ``SPEED_RAMP`` / 2 of the duration either
        side of each change of direction; a and j its finite-difference derivatives (an approximate start:
        the transcription makes them consistent; 0 where v is constant).
    """
    r = vehicle.roles
    speed = np.asarray(speed, dtype=float)
    span = max(float(t[-1] - t[0]), 1e-9)
    cusps = [(t[k] + t[k + 1]) / 2 for k in np.flatnonzero(np.sign(speed[:-1]) * np.sign(speed[1:]) < 0)]
    v = speed * np.clip(
        np.min([np.abs(t - c) / (0.5 * SPEED_RAMP * span) for c in cusps], axis=0) if cusps else 1.0, 0.0, 1.0
    )
    for values, end, ramp in ((initial, 0, t - t[0]), (final, -1, t[-1] - t)):
        if r.speed in values:
            v = v + np.clip(1 - ramp / (SPEED_RAMP * span), 0.0, 1.0) * (values[r.speed] - speed[end])
    out = {r.speed: v}
    if r.acceleration is not None:
        out[r.acceleration] = _rate(v, t)
    if r.jerk is not None:
        out[r.jerk] = _rate(out[r.acceleration], t)
    return out


def _rate(values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """d(values)/dt by finite differences; exactly 0 for constant values (np.gradient on unequal steps leaves
    round-off there)."""
    return np.gradient(values, t) if np.ptp(values) > 0 else np.zeros_like(values)
