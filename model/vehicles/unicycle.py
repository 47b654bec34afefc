"""The unicycle: speed and turn rate as controls."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from model.vehicles.base import Roles, Vehicle, sym


@dataclass
class Unicycle(Vehicle):
    """Unicycle (Dubins-like without a speed floor): speed u1 and turn rate u2."""

    model = "unicycle"
    states = ("x", "y", "theta")
    controls = ("u1", "u2")
    roles = Roles(steering=None, steering_rate=None, turn_rate="u2")  # no steering angle: u2 turns it

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta = self.state_symbols()
        u1, u2 = self.control_symbols()
        return {"x": u1 * sp.cos(theta), "y": u1 * sp.sin(theta), "theta": u2}

    @property
    def lateral_acceleration(self) -> sp.Expr:
        """u1 u2: the speed times the turn rate."""
        return sym("u1") * sym("u2")
