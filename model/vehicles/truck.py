"""The seed paper's car-like truck, system (1)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from model.vehicles.base import Vehicle, sym


@dataclass
class Truck(Vehicle):
    """The seed paper's car-like truck, system (1); ``wheelbase`` is d in metres."""

    wheelbase: float = 0.1
    model = "truck"
    parameter_keys = {"d": "wheelbase"}
    states = ("x", "y", "theta", "phi")
    controls = ("u1", "u2")

    def parameters(self) -> dict[str, float]:
        return {"d": float(self.wheelbase)}

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta, phi = self.state_symbols()
        u1, u2 = self.control_symbols()
        d = sym("d")
        return {
            "x": u1 * sp.cos(theta),
            "y": u1 * sp.sin(theta),
            "theta": u1 * sp.tan(phi) / d,
            "phi": u2,
        }

    @property
    def lateral_acceleration(self) -> sp.Expr:
        """u1^2 tan(phi) / d: the rear axle's speed u1 times the yaw rate u1 tan(phi) / d."""
        u1, phi, d = sym("u1"), sym("phi"), sym("d")
        return u1**2 * sp.tan(phi) / d
