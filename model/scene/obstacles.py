"""Obstacles: what the vehicle keeps clear of, static (``Circle``) or moving (``model.scene.moving``).

Every obstacle follows the ``Obstacle`` protocol: a symbolic keep-out constraint at (x, y, t),
a numeric clearance at (x, y, t) and an outline to draw at t. A ``Circle`` is the paper's
static disc, dist((x, y), centre) >= radius + safety, the same at every t.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike, NDArray


@runtime_checkable
class Obstacle(Protocol):
    """What a vehicle keeps clear of, as the problem, the validation and the figures use it."""

    safety: float

    def constraint_at(self, x: sp.Expr, y: sp.Expr, t: sp.Expr) -> list[sp.Expr]:
        """Expressions c_j(x, y, t), each to keep >= 0 (SymPy)."""
        ...

    def clearance_at(self, x: ArrayLike, y: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Signed clearance of the points (x, y) at times t, minus the safety distance (m; < 0 inside)."""
        ...

    def outline(self, t: float) -> NDArray[np.float64]:
        """The shape at time t as polygon vertices, shape (k, 2), for drawing."""
        ...


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

    def constraint_at(self, x: sp.Expr, y: sp.Expr, t: sp.Expr) -> list[sp.Expr]:
        """``[constraint(x, y)]``: a static disc is the same at every t."""
        return [self.constraint(x, y)]

    def clearance_at(self, x: ArrayLike, y: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """``clearance(x, y)`` broadcast against ``t``."""
        return np.broadcast_to(self.clearance(x, y), np.broadcast_shapes(np.shape(x), np.shape(t))).copy()

    def outline(self, t: float = 0.0, points: int = 64) -> NDArray[np.float64]:
        """The disc's edge (radius, without the safety) as ``points`` vertices."""
        a = np.linspace(0.0, 2 * np.pi, points, endpoint=False)
        return np.column_stack([self.center[0] + self.radius * np.cos(a), self.center[1] + self.radius * np.sin(a)])

    def swept_angle(self, x: np.ndarray, y: np.ndarray) -> float:
        """Signed angle (rad) swept around the centre along the node polyline; > 0 is ccw."""
        a = np.unwrap(np.arctan2(np.asarray(y) - self.center[1], np.asarray(x) - self.center[0]))
        return float(a[-1] - a[0])
