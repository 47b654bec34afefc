"""Exact plane geometry for road regions: pieces, shapes, regions and the signed clearance of a body.

A region is a CSG ``Shape`` (discs and convex polygons joined by ``Union`` and ``Difference``) with
an exact point test. Its boundary is found exactly, once, as ``Edge`` objects: each a named
primitive (a half-plane or a circle with its inside/outside sense) with the ``Segment`` and ``Arc``
pieces along which that primitive is the region's boundary. Distances are computed on these exact
pieces, never on polygons. ``Region.polygon`` is traced along those pieces (arcs as inscribed
polylines within ``CIRCLE_TOL``), for drawing and export; ``Shape.polygon`` (an overlay of the
shape's polygons) serves the overlap checks.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

TWO_PI = 2.0 * math.pi
CIRCLE_TOL = 1e-4  # m: largest distance between a circle and its polygon (vertices on the circle)
SIDE_STEP = 1e-7  # m: offset of the two probes that decide whether a piece bounds the region
SAMPLE_STEP = 1e-2  # m: spacing of the body-edge samples when an encroachment depth is measured
GRID = 1e-9  # m: precision grid of the polygon overlays (closes the slits of nearly collinear shared edges)
CUT_GAP = 1e-10  # m (rad on circles): split points closer than this are one point

Point2 = tuple[float, float]


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped into (-pi, pi]."""
    w = math.remainder(angle, TWO_PI)
    return math.pi if w <= -math.pi else w


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


# --------------------------------------------------------------------------- pieces


@dataclass(frozen=True)
class Segment:
    """A straight boundary piece from ``start`` to ``end``; the region it bounds lies on its left."""

    start: Point2
    end: Point2


@dataclass(frozen=True)
class Arc:
    """A boundary piece on the circle (``center``, ``radius``), ccw from angle ``start`` to ``end``.

    ``0 < end - start <= 2 pi``; ``inside`` is True when the region lies inside the circle.
    """

    center: Point2
    radius: float
    start: float
    end: float
    inside: bool

    def point(self, angle: float) -> np.ndarray:
        """The point of the circle at polar ``angle``."""
        return np.array(self.center) + self.radius * np.array([math.cos(angle), math.sin(angle)])

    def covers(self, angles: np.ndarray) -> np.ndarray:
        """Whether the polar ``angles`` (radians) lie within the arc."""
        return np.mod(np.asarray(angles) - self.start, TWO_PI) <= (self.end - self.start) + 1e-14


def point_segment_distance(p: np.ndarray, a: Sequence[float], b: Sequence[float]) -> np.ndarray:
    """Distances from the points ``p`` (n, 2) to the segment ``a``-``b``."""
    p, a, b = np.atleast_2d(np.asarray(p, float)), np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0.0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.hypot(*(p - a - t[:, None] * ab).T)


def point_arc_distance(p: np.ndarray, arc: Arc) -> np.ndarray:
    """Distances from the points ``p`` (n, 2) to ``arc``."""
    v = np.atleast_2d(np.asarray(p, float)) - np.asarray(arc.center)
    rho = np.hypot(*v.T)
    on = arc.covers(np.arctan2(v[:, 1], v[:, 0]))
    p = v + np.asarray(arc.center)
    to_ends = np.minimum(*(np.hypot(*(p - arc.point(angle)).T) for angle in (arc.start, arc.end)))
    return np.where(on, np.abs(rho - arc.radius), to_ends)


def point_piece_distance(p: np.ndarray, piece: Segment | Arc) -> np.ndarray:
    """Distances from the points ``p`` (n, 2) to a boundary piece."""
    if isinstance(piece, Segment):
        return point_segment_distance(p, piece.start, piece.end)
    return point_arc_distance(p, piece)


def line_circle_params(p0: Sequence[float], d: Sequence[float], center: Sequence[float], radius: float) -> list[float]:
    """Parameters t of the points p0 + t d (``d`` a unit vector) on the circle; a tangent gives one."""
    fx, fy = float(p0[0]) - float(center[0]), float(p0[1]) - float(center[1])
    b = fx * float(d[0]) + fy * float(d[1])
    ff = fx * fx + fy * fy
    disc = b * b - (ff - radius * radius)
    tiny = 1e-14 * max(radius * radius, ff, 1.0)
    if disc < -tiny:
        return []
    if disc <= tiny:
        return [-b]
    root = math.sqrt(disc)
    return [-b - root, -b + root]


def circle_circle_points(c1: Sequence[float], r1: float, c2: Sequence[float], r2: float) -> list[np.ndarray]:
    """The common points of two circles (one for tangent circles, none for equal or disjoint ones)."""
    c1, c2 = np.asarray(c1, float), np.asarray(c2, float)
    v = c2 - c1
    dist = math.hypot(*v)
    tiny = 1e-12 * max(r1, r2, 1.0)
    if dist < tiny or dist > r1 + r2 + tiny or dist < abs(r1 - r2) - tiny:
        return []
    a = (r1 * r1 - r2 * r2 + dist * dist) / (2.0 * dist)
    h2 = r1 * r1 - a * a
    e = v / dist
    base = c1 + a * e
    if h2 <= (tiny * max(r1, r2)):
        return [base]
    h = math.sqrt(h2)
    normal = np.array([-e[1], e[0]])
    return [base + h * normal, base - h * normal]


def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    den = dx * dx + dy * dy
    t = 0.0 if den == 0.0 else min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / den))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def _covers(arc: Arc, angle: float) -> bool:
    return (angle - arc.start) % TWO_PI <= (arc.end - arc.start) + 1e-14


def _point_arc(px: float, py: float, arc: Arc) -> float:
    cx, cy = arc.center
    if _covers(arc, math.atan2(py - cy, px - cx)):
        return abs(math.hypot(px - cx, py - cy) - arc.radius)
    r = arc.radius
    return min(math.hypot(px - cx - r * math.cos(a), py - cy - r * math.sin(a)) for a in (arc.start, arc.end))


def _point_piece(px: float, py: float, piece: Segment | Arc) -> float:
    if isinstance(piece, Segment):
        return _point_segment(px, py, *piece.start, *piece.end)
    return _point_arc(px, py, piece)


def segment_segment_distance(
    a0: Sequence[float], a1: Sequence[float], b0: Sequence[float], b1: Sequence[float]
) -> float:
    """Distance between the segments a0-a1 and b0-b1 (0 where they cross)."""
    (ax, ay), (bx, by), (cx, cy), (dx, dy) = a0, a1, b0, b1
    o1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    o2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    o3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    o4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    if o1 * o2 < 0.0 and o3 * o4 < 0.0:
        return 0.0
    return min(
        _point_segment(ax, ay, cx, cy, dx, dy),
        _point_segment(bx, by, cx, cy, dx, dy),
        _point_segment(cx, cy, ax, ay, bx, by),
        _point_segment(dx, dy, ax, ay, bx, by),
    )


def segment_arc_distance(a0: Sequence[float], a1: Sequence[float], arc: Arc) -> float:
    """Exact distance between the segment a0-a1 and ``arc`` (0 where they meet).

    The minimum lies at a meeting point, at an end of either piece, or where the arc's normal is
    the segment's normal (the arc points c +- r n); all are candidates.
    """
    (ax, ay), (bx, by) = a0, a1
    (cx, cy), r = arc.center, arc.radius
    length = math.hypot(bx - ax, by - ay)
    if length == 0.0:
        return _point_arc(ax, ay, arc)
    ux, uy = (bx - ax) / length, (by - ay) / length
    for t in line_circle_params((ax, ay), (ux, uy), arc.center, r):
        if -1e-12 <= t <= length + 1e-12 and _covers(arc, math.atan2(ay + t * uy - cy, ax + t * ux - cx)):
            return 0.0
    best = min(_point_arc(ax, ay, arc), _point_arc(bx, by, arc))
    angles = [arc.start, arc.end] + [a for a in (math.atan2(ux, -uy), math.atan2(-ux, uy)) if _covers(arc, a)]
    for a in angles:
        best = min(best, _point_segment(cx + r * math.cos(a), cy + r * math.sin(a), ax, ay, bx, by))
    return best


# --------------------------------------------------------------------------- shapes


@dataclass(frozen=True)
class LineCurve:
    """A named straight boundary candidate: the points ``point + t * direction`` for t in ``extent``."""

    name: str
    point: Point2
    direction: Point2
    extent: tuple[float, float]


@dataclass(frozen=True)
class CircleCurve:
    """A named circular boundary candidate."""

    name: str
    center: Point2
    radius: float


def circle_points(center: Sequence[float], radius: float, tol: float = CIRCLE_TOL) -> np.ndarray:
    """Vertices on the circle, spaced so that the polygon stays within ``tol`` of the circle."""
    n = 8 if tol >= radius else max(8, math.ceil(math.pi / math.acos(1.0 - tol / radius)))
    phi = np.linspace(0.0, TWO_PI, n, endpoint=False)
    return np.asarray(center, float) + radius * np.column_stack([np.cos(phi), np.sin(phi)])


class Shape:
    """A closed plane set with an exact point test, a polygon and its candidate boundary curves."""

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Exact membership of the points ``xy`` (n, 2)."""
        raise NotImplementedError

    def polygon(self, tol: float = CIRCLE_TOL) -> BaseGeometry:
        """A shapely polygon, circles within ``tol``."""
        raise NotImplementedError

    def curves(self) -> list[LineCurve | CircleCurve]:
        """Every named curve on which the boundary may lie."""
        raise NotImplementedError


@dataclass(frozen=True)
class Disc(Shape):
    """The closed disc of ``radius`` around ``center``; its circle is called ``name``."""

    center: Point2
    radius: float
    name: str

    def contains(self, xy: np.ndarray) -> np.ndarray:
        v = np.atleast_2d(xy) - np.asarray(self.center)
        return v[:, 0] ** 2 + v[:, 1] ** 2 <= self.radius**2

    def polygon(self, tol: float = CIRCLE_TOL) -> BaseGeometry:
        if self.radius <= 0.0:
            return Polygon()
        return Polygon(circle_points(self.center, self.radius, tol))

    def curves(self) -> list[LineCurve | CircleCurve]:
        return [CircleCurve(self.name, self.center, self.radius)] if self.radius > 0.0 else []


@dataclass(frozen=True)
class ConvexPolygon(Shape):
    """A convex polygon; ``names[k]`` names the side from ``vertices[k]`` to ``vertices[k + 1]``.

    Either orientation may be given; the vertices are stored counter-clockwise.
    """

    vertices: tuple[Point2, ...]
    names: tuple[str, ...]

    def __post_init__(self):
        v = np.asarray(self.vertices, float)
        n = len(v)
        if float(np.sum(_cross(v, np.roll(v, -1, axis=0)))) < 0.0:
            object.__setattr__(self, "vertices", tuple(map(tuple, v[::-1])))
            object.__setattr__(self, "names", tuple(self.names[(n - 2 - m) % n] for m in range(n)))
        else:
            object.__setattr__(self, "vertices", tuple(map(tuple, v)))

    def contains(self, xy: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(xy)
        v = np.asarray(self.vertices)
        ok = np.ones(len(p), bool)
        for a, b in zip(v, np.roll(v, -1, axis=0), strict=True):
            ok &= _cross(b - a, p - a) >= 0.0
        return ok

    def polygon(self, tol: float = CIRCLE_TOL) -> BaseGeometry:
        return Polygon(self.vertices)

    def curves(self) -> list[LineCurve | CircleCurve]:
        v = np.asarray(self.vertices)
        out = []
        for a, b, name in zip(v, np.roll(v, -1, axis=0), self.names, strict=True):
            length = math.hypot(*(b - a))
            out.append(LineCurve(name, tuple(a), tuple((b - a) / length), (0.0, length)))
        return out


@dataclass(frozen=True)
class Union(Shape):
    """The union of ``parts``."""

    parts: tuple[Shape, ...]

    def contains(self, xy: np.ndarray) -> np.ndarray:
        return np.logical_or.reduce([part.contains(xy) for part in self.parts])

    def polygon(self, tol: float = CIRCLE_TOL) -> BaseGeometry:
        return shapely.union_all([part.polygon(tol) for part in self.parts], grid_size=GRID)

    def curves(self) -> list[LineCurve | CircleCurve]:
        return [curve for part in self.parts for curve in part.curves()]


@dataclass(frozen=True)
class Difference(Shape):
    """``base`` without ``cut``."""

    base: Shape
    cut: Shape

    def contains(self, xy: np.ndarray) -> np.ndarray:
        return self.base.contains(xy) & ~self.cut.contains(xy)

    def polygon(self, tol: float = CIRCLE_TOL) -> BaseGeometry:
        return self.base.polygon(tol).difference(self.cut.polygon(tol), grid_size=GRID)

    def curves(self) -> list[LineCurve | CircleCurve]:
        return self.base.curves() + self.cut.curves()


# --------------------------------------------------------------------------- exact boundary


@dataclass(frozen=True)
class Edge:
    """One primitive of a region's boundary, with the pieces along which it bounds the region.

    Attributes
    ----------
    name : str
        What a designer calls it ("outer curb", "island", "leg 0 entry fillet", ...).
    kind : {"halfplane", "circle_inside", "circle_outside"}
        The allowed side: ``normal . p >= offset``; ``|p - center| <= radius``; ``|p - center| >= radius``.
    center, radius : circles only.
    normal, offset : half-planes only; ``normal`` is a unit vector pointing into the region.
    pieces : tuple of Segment or Arc
        Where this primitive is the region's boundary (segments with the region on their left).
    """

    name: str
    kind: str
    pieces: tuple[Segment | Arc, ...]
    center: Point2 | None = None
    radius: float | None = None
    normal: Point2 | None = None
    offset: float | None = None

    def margin(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The primitive's signed margin at (x, y), >= 0 on the allowed side, metres."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        if self.kind == "halfplane":
            return self.normal[0] * x + self.normal[1] * y - self.offset
        rho = np.hypot(x - self.center[0], y - self.center[1])
        return self.radius - rho if self.kind == "circle_inside" else rho - self.radius


def _group_curves(curves: Iterable[LineCurve | CircleCurve]) -> tuple[dict, dict]:
    """Curves of one name merged: lines as (point, direction, [intervals]), circles as (center, radius)."""
    lines: dict[str, tuple[np.ndarray, np.ndarray, list]] = {}
    circles: dict[str, tuple[np.ndarray, float]] = {}
    for c in curves:
        if isinstance(c, CircleCurve):
            old = circles.setdefault(c.name, (np.asarray(c.center, float), c.radius))
            if not (np.allclose(old[0], c.center, atol=1e-9) and abs(old[1] - c.radius) < 1e-9):
                raise ValueError(f"two different circles are both called {c.name!r}")
            continue
        p, d = np.asarray(c.point, float), np.asarray(c.direction, float)
        p0, d0, spans = lines.setdefault(c.name, (p, d, []))
        ends = [float((p + t * d - p0) @ d0) for t in c.extent]
        if abs(_cross(d, d0)) > 1e-9 or abs(_cross(d0, p - p0)) > 1e-7:
            raise ValueError(f"two different lines are both called {c.name!r}")
        spans.append((min(ends), max(ends)))
    return lines, circles


def _line_hits(p0: np.ndarray, d: np.ndarray, lines: dict, circles: dict) -> list[float]:
    """Parameters along p0 + t d where any other curve's support crosses it."""
    ts = []
    for q0, e, _ in lines.values():
        den = _cross(d, e)
        if abs(den) > 1e-12:
            ts.append(float(_cross(q0 - p0, e) / den))
    for center, radius in circles.values():
        ts += line_circle_params(p0, d, center, radius)
    return ts


def _circle_hits(center: np.ndarray, radius: float, lines: dict, circles: dict) -> list[float]:
    """Polar angles on the circle where any other curve's support crosses it."""
    points = []
    for q0, e, _ in lines.values():
        points += [q0 + t * e for t in line_circle_params(q0, e, center, radius)]
    for c2, r2 in circles.values():
        points += circle_circle_points(center, radius, c2, r2)
    return [math.atan2(*(p - center)[::-1]) % TWO_PI for p in points]


def _cluster(values: Iterable[float]) -> list[float]:
    """Sorted values, each run closer than CUT_GAP kept once."""
    out: list[float] = []
    for v in sorted(values):
        if not out or v - out[-1] > CUT_GAP:
            out.append(v)
    return out


def _merge(pieces: list[tuple[float, float, bool]]) -> list[tuple[float, float, bool]]:
    """Adjacent (start, end, side) intervals with the same side joined."""
    out: list[tuple[float, float, bool]] = []
    for a, b, side in pieces:
        if out and out[-1][1] == a and out[-1][2] == side:
            out[-1] = (out[-1][0], b, side)
        else:
            out.append((a, b, side))
    return out


def _line_edges(shape: Shape, name: str, line: tuple, lines: dict, circles: dict) -> list[Edge]:
    p0, d, spans = line
    others = {k: v for k, v in lines.items() if k != name}
    cuts = [t for a, b in spans for t in (a, b)] + _line_hits(p0, d, others, circles)
    lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
    cuts = _cluster([t for t in cuts if lo <= t <= hi])
    mids = np.array([(a + b) / 2 for a, b in zip(cuts, cuts[1:], strict=False)])
    keep = [any(a <= m <= b for a, b in spans) for m in mids]
    normal = np.array([-d[1], d[0]])
    points = p0 + mids[:, None] * d if len(mids) else np.zeros((0, 2))
    left, right = shape.contains(points + SIDE_STEP * normal), shape.contains(points - SIDE_STEP * normal)
    pieces = [
        (a, b, bool(lft))
        for a, b, k, lft, rgt in zip(cuts, cuts[1:], keep, left, right, strict=False)
        if k and lft != rgt
    ]
    edges = []
    for on_left in (True, False):
        runs = [(a, b) for a, b, side in _merge(pieces) if side == on_left]
        if not runs:
            continue
        inward = normal if on_left else -normal
        segs = tuple(
            Segment(tuple(p0 + a * d), tuple(p0 + b * d)) if on_left else Segment(tuple(p0 + b * d), tuple(p0 + a * d))
            for a, b in runs
        )
        edges.append(Edge(name, "halfplane", segs, normal=tuple(inward), offset=float(inward @ p0)))
    return edges


def _circle_edges(shape: Shape, name: str, circle: tuple, lines: dict, circles: dict) -> list[Edge]:
    center, radius = circle
    others = {k: v for k, v in circles.items() if k != name}
    cuts = _cluster(_circle_hits(center, radius, lines, others))
    if len(cuts) > 1 and cuts[-1] - cuts[0] > TWO_PI - CUT_GAP:
        cuts.pop()
    bounds = list(zip(cuts, cuts[1:] + [cuts[0] + TWO_PI], strict=True)) if cuts else [(0.0, TWO_PI)]
    mids = np.array([(a + b) / 2 for a, b in bounds])
    e = np.column_stack([np.cos(mids), np.sin(mids)])
    inner = shape.contains(center + (radius - SIDE_STEP) * e)
    outer = shape.contains(center + (radius + SIDE_STEP) * e)
    pieces = _merge([(a, b, bool(i)) for (a, b), i, o in zip(bounds, inner, outer, strict=True) if i != o])
    if len(pieces) > 1 and pieces[0][0] + TWO_PI == pieces[-1][1] and pieces[0][2] == pieces[-1][2]:
        pieces = pieces[1:-1] + [(pieces[-1][0], pieces[0][1] + TWO_PI, pieces[0][2])]
    edges = []
    for inside in (True, False):
        arcs = tuple(Arc(tuple(center), radius, a, b, inside) for a, b, side in pieces if side == inside)
        if arcs:
            kind = "circle_inside" if inside else "circle_outside"
            edges.append(Edge(name, kind, arcs, center=tuple(center), radius=radius))
    return edges


def boundary_edges(shape: Shape) -> tuple[Edge, ...]:
    """The exact boundary of ``shape`` as named edges (each curve split where others cross it)."""
    lines, circles = _group_curves(shape.curves())
    edges = []
    for name, line in lines.items():
        edges += _line_edges(shape, name, line, lines, circles)
    for name, circle in circles.items():
        edges += _circle_edges(shape, name, circle, lines, circles)
    return tuple(edges)


class Region:
    """An allowed (or named) area: exact point test, exact boundary edges, and a drawing polygon.

    Parameters
    ----------
    name : str
        For messages and figures.
    shape : Shape
        The exact CSG definition.
    tol : float
        Largest distance between a circle and its polygon in ``polygon`` (default 0.1 mm).
    """

    def __init__(self, name: str, shape: Shape, tol: float = CIRCLE_TOL):
        self.name = name
        self.shape = shape
        self.tol = tol
        self.edges = boundary_edges(shape)
        self.pieces = tuple((edge, piece) for edge in self.edges for piece in edge.pieces)

    def __repr__(self) -> str:
        return f"Region({self.name!r}, edges={[e.name for e in self.edges]})"

    @cached_property
    def polygon(self) -> BaseGeometry:
        """The shapely polygon traced along the exact boundary (arcs as inscribed polylines within ``tol``).

        Falls back on the overlay of the shape's polygons (without slivers) if the pieces do not close.
        """
        rings = _trace_rings([(_directed_points(piece, self.tol)) for _, piece in self.pieces])
        if rings is None:
            return _drop_slivers(self.shape.polygon(self.tol), 1e-6)
        return _polygon_from_rings(rings)

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Exact membership of the points ``xy`` (n, 2)."""
        return self.shape.contains(np.atleast_2d(np.asarray(xy, float)))

    def boundary_distance(self, xy: np.ndarray) -> np.ndarray:
        """Exact distances from the points ``xy`` (n, 2) to the region's boundary."""
        p = np.atleast_2d(np.asarray(xy, float))
        if not self.pieces:
            return np.full(len(p), np.inf)
        return np.min([point_piece_distance(p, piece) for _, piece in self.pieces], axis=0)

    def signed_distance(self, xy: np.ndarray) -> np.ndarray:
        """Distances to the boundary, >= 0 inside, < 0 outside."""
        d = self.boundary_distance(xy)
        return np.where(self.contains(xy), d, -d)

    def nearest_edge(self, xy: Sequence[float]) -> Edge | None:
        """The edge nearest to the point ``xy``."""
        p = np.asarray(xy, float)[None]
        if not self.pieces:
            return None
        return min(self.pieces, key=lambda ep: float(point_piece_distance(p, ep[1])[0]))[0]

    def body_distance(self, corners: np.ndarray) -> float:
        """Exact distance between the polygon ``corners`` (n, 2) and the boundary (0 where they meet)."""
        return self.nearest_to_body(corners)[0]

    def nearest_to_body(self, corners: np.ndarray) -> tuple[float, Edge | None]:
        """``body_distance`` and the edge that attains it (the first one met when the body crosses several)."""
        v = np.asarray(corners, float)
        if not self.pieces:
            return math.inf, None
        inside = shapely.contains_xy(Polygon(v), self._starts[:, 0], self._starts[:, 1])
        if inside.any():
            return 0.0, self.pieces[int(np.argmax(inside))][0]
        mid = v.mean(axis=0)
        reach = float(np.hypot(*(v - mid).T).max())
        near = [_point_piece(float(mid[0]), float(mid[1]), piece) for _, piece in self.pieces]
        sides = [(tuple(a), tuple(b)) for a, b in zip(v.tolist(), np.roll(v, -1, axis=0).tolist(), strict=True)]
        best, which = math.inf, None
        for lower, (edge, piece) in sorted(zip(near, self.pieces, strict=True), key=lambda item: item[0]):
            if lower - reach >= best:
                break
            for a, b in sides:
                if isinstance(piece, Segment):
                    d = segment_segment_distance(a, b, piece.start, piece.end)
                else:
                    d = segment_arc_distance(a, b, piece)
                if d < best:
                    best, which = d, edge
            if best == 0.0:
                break
        return best, which

    @cached_property
    def _starts(self) -> np.ndarray:
        return np.array([_piece_start(piece) for _, piece in self.pieces], float).reshape(-1, 2)

    def encroachment(self, corners: np.ndarray) -> tuple[float, np.ndarray]:
        """Largest distance from the region of a point of the body ``corners`` lying outside it.

        Measured on the corners, on the edges every ``SAMPLE_STEP`` and at the edge points nearest
        to every circle's centre (and the centre itself when the body covers it). Exact when the
        deepest point is one of these, which it is whenever a single edge is crossed: over a convex
        curb or a straight edge (a corner), onto a disc such as the island or a fillet (the point
        nearest its centre). Where two edges are crossed at once the deepest point may lie between
        samples or inside the body, and the value is a lower bound. Returns (depth, deepest point).
        """
        pts = _body_samples(np.asarray(corners, float), self.edges)
        out = ~self.contains(pts)
        if not out.any():
            return 0.0, pts[0]
        d = self.boundary_distance(pts[out])
        k = int(np.argmax(d))
        return float(d[k]), pts[out][k]


def _directed_points(piece: Segment | Arc, tol: float) -> np.ndarray:
    """The piece as a polyline with the region on its left (arcs within ``tol``, ends exact)."""
    if isinstance(piece, Segment):
        return np.array([piece.start, piece.end], float)
    step = 2.0 * math.acos(max(-1.0, 1.0 - tol / piece.radius)) if tol < piece.radius else math.pi / 4
    n = max(1, math.ceil((piece.end - piece.start) / step))
    phi = np.linspace(piece.start, piece.end, n + 1)
    pts = np.asarray(piece.center) + piece.radius * np.column_stack([np.cos(phi), np.sin(phi)])
    return pts if piece.inside else pts[::-1]


def _trace_rings(chains: list[np.ndarray], gap: float = 1e-6) -> list[np.ndarray] | None:
    """Closed rings made by joining each polyline's end to the start of the next; None if they do not close."""
    unused = list(range(len(chains)))
    rings = []
    while unused:
        first = unused.pop(0)
        ring = [chains[first]]
        while np.hypot(*(ring[-1][-1] - ring[0][0])) > gap:
            if not unused:
                return None
            d = [float(np.hypot(*(chains[k][0] - ring[-1][-1]))) for k in unused]
            k = int(np.argmin(d))
            if d[k] > gap:
                return None
            ring.append(chains[unused.pop(k)][1:])
        rings.append(np.concatenate(ring)[:-1] if len(ring) > 1 else ring[0])
    return rings


def _polygon_from_rings(rings: list[np.ndarray]) -> BaseGeometry:
    """Counter-clockwise rings as shells, clockwise ones as holes of the shell that contains them."""
    area = [float(np.sum(_cross(r, np.roll(r, -1, axis=0)))) / 2.0 for r in rings]
    shells = [Polygon(r) for r, a in zip(rings, area, strict=True) if a > 0.0]
    holes: list[list] = [[] for _ in shells]
    for r, a in zip(rings, area, strict=True):
        if a < 0.0:
            k = next((i for i, sh in enumerate(shells) if sh.contains(shapely.Point(r[0]))), None)
            if k is not None:
                holes[k].append(r)
    polys = [Polygon(sh.exterior, h) for sh, h in zip(shells, holes, strict=True)]
    if not polys:
        return Polygon()
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)


def _drop_slivers(geom: BaseGeometry, min_area: float) -> BaseGeometry:
    """``geom`` without the holes and parts smaller than ``min_area`` that polygon overlays leave."""
    parts = [p for p in shapely.get_parts(geom) if isinstance(p, Polygon) and p.area >= min_area]
    kept = [Polygon(p.exterior, [h for h in p.interiors if Polygon(h).area >= min_area]) for p in parts]
    if not kept:
        return Polygon()
    return kept[0] if len(kept) == 1 else shapely.MultiPolygon(kept)


def _piece_start(piece: Segment | Arc) -> Point2:
    return piece.start if isinstance(piece, Segment) else tuple(piece.point(piece.start))


def _body_samples(v: np.ndarray, edges: Sequence[Edge]) -> np.ndarray:
    """Corners, edge samples and the edge points nearest to the circles' centres of the body ``v``."""
    pts = [v]
    centers = np.array([e.center for e in edges if e.center is not None]).reshape(-1, 2)
    for a, b in zip(v, np.roll(v, -1, axis=0), strict=True):
        ab = b - a
        n = max(1, math.ceil(math.hypot(*ab) / SAMPLE_STEP))
        pts.append(a + np.linspace(0.0, 1.0, n + 1)[:, None] * ab)
        if len(centers):
            t = np.clip((centers - a) @ ab / float(ab @ ab), 0.0, 1.0)
            pts.append(a + t[:, None] * ab)
    if len(centers):
        inside = shapely.contains_xy(Polygon(v), centers[:, 0], centers[:, 1])
        pts.append(centers[inside])
    return np.concatenate(pts)


def body_corners(body: Polygon | np.ndarray) -> np.ndarray:
    """The corners (n, 2) of a shapely polygon or an array of corners, without the closing repeat."""
    if isinstance(body, Polygon):
        v = np.asarray(body.exterior.coords, float)
        return v[:-1] if len(v) > 1 and np.array_equal(v[0], v[-1]) else v
    return np.asarray(body, float)


def clearance(region: Region | BaseGeometry, body: Polygon | np.ndarray) -> float:
    """Signed clearance of a body polygon in an allowed region, metres.

    ``>= 0``: the body lies inside the region, and this is the smallest distance from the body to
    the region's boundary (exact, on the exact circles and lines). ``< 0``: part of the body lies
    outside, and this is minus the largest distance of a body point from the region (the
    encroachment depth, see ``Region.encroachment``). A plain shapely geometry as ``region`` is
    measured on its polygon instead (approximate by its polygon error and 5 cm edge samples).
    """
    if not isinstance(region, Region):
        return _polygon_clearance(region, body)
    return float(clearances(region, body_corners(body)[None])[0])


def clearances(region: Region, corners: np.ndarray) -> np.ndarray:
    """``clearance`` of many bodies given as corners (m, n, 2), one membership test for all."""
    first_inside = region.contains(corners[:, 0, :])
    out = np.empty(len(corners))
    for i, (c, inside) in enumerate(zip(corners, first_inside, strict=True)):
        d = region.nearest_to_body(c)[0]
        out[i] = d if d > 0.0 and inside else min(-region.encroachment(c)[0], 0.0)
    return out


def clearance_detail(region: Region, body: Polygon | np.ndarray) -> tuple[float, str | None, np.ndarray]:
    """``clearance`` with the name of the edge that sets it and the body point where it is set.

    Inside: the edge nearest to the body and the body corner nearest to the boundary. Outside: the edge
    nearest to the deepest point and that point. For ``diagnosis``: "0.42 m over the island".
    """
    corners = body_corners(body)
    d, edge = region.nearest_to_body(corners)
    if d > 0.0 and bool(region.contains(corners[:1])[0]):
        k = int(np.argmin(region.boundary_distance(corners)))
        return float(d), edge.name if edge else None, corners[k]
    depth, point = region.encroachment(corners)
    if depth <= 0.0:
        return 0.0, edge.name if edge else None, point
    deepest = region.nearest_edge(point)
    return -depth, deepest.name if deepest else None, point


def polygon_clearances(region: BaseGeometry, corners: np.ndarray) -> np.ndarray:
    """``clearance`` in a plain shapely ``region`` of many bodies given as corners (m, n, 2): the bodies the
    region covers measured together (their distance to its boundary), the others one by one."""
    polys = shapely.polygons(np.asarray(corners, float))
    shapely.prepare(region)
    covered = shapely.covers(region, polys)
    out = np.empty(len(polys))
    out[covered] = shapely.distance(region.boundary, polys[covered])
    out[~covered] = [_polygon_clearance(region, p) for p in polys[~covered]]
    return out


def _polygon_clearance(region: BaseGeometry, body: Polygon | np.ndarray) -> float:
    poly = body if isinstance(body, Polygon) else Polygon(body)
    if region.covers(poly):
        return float(region.boundary.distance(poly))
    outside = shapely.segmentize(poly.difference(region), 5 * SAMPLE_STEP)
    pts = shapely.get_coordinates(outside)
    return -float(max(shapely.distance(region, shapely.points(pts)).max(), 0.0))
