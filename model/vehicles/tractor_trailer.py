"""The tractor-semitrailer: the truck pulling one trailer by a hitch at signed offset h."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from model.vehicles.base import Roles, Vehicle, sym


@dataclass
class TractorTrailer(Vehicle):
    """The seed paper's truck as tractor, with one trailer hitched on or off its rear axle.

    (x, y) is the tractor's rear axle centre, theta its heading, theta1 the trailer's.
    The hitch sits at (x, y) + h (cos theta, sin theta); the trailer axle at the hitch
    minus L (cos theta1, sin theta1). Requiring the trailer axle to move along theta1
    gives theta1' = (u1 / L) (sin(theta - theta1) + (h / d) tan(phi) cos(theta - theta1)).

    Parameters
    ----------
    wheelbase : float
        d, tractor rear axle to front axle, m (> 0).
    hitch_offset : float
        h, signed distance from the tractor's rear axle to the hitch along its heading, m:
        > 0 ahead (fifth wheel), 0 on the axle, < 0 behind (tow ball).
    trailer_wheelbase : float
        L, hitch (kingpin) to the trailer axle, m (> 0).
    """

    wheelbase: float = 3.8
    hitch_offset: float = 0.5
    trailer_wheelbase: float = 7.8
    model = "tractor-trailer"
    parameter_keys = {"d": "wheelbase", "h": "hitch_offset", "L": "trailer_wheelbase"}
    positive_parameters = ("d", "L")  # h may be negative or zero; every other vehicle: all
    states = ("x", "y", "theta", "phi", "theta1")
    controls = ("u1", "u2")
    roles = Roles(trailers=("theta1",))

    def parameters(self) -> dict[str, float]:
        return {"d": float(self.wheelbase), "h": float(self.hitch_offset), "L": float(self.trailer_wheelbase)}

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta, phi, theta1 = self.state_symbols()
        u1, u2 = self.control_symbols()
        d, h, L = sym("d"), sym("h"), sym("L")
        beta = theta - theta1
        return {
            "x": u1 * sp.cos(theta),
            "y": u1 * sp.sin(theta),
            "theta": u1 * sp.tan(phi) / d,
            "phi": u2,
            "theta1": (u1 / L) * (sp.sin(beta) + (h / d) * sp.tan(phi) * sp.cos(beta)),
        }

    @property
    def lateral_acceleration(self) -> sp.Expr:
        """The tractor's: u1^2 tan(phi) / d at its rear axle, as the truck's."""
        u1, phi, d = sym("u1"), sym("phi"), sym("d")
        return u1**2 * sp.tan(phi) / d

    def outputs(self) -> dict[str, sp.Expr]:
        """``articulation`` = theta - theta1, the angle a jackknife limit bounds."""
        return {"articulation": sym("theta") - sym("theta1")}

    def body_poses(self) -> dict[str, tuple[sp.Expr, sp.Expr, sp.Expr]]:
        """The tractor's body on its rear axle; the trailer's on the trailer axle, heading theta1."""
        x, y, theta, _, theta1 = self.state_symbols()
        h, L = sym("h"), sym("L")
        trailer = (x + h * sp.cos(theta) - L * sp.cos(theta1), y + h * sp.sin(theta) - L * sp.sin(theta1), theta1)
        return {"vehicle": (x, y, theta), "trailer": trailer}
