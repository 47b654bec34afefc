"""The tricycle: a driven, steered front wheel; (x, y) is the rear axle centre."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from model.vehicles.base import sym
from model.vehicles.truck import Truck


@dataclass
class Tricycle(Truck):
    """Front-wheel-driven car-like vehicle: u1 is the speed of the steered front wheel.

    The rear axle centre moves at u1 cos(phi), so unlike the truck the speed along the
    heading falls as the steering angle grows (roundabout-format.md, "Models").

    Parameters
    ----------
    wheelbase : float
        d, rear axle to front axle, m.
    """

    model = "tricycle"  # states, controls, wheelbase and its parameter as the truck's

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta, phi = self.state_symbols()
        u1, u2 = self.control_symbols()
        d = sym("d")
        return {
            "x": u1 * sp.cos(phi) * sp.cos(theta),
            "y": u1 * sp.cos(phi) * sp.sin(theta),
            "theta": u1 * sp.sin(phi) / d,
            "phi": u2,
        }

    @property
    def lateral_acceleration(self) -> sp.Expr:
        """u1^2 sin(phi) cos(phi) / d: the rear axle's speed u1 cos(phi) times the yaw rate u1 sin(phi) / d."""
        u1, phi, d = sym("u1"), sym("phi"), sym("d")
        return u1**2 * sp.sin(phi) * sp.cos(phi) / d
