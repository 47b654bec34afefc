"""Moving obstacles: another vehicle, a rectangle whose pose is known as a function of time.

``MovingVehicle`` is a ``length`` x ``width`` rectangle centred on its pose (x, y, heading) at
time t (seconds from the manoeuvre's start), kept ``safety`` metres away. The pose is either

- **sampled**, ``trajectory = ((t, x, y, heading), ...)`` with increasing t: linear between the
  samples (the heading the short way round, so 3.1 -> -3.1 turns by 0.08 rad, not 6.2), held
  before the first sample and after the last; or
- **predicted** at constant ``speed`` and ``yaw_rate`` from ``start = (x, y, heading)`` at t = 0:
  the exact arc x = x0 + v t cos(h0 + w t / 2) sinc(w t / 2), likewise y, h = h0 + w t (a
  straight line for w = 0).

The NLP keeps clear of the rectangle through ``discs(t)``: ``disc_count`` equal discs along the
long axis whose common radius covers the rectangle exactly (the rule of the vehicle bodies,
``model.vehicles.body.Body.cover`` with ``model.direct.bodies.disc_count``, whose slack
``COVER_SLACK`` this module repeats because the scene imports neither layer). Validation measures
the exact rectangle (``rectangle``, ``clearance``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike, NDArray

from model.errors import InputError
from model.vehicles.body import centred_rectangle, place_points

COVER_SLACK = 0.1  # as model.direct.bodies.COVER_SLACK: a disc reaches at most 10 % of the half-width beyond the sides


def disc_count(length: float, width: float, slack: float = COVER_SLACK) -> int:
    """The fewest equal discs along the axis whose common radius is at most (1 + slack) width / 2."""
    half = width / 2
    reach = math.sqrt(((1 + slack) * half) ** 2 - half**2)
    return max(1, math.ceil(length / (2 * reach)))


def wrap(angle: ArrayLike) -> NDArray[np.float64]:
    """Angles wrapped into [-pi, pi)."""
    return (np.asarray(angle, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def _finite(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(key, f"must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class MovingVehicle:
    """A rectangle moving on a known path: another vehicle the manoeuvre must keep clear of.

    Parameters
    ----------
    length, width : float
        The rectangle, m (> 0); ``length`` along the heading.
    safety : float
        Distance to keep from the rectangle, m (>= 0).
    trajectory : sequence of (t, x, y, heading), optional
        Samples of the pose (the rectangle's centre), t in s increasing; exactly one of
        ``trajectory`` and ``start`` is given.
    start : (x, y, heading), optional
        The pose at t = 0 of a constant-speed, constant-yaw-rate prediction.
    speed : float
        m/s along the heading (with ``start``; may be negative).
    yaw_rate : float
        rad/s (with ``start``; default 0, a straight line).
    key : str
        The scenario key the obstacle comes from, named in errors ("moving_obstacles[0]").

    Raises
    ------
    InputError
        Naming ``<key>.<field>`` for a bad value.

    Examples
    --------
    >>> car = MovingVehicle(4.5, 1.8, start=(0.0, -10.0, math.pi / 2), speed=5.0)
    >>> [round(float(v), 6) for v in car.pose(2.0)]
    [0.0, 0.0, 1.570796]
    """

    length: float
    width: float
    safety: float = 0.0
    trajectory: tuple[tuple[float, float, float, float], ...] | None = None
    start: tuple[float, float, float] | None = None
    speed: float | None = None
    yaw_rate: float = 0.0
    key: str = field(default="moving_obstacles[0]", compare=False, repr=False)

    def __post_init__(self) -> None:
        k = self.key
        for name in ("length", "width", "safety"):
            object.__setattr__(self, name, _finite(getattr(self, name), f"{k}.{name}"))
        for name in ("length", "width"):
            if getattr(self, name) <= 0:
                raise InputError(f"{k}.{name}", f"must be > 0, got {getattr(self, name):g}")
        if self.safety < 0:
            raise InputError(f"{k}.safety", f"must be >= 0, got {self.safety:g}")
        if (self.trajectory is None) == (self.start is None):
            raise InputError(k, "give either trajectory = [[t, x, y, heading], ...] or start = [x, y, heading]")
        if self.trajectory is not None:
            self._check_samples()
        else:
            self._check_prediction()

    def _check_samples(self) -> None:
        k = f"{self.key}.trajectory"
        if self.speed is not None or self.yaw_rate != 0.0:
            name = "speed" if self.speed is not None else "yaw_rate"
            raise InputError(f"{self.key}.{name}", "belongs to start = [x, y, heading], not to a trajectory")
        samples = self.trajectory
        if not isinstance(samples, list | tuple) or not samples:
            raise InputError(k, "must be one or more samples [t, x, y, heading]")
        rows = []
        for i, row in enumerate(samples):
            if not isinstance(row, list | tuple) or len(row) != 4:
                raise InputError(f"{k}[{i}]", f"must be [t, x, y, heading] (4 numbers), got {row!r}")
            rows.append(tuple(_finite(v, f"{k}[{i}]") for v in row))
        for i in range(1, len(rows)):
            if not rows[i][0] > rows[i - 1][0]:
                raise InputError(f"{k}[{i}]", f"times must increase: t = {rows[i][0]:g} after {rows[i - 1][0]:g}")
        object.__setattr__(self, "trajectory", tuple(rows))

    def _check_prediction(self) -> None:
        start = self.start
        if not isinstance(start, list | tuple) or len(start) != 3:
            raise InputError(f"{self.key}.start", f"must be [x, y, heading] (3 numbers), got {start!r}")
        object.__setattr__(self, "start", tuple(_finite(v, f"{self.key}.start") for v in start))
        if self.speed is None:
            raise InputError(f"{self.key}.speed", "missing: start = [x, y, heading] needs a speed (m/s)")
        object.__setattr__(self, "speed", _finite(self.speed, f"{self.key}.speed"))
        object.__setattr__(self, "yaw_rate", _finite(self.yaw_rate, f"{self.key}.yaw_rate"))

    # -- the pose -------------------------------------------------------------
    def _unwrapped(self) -> NDArray[np.float64]:
        """The samples' headings, each step taken the short way round (cumulative)."""
        h = np.array([row[3] for row in self.trajectory])
        return h[0] + np.concatenate([[0.0], np.cumsum(wrap(np.diff(h)))])

    def pose(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(x, y, heading) of the rectangle's centre at times ``t`` (any shape), heading unwrapped."""
        t = np.asarray(t, dtype=float)
        if self.trajectory is not None:
            s = np.array([row[0] for row in self.trajectory])
            x = np.interp(t, s, [row[1] for row in self.trajectory])
            y = np.interp(t, s, [row[2] for row in self.trajectory])
            return x, y, np.interp(t, s, self._unwrapped())
        x0, y0, h0 = self.start
        v, w = self.speed, self.yaw_rate
        mid = h0 + w * t / 2
        reach = v * t * np.sinc(w * t / (2 * np.pi))  # sinc(z / pi) = sin(z) / z
        return x0 + reach * np.cos(mid), y0 + reach * np.sin(mid), h0 + w * t

    def rate(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """d/dt of (x, y, heading) at ``t``; for samples the slope of the segment ahead (0 after the last)."""
        t = np.asarray(t, dtype=float)
        if self.trajectory is not None:
            s = np.array([row[0] for row in self.trajectory])
            values = np.array([[row[1] for row in self.trajectory], [row[2] for row in self.trajectory],
                               self._unwrapped()])  # fmt: skip
            if len(s) == 1:
                return tuple(np.zeros_like(t) for _ in range(3))
            slopes = np.diff(values, axis=1) / np.diff(s)
            seg = np.searchsorted(s, t, side="right") - 1
            inside = (seg >= 0) & (seg < len(s) - 1)
            seg = np.clip(seg, 0, len(s) - 2)
            return tuple(np.where(inside, slopes[i][seg], 0.0) for i in range(3))
        h = self.start[2] + self.yaw_rate * t
        return self.speed * np.cos(h), self.speed * np.sin(h), np.full_like(t, self.yaw_rate)

    # -- shapes ---------------------------------------------------------------
    def corners(self, t: ArrayLike) -> NDArray[np.float64]:
        """The rectangle's corners at ``t`` (shape S), shape S + (4, 2), counter-clockwise from rear right."""
        x, y, h = self.pose(t)
        return centred_rectangle(x, y, h, self.length, self.width)

    def rectangle(self, t: float):
        """The exact rectangle at time ``t``: a shapely Polygon."""
        import shapely

        return shapely.Polygon(self.corners(float(t)))

    def cover(self) -> tuple[NDArray[np.float64], float]:
        """Offsets of the cover discs ahead of the centre along the axis, and their common radius.

        ``disc_count(length, width)`` equal slices, each disc the circumcircle of one: the union
        contains the rectangle, with the least radius for that many discs on the axis.
        """
        n = disc_count(self.length, self.width)
        step = self.length / n
        return -self.length / 2 + step * (np.arange(n) + 0.5), math.hypot(step / 2, self.width / 2)

    def discs(self, t: ArrayLike) -> tuple[NDArray[np.float64], float]:
        """World-frame centres of the cover discs at ``t`` (shape S), shape S + (n, 2), and their radius."""
        offsets, radius = self.cover()
        x, y, h = self.pose(t)
        return place_points(np.column_stack([offsets, np.zeros(len(offsets))]), x, y, h), radius

    def disc_velocities(self, t: ArrayLike) -> NDArray[np.float64]:
        """d/dt of the disc centres at ``t``, shape S + (n, 2) (``rate`` carried along the axis)."""
        offsets, _ = self.cover()
        _, _, h = self.pose(t)
        vx, vy, w = self.rate(t)
        c, s = np.cos(h)[..., None], np.sin(h)[..., None]
        return np.stack([vx[..., None] - offsets * w[..., None] * s, vy[..., None] + offsets * w[..., None] * c], -1)

    # -- the obstacle protocol ------------------------------------------------
    def clearance_at(self, x: ArrayLike, y: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Signed distance of the points (x, y) at times t to the rectangle, minus ``safety`` (m; < 0 inside)."""
        cx, cy, h = self.pose(t)
        dx, dy = np.asarray(x, dtype=float) - cx, np.asarray(y, dtype=float) - cy
        along = np.abs(np.cos(h) * dx + np.sin(h) * dy) - self.length / 2
        across = np.abs(-np.sin(h) * dx + np.cos(h) * dy) - self.width / 2
        outside = np.hypot(np.maximum(along, 0.0), np.maximum(across, 0.0))
        return outside + np.minimum(np.maximum(along, across), 0.0) - self.safety

    def constraint_at(self, x: sp.Expr, y: sp.Expr, t: sp.Expr) -> list[sp.Expr]:
        """c_j(x, y, t) = |(x, y) - centre_j(t)| - (radius + safety) >= 0, one per cover disc (SymPy)."""
        offsets, radius = self.cover()
        px, py, h = self._symbolic_pose(t)
        out = []
        for a in offsets:
            cx, cy = px + float(a) * sp.cos(h), py + float(a) * sp.sin(h)
            out.append(sp.sqrt((x - cx) ** 2 + (y - cy) ** 2) - (radius + self.safety))
        return out

    def _symbolic_pose(self, t: sp.Expr) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """The pose as SymPy expressions of ``t``: Piecewise-linear samples or the exact arc."""
        if self.trajectory is None:
            x0, y0, h0 = self.start
            v, w = self.speed, self.yaw_rate
            if w == 0.0:
                return x0 + v * t * sp.cos(h0), y0 + v * t * sp.sin(h0), sp.Float(h0)
            h = h0 + w * t
            return x0 + v / w * (sp.sin(h) - math.sin(h0)), y0 - v / w * (sp.cos(h) - math.cos(h0)), h
        s = [row[0] for row in self.trajectory]
        columns = ([row[1] for row in self.trajectory], [row[2] for row in self.trajectory], self._unwrapped())
        return tuple(_piecewise_linear(t, s, list(map(float, c))) for c in columns)

    def outline(self, t: float) -> NDArray[np.float64]:
        """Drawing data: the rectangle's corners at ``t``, shape (4, 2)."""
        return self.corners(float(t))

    def path(self, t: ArrayLike) -> NDArray[np.float64]:
        """Drawing data: the centre at times ``t``, shape S + (2,)."""
        x, y, _ = self.pose(t)
        return np.stack([x, y], axis=-1)


def _piecewise_linear(t: sp.Expr, s: list[float], values: list[float]) -> sp.Expr:
    """Linear interpolation of ``values`` at the times ``s``, held outside them."""
    pieces = [(sp.Float(values[0]), t < s[0])]
    for i in range(len(s) - 1):
        slope = (values[i + 1] - values[i]) / (s[i + 1] - s[i])
        pieces.append((values[i] + slope * (t - s[i]), t < s[i + 1]))
    pieces.append((sp.Float(values[-1]), True))
    return sp.Piecewise(*pieces)
