"""A curvilinear frame along a route's centre line and a corridor's lateral extent in it (docs/map-corridor.md).

The frame is the route's centre line resampled every ``step`` metres and smoothed (a Gaussian of
``sigma`` metres along the line), so that its tangent and normal turn continuously. At each sample
the corridor's extent to the left and to the right is where the normal first leaves the corridor
(``lateral_extents``); ``conservative`` takes the least extent within a window along the line, so
that a disc whose centre projects to s stays clear of the edges beside its whole footprint.

Scene layer: shapely and numpy only; knows no vehicle and no solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.ops
from numpy.typing import NDArray

REACH = 40.0  # m: how far a normal is followed to find the corridor's edge
NUDGE = 0.02  # m: a sample on the corridor's edge is measured from this far along the line into it


@dataclass(frozen=True)
class Frame:
    """Samples of a smooth reference line: arclength, points, unit tangents and left normals.

    Attributes
    ----------
    s : ndarray (n,)
    points, tangents, normals : ndarray (n, 2)
    """

    s: NDArray[np.float64]
    points: NDArray[np.float64]
    tangents: NDArray[np.float64]
    normals: NDArray[np.float64]
    chain: float | None = None  # m: ``project`` follows a path within this arclength of its previous point

    def at(self, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Point, tangent and normal at arclengths ``s`` (linear between samples, clipped), each (..., 2)."""
        s = np.clip(np.asarray(s, float), self.s[0], self.s[-1])

        def interp(a):
            return np.stack([np.interp(s, self.s, a[:, 0]), np.interp(s, self.s, a[:, 1])], -1)

        t = interp(self.tangents)
        t /= np.linalg.norm(t, axis=-1, keepdims=True)
        return interp(self.points), t, np.stack([-t[..., 1], t[..., 0]], -1)

    def project(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Arclength of the nearest point of the (sampled) line to each point (..., 2).

        With ``chain`` (a line that passes a place twice, as a loop round a ring does) and points
        (n, ..., 2) ordered along a path: the points of row k project to the nearest point of the line
        within ``chain`` m of arclength of row k - 1's projections (row 0 and a single point: the whole line).
        """
        xy = np.asarray(xy, float)
        line = shapely.LineString(self.points)
        if self.chain is None or xy.ndim < 2:
            return np.asarray(shapely.line_locate_point(line, shapely.points(xy)))
        out = np.empty(xy.shape[:-1])
        out[0] = shapely.line_locate_point(line, shapely.points(xy[0]))
        for k in range(1, len(xy)):
            lo, hi = float(np.min(out[k - 1])) - self.chain, float(np.max(out[k - 1])) + self.chain
            lo, hi = max(lo, float(self.s[0])), min(hi, float(self.s[-1]))
            part = shapely.ops.substring(line, lo, hi)
            out[k] = lo + shapely.line_locate_point(part, shapely.points(xy[k])) if part.length > 0 else lo
        return out

    def curvature(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed curvature (1/m, > 0 turning left) at arclengths ``s``: the tangent's turn rate per metre
        at the samples, linear between them."""
        theta = np.unwrap(np.arctan2(self.tangents[:, 1], self.tangents[:, 0]))
        return np.interp(np.clip(np.asarray(s, float), self.s[0], self.s[-1]), self.s, np.gradient(theta, self.s))

    def lateral(self, xy: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed offset (m, > 0 left) of each point from the frame's point at ``s``, along its normal."""
        c, _, n = self.at(s)
        return np.sum((np.asarray(xy, float) - c) * n, axis=-1)


def frame(points: NDArray[np.float64], step: float = 0.25, sigma: float = 2.0, chain: float | None = None) -> Frame:
    """The smoothed frame of a polyline (resampled every ``step`` m, Gaussian of ``sigma`` m; ``chain``: as
    ``Frame.chain``)."""
    pts = np.asarray(points, float)
    s0 = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    s = np.linspace(0.0, s0[-1], max(int(np.ceil(s0[-1] / step)) + 1, 2))
    xy = np.column_stack([np.interp(s, s0, pts[:, 0]), np.interp(s, s0, pts[:, 1])])
    if sigma > 0:
        xy = _gaussian(xy, sigma / (s[1] - s[0]))
    d = np.gradient(xy, axis=0)
    t = d / np.linalg.norm(d, axis=1, keepdims=True)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    return Frame(s=arc, points=xy, tangents=t, normals=np.column_stack([-t[:, 1], t[:, 0]]), chain=chain)


def _gaussian(xy: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """Each column smoothed by a Gaussian of ``width`` samples; the ends are extended along their tangent."""
    half = int(np.ceil(3 * width))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / width) ** 2)
    kernel /= kernel.sum()
    k = np.arange(1, half + 1)[:, None]
    head = xy[0] - k[::-1] * (xy[1] - xy[0])
    tail = xy[-1] + k * (xy[-1] - xy[-2])
    padded = np.vstack([head, xy, tail])
    return np.column_stack([np.convolve(padded[:, i], kernel, mode="valid") for i in range(2)])


def lateral_extents(corridor, fr: Frame, reach: float = REACH) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Distances (m) along each sample's left and right normal to the corridor's edge.

    A sample on the corridor's edge (the route's two ends) is measured from the point ``NUDGE``
    metres along the line into the corridor; a sample outside it has extents 0.
    """
    edge = corridor.boundary
    origins = fr.points.copy()
    for sign in (1.0, -1.0):  # the ends lie on the corridor's edge: step along the line into it
        out = ~shapely.contains_xy(corridor, origins[:, 0], origins[:, 1])
        moved = origins + sign * NUDGE * fr.tangents
        fix = out & shapely.contains_xy(corridor, moved[:, 0], moved[:, 1])
        origins[fix] = moved[fix]
    inside = shapely.contains_xy(corridor, origins[:, 0], origins[:, 1])
    result = []
    for sign in (1.0, -1.0):
        ends = origins + sign * reach * fr.normals
        hits = shapely.intersection(shapely.linestrings(np.stack([origins, ends], axis=1)), edge)
        dist = np.where(shapely.is_empty(hits), reach, shapely.distance(shapely.points(origins), hits))
        result.append(np.where(inside, dist, 0.0))
    return result[0], result[1]


def conservative(fr: Frame, extent: NDArray[np.float64], window: float) -> NDArray[np.float64]:
    """The least ``extent`` within +-``window`` m of each sample along the line."""
    out = np.empty_like(extent)
    lo = np.searchsorted(fr.s, fr.s - window, side="left")
    hi = np.searchsorted(fr.s, fr.s + window, side="right")
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        out[i] = extent[a:b].min()
    return out


def disc_extents(corridor, fr: Frame, radius: float, step: float = 0.05,
                 reach: float = 8.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # fmt: skip
    """How far (m) a disc of ``radius`` may move from each sample along its left and right normal.

    The largest d (a multiple of ``step``, at most ``reach``) such that the disc centred at every point
    between the sample and d along the normal lies inside the corridor (its centre inside, its distance
    to the corridor's edge at least ``radius``); -1 where the disc does not fit at the sample itself.
    Unlike ``lateral_extents`` this is exact for a disc whose centre lies on the normal.
    """
    rings = [corridor] if corridor.geom_type == "Polygon" else list(corridor.geoms)
    pieces = []
    for poly in rings:
        for ring in (poly.exterior, *poly.interiors):
            xy = np.asarray(ring.coords)
            pieces.append(np.stack([xy[:-1], xy[1:]], axis=1))
    tree = shapely.STRtree(shapely.linestrings(np.concatenate(pieces)))
    d = np.arange(0.0, reach + step / 2, step)
    out = []
    for sign in (1.0, -1.0):
        pts = fr.points[:, None, :] + sign * d[None, :, None] * fr.normals[:, None, :]
        flat = pts.reshape(-1, 2)
        _, dist = tree.query_nearest(shapely.points(flat), return_distance=True, all_matches=False)
        ok = (dist >= radius) & shapely.contains_xy(corridor, flat[:, 0], flat[:, 1])
        ok = ok.reshape(pts.shape[:2])
        first_bad = np.where(ok.all(axis=1), len(d), np.argmin(ok, axis=1))
        out.append(np.where(first_bad > 0, d[np.maximum(first_bad - 1, 0)], -1.0))
    return out[0], out[1]
