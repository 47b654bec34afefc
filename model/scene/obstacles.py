"""Circular obstacles: dist((x, y), centre) >= radius + safety."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp


@dataclass(frozen=True)
class Circle:
    """A disc of ``radius`` around ``center`` kept ``safety`` metres away."""

    center: tuple[float, float]
    radius: float
    safety: float = 0.0

    @property
    def keep_out(self) -> float:
        """R = r_obs + d_s, the radius of the forbidden disc."""
        return self.radius + self.safety

    def clearance(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Distance to the centre minus R (negative inside), metres."""
        return np.hypot(np.asarray(x) - self.center[0], np.asarray(y) - self.center[1]) - self.keep_out

    def constraint(self, x: sp.Expr, y: sp.Expr) -> sp.Expr:
        """c(x, y) = dist - R >= 0, the paper's (3) written as a function to keep >= 0."""
        return sp.sqrt((x - self.center[0]) ** 2 + (y - self.center[1]) ** 2) - self.keep_out

    def swept_angle(self, x: np.ndarray, y: np.ndarray) -> float:
        """Signed angle (rad) swept around the centre along the node polyline; > 0 is ccw."""
        a = np.unwrap(np.arctan2(np.asarray(y) - self.center[1], np.asarray(x) - self.center[0]))
        return float(a[-1] - a[0])
