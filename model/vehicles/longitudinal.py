"""Longitudinal dynamics for any vehicle: its speed control becomes the state ``v``, driven by ``a``.

docs/dynamics-format.md: for every registered model the speed control (``roles.speed``) is
replaced by the state ``v`` in the model's dynamics, and ``v' = a``; with a jerk limit also
``a' = j``. States: the model's own, in its order, then ``v`` (then ``a``); controls: ``a`` (or
``j``) in place of the speed control, the other controls unchanged. Everything else (parameters,
bodies, outputs, the lateral acceleration) is the model's, with ``v`` for its speed control.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sp

from model.vehicles.base import Vehicle, expression, sym

SPEED, ACCELERATION, JERK = "v", "a", "j"  # the contract's names


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
