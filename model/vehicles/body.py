"""Rectangular bodies fixed to an axle, and their cover by equal discs.

A body is the rectangle a vehicle (or its trailer) occupies, fixed to the rear axle (the
trailer axle) whose centre is the reference point; roundabout-format.md, "Bodies". The NLP
keeps a body inside its allowed region through the n discs of ``cover(n)``, which contain
the rectangle exactly: no point of the body lies outside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from model.errors import InputError


class Cover(NamedTuple):
    """n equal discs covering a body, in the body's frame.

    Attributes
    ----------
    offsets : ndarray, shape (n,)
        Distances of the disc centres ahead of the reference point along the body's axis, m
        (negative: behind it).
    radius : float
        The common radius, m: sqrt((length / (2 n))^2 + (width / 2)^2), the least radius with
        which n discs cover the rectangle.
    """

    offsets: NDArray[np.float64]
    radius: float


@dataclass(frozen=True)
class Body:
    """A rectangle fixed to an axle; its reference point is that axle's centre.

    Parameters
    ----------
    length : float
        Bumper to bumper, m (> 0).
    width : float
        m (> 0).
    rear_overhang : float
        Reference axle to the rear end, m (0 <= rear_overhang < length).
    key : str
        The scenario table the body comes from, named in errors: "vehicle.body" (default)
        or "vehicle.trailer_body".

    Raises
    ------
    InputError
        ``<key>.length``, ``<key>.width`` or ``<key>.rear_overhang`` out of range.

    Examples
    --------
    >>> body = Body(length=8.0, width=2.5, rear_overhang=1.5)
    >>> body.front_overhang(wheelbase=5.0)
    1.5
    >>> body.corners(0.0, 0.0, 0.0).tolist()
    [[-1.5, -1.25], [6.5, -1.25], [6.5, 1.25], [-1.5, 1.25]]
    """

    length: float
    width: float
    rear_overhang: float
    key: str = field(default="vehicle.body", compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("length", "width", "rear_overhang"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise InputError(f"{self.key}.{name}", f"must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        for name in ("length", "width"):
            if getattr(self, name) <= 0:
                raise InputError(f"{self.key}.{name}", f"must be > 0, got {getattr(self, name)}")
        if not 0 <= self.rear_overhang < self.length:
            raise InputError(
                f"{self.key}.rear_overhang",
                f"must satisfy 0 <= rear_overhang < length = {self.length}, got {self.rear_overhang}",
            )

    @property
    def front(self) -> float:
        """Distance from the reference point to the front end along the axis, m."""
        return self.length - self.rear_overhang

    def front_overhang(self, wheelbase: float) -> float:
        """Front axle (for a trailer: the hitch) to the front end, m; negative if the body ends behind it."""
        return self.front - wheelbase

    def outline(self) -> NDArray[np.float64]:
        """The corners in the body frame (x ahead, y left), counter-clockwise from rear right, shape (4, 2)."""
        r, f, w = -self.rear_overhang, self.front, self.width / 2
        return np.array([[r, -w], [f, -w], [f, w], [r, w]])

    def corners(self, x: ArrayLike, y: ArrayLike, heading: ArrayLike) -> NDArray[np.float64]:
        """The corners in the world frame, vectorised over nodes.

        Parameters
        ----------
        x, y, heading : array_like
            Reference point and heading (rad), broadcast against each other (shape S).

        Returns
        -------
        ndarray, shape S + (4, 2)
            Counter-clockwise from the rear right corner.
        """
        return place_points(self.outline(), x, y, heading)

    def cover(self, n: int) -> Cover:
        """n equal discs along the axis whose union contains the rectangle.

        The rectangle is cut into n equal slices; each disc is the circumcircle of one
        slice, so the radius is the least possible for n discs centred on the axis.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise InputError(f"{self.key}.discs", f"must be an integer >= 1, got {n!r}")
        step = self.length / n
        offsets = -self.rear_overhang + step * (np.arange(n) + 0.5)
        return Cover(offsets=offsets, radius=math.hypot(step / 2, self.width / 2))

    def discs(self, x: ArrayLike, y: ArrayLike, heading: ArrayLike, n: int) -> tuple[NDArray[np.float64], float]:
        """World-frame centres of the n discs of ``cover(n)``, shape S + (n, 2), and their common radius."""
        cover = self.cover(n)
        local = np.column_stack([cover.offsets, np.zeros(n)])
        return place_points(local, x, y, heading), cover.radius


def place_points(local: NDArray[np.float64], x: ArrayLike, y: ArrayLike, heading: ArrayLike) -> NDArray[np.float64]:
    """Rotate body-frame points (k, 2) by heading and translate them to (x, y): shape S + (k, 2)."""
    x, y, heading = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, heading)))
    c, s = np.cos(heading)[..., None], np.sin(heading)[..., None]
    px = x[..., None] + c * local[:, 0] - s * local[:, 1]
    py = y[..., None] + s * local[:, 0] + c * local[:, 1]
    return np.stack([px, py], axis=-1)


def centred_rectangle(
    x: ArrayLike, y: ArrayLike, heading: ArrayLike, length: float, width: float
) -> NDArray[np.float64]:
    """Corners, shape S + (4, 2), counter-clockwise from rear right, of a rectangle centred at (x, y).

    Another vehicle's rectangle (a moving obstacle, a traffic.csv row), ``length`` x ``width``.
    """
    half_l, half_w = length / 2, width / 2
    local = np.array([[-half_l, -half_w], [half_l, -half_w], [half_l, half_w], [-half_l, half_w]])
    return place_points(local, x, y, heading)
