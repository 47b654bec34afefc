"""Roundabout road geometry as in shared/roundabout-format.md: ring, apron, island, legs, lanes, fillets.

Frames. Leg ``i`` has the unit axis ``u = (cos a, sin a)`` (``a`` its angle, pointing away from the
centre) and the normal ``n = (-sin a, cos a)``; a point of the leg is ``c + s_a u + s_n n``. Under
right-hand traffic the entry lane is the half ``0 <= s_n <= w`` (right of a driver coming in), the
exit lane ``-w <= s_n <= 0``; mirrored for left-hand traffic. The lane's *outer edge* is its curb
side ``|s_n| = w``, the leg axis is its *centre line*.

Every region is a ``Region`` (model.scene.geometry): an exact point test, its exact boundary as
named ``Edge`` primitives (the data the NLP's smooth constraints need), and a shapely polygon for
drawing whose circles lie within 0.1 mm of the true circles.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from model.errors import InputError
from model.scene.geometry import (
    CIRCLE_TOL,
    ConvexPolygon,
    Difference,
    Disc,
    Edge,
    Region,
    Shape,
    Union,
    clearance,
    clearance_detail,
    wrap_angle,
)

__all__ = [
    "Leg", "Roundabout", "Route", "Edge", "Region", "clearance", "clearance_detail", "rectangle",
    "rectangle_corners", "exit_leg", "exit_order", "exit_taken", "sweep", "heading_change", "start_pose",
    "goal_pose", "corridor", "edges", "ring_region", "apron_region", "island_region", "lane_region",
    "fillet_region", "fillet_geometry", "lane_side", "leg_point", "check_lane_width", "apron_allowed",
]  # fmt: skip

TRAFFIC = ("right", "left")
APRON_USE = ("trailer", "all", "none")
LANES = ("entry", "exit")
BODIES = ("vehicle", "trailer")
OVERLAP_AREA = 1e-6  # m^2: a fillet sharing more than this with another leg overlaps it
MAX_SIZE = 1e4  # m: lengths of a roundabout (diameter, widths, radii, legs) beyond this are refused
MAX_COORDINATE = 1e6  # m: a centre further from the origin loses the 0.1 mm the geometry works to
OVERLAP_TOL = 1e-3  # m: circle polygon tolerance of the fillet overlap check


def _finite(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Leg:
    """One approach road: an entry and an exit lane side by side along an axis from the centre.

    Parameters
    ----------
    angle_deg : float
        Direction of the axis seen from the centre, degrees counter-clockwise from +x.
    lane_width : float
        Width of each lane, m (the leg is ``2 * lane_width`` wide).
    entry_radius, exit_radius : float
        Radii of the curb fillets between each lane's outer edge and the outer curb, m.
    length : float
        How far the leg reaches beyond the outer curb circle, m.
    """

    angle_deg: float
    lane_width: float
    entry_radius: float
    exit_radius: float
    length: float = 60.0

    @property
    def angle(self) -> float:
        """The axis direction in radians."""
        return math.radians(self.angle_deg)

    @property
    def axis(self) -> np.ndarray:
        """Unit vector along the axis, away from the centre."""
        return np.array([math.cos(self.angle), math.sin(self.angle)])

    @property
    def normal(self) -> np.ndarray:
        """Unit vector across the axis, the axis turned a quarter counter-clockwise."""
        return np.array([-math.sin(self.angle), math.cos(self.angle)])

    def radius(self, lane: str) -> float:
        """The fillet radius of the ``"entry"`` or ``"exit"`` lane."""
        return self.entry_radius if lane == "entry" else self.exit_radius


@dataclass(frozen=True)
class Roundabout:
    """A roundabout: ring roadway, optional truck apron, central island and its legs.

    Parameters
    ----------
    center : (float, float)
        Centre, m.
    inscribed_diameter : float
        ICD, the diameter of the outer curb, m; ``Ro = ICD / 2``.
    circulatory_width : float
        Width of the ring roadway inside the outer curb, m; ``Ri = Ro - circulatory_width``.
    apron_width : float
        Mountable apron inside the ring roadway, m; the island has radius ``Ri - apron_width``.
    apron_use : {"trailer", "all", "none"}
        Which bodies may sweep over the apron.
    traffic : {"right", "left"}
        Right-hand traffic circulates counter-clockwise, left-hand clockwise.
    legs : sequence of Leg
        The approach roads, in the order of ``[[roundabout.legs]]``.

    Raises
    ------
    InputError
        Naming the scenario key at fault (``roundabout.legs[1].lane_width``, ...).
    """

    center: tuple[float, float]
    inscribed_diameter: float
    circulatory_width: float
    apron_width: float = 0.0
    apron_use: str = "trailer"
    traffic: str = "right"
    legs: Sequence[Leg] = ()

    def __post_init__(self):
        center = self.center
        if not (isinstance(center, Sequence) and len(center) == 2 and all(_finite(v) for v in center)):
            raise InputError("roundabout.center", f"must be two finite numbers [x, y], got {center!r}")
        if max(abs(v) for v in center) > MAX_COORDINATE:
            raise InputError("roundabout.center", f"must lie within {MAX_COORDINATE:g} m of the origin, got {center!r}")
        object.__setattr__(self, "center", (float(center[0]), float(center[1])))
        object.__setattr__(self, "legs", tuple(self.legs))
        self.check()

    @property
    def outer_radius(self) -> float:
        """Ro, the radius of the outer curb."""
        return self.inscribed_diameter / 2.0

    @property
    def inner_radius(self) -> float:
        """Ri, the inner radius of the ring roadway (the apron's outer edge)."""
        return self.outer_radius - self.circulatory_width

    @property
    def island_radius(self) -> float:
        """Radius of the raised central island, ``Ri - apron_width``."""
        return self.inner_radius - self.apron_width

    @property
    def circulation(self) -> int:
        """+1 for counter-clockwise circulation (right-hand traffic), -1 for clockwise."""
        return 1 if self.traffic == "right" else -1

    def check(self) -> None:
        """Raise InputError naming the first invalid key (ring, apron, legs, overlaps)."""
        self._check_ring()
        for i, leg in enumerate(self.legs):
            self._check_leg(i, leg)
        _check_overlaps(self)

    def _check_ring(self) -> None:
        ro = self.inscribed_diameter / 2.0 if _finite(self.inscribed_diameter) else math.nan
        if not 0.0 < ro <= MAX_SIZE / 2:
            limit = f"must be > 0 and at most {MAX_SIZE:g} m"
            raise InputError("roundabout.inscribed_diameter", f"{limit}, got {self.inscribed_diameter!r}")
        if not (_finite(self.circulatory_width) and 0.0 < self.circulatory_width < ro):
            raise InputError(
                "roundabout.circulatory_width",
                f"must satisfy 0 < circulatory_width < Ro = {ro:g} m, got {self.circulatory_width!r}",
            )
        if not (_finite(self.apron_width) and self.apron_width >= 0.0):
            raise InputError("roundabout.apron_width", f"must be >= 0, got {self.apron_width!r}")
        if self.apron_width >= ro - self.circulatory_width:
            raise InputError(
                "roundabout.apron_width",
                f"{self.apron_width:g} m leaves no central island (Ri = {ro - self.circulatory_width:g} m)",
            )
        if self.apron_use not in APRON_USE:
            raise InputError("roundabout.apron_use", f"must be one of {', '.join(APRON_USE)}, got {self.apron_use!r}")
        if self.traffic not in TRAFFIC:
            raise InputError("roundabout.traffic", f"must be one of {', '.join(TRAFFIC)}, got {self.traffic!r}")
        if not self.legs:
            raise InputError("roundabout.legs", "a roundabout needs at least one leg")

    def _check_leg(self, i: int, leg: Leg) -> None:
        key = f"roundabout.legs[{i}]"
        if not isinstance(leg, Leg):
            raise InputError(key, f"must be a Leg, got {type(leg).__name__}")
        if not _finite(leg.angle_deg):
            raise InputError(f"{key}.angle", f"must be a finite number of degrees, got {leg.angle_deg!r}")
        for name in ("lane_width", "entry_radius", "exit_radius", "length"):
            value = getattr(leg, name)
            if not (_finite(value) and 0.0 < value <= MAX_SIZE):
                raise InputError(f"{key}.{name}", f"must be > 0 and at most {MAX_SIZE:g} m, got {value!r}")
        if leg.lane_width >= self.outer_radius:
            raise InputError(
                f"{key}.lane_width",
                f"{leg.lane_width:g} m is not narrower than the outer curb's radius Ro = {self.outer_radius:g} m",
            )
        for lane in LANES:
            reach = fillet_geometry(self, i, lane)["axial"] - self.outer_radius
            if reach > leg.length:
                raise InputError(
                    f"{key}.{lane}_radius",
                    f"the {lane} fillet reaches {reach:.3g} m beyond the outer "
                    f"curb, past the leg's end (length = {leg.length:g} m)",
                )


# --------------------------------------------------------------------------- legs, lanes, fillets


def lane_side(roundabout: Roundabout, lane: str) -> int:
    """+1 if the ``"entry"``/``"exit"`` lane is the half of its leg on the side of ``n``, else -1."""
    if lane not in LANES:
        raise ValueError(f"lane must be one of {LANES}, got {lane!r}")
    return (1 if lane == "entry" else -1) * roundabout.circulation


def leg_point(roundabout: Roundabout, leg: int, along: float, across: float) -> np.ndarray:
    """The point ``c + along * u + across * n`` of leg ``leg``'s frame."""
    g = roundabout.legs[leg]
    return np.asarray(roundabout.center) + along * g.axis + across * g.normal


def fillet_geometry(roundabout: Roundabout, leg: int, lane: str) -> dict:
    """The fillet of a lane's outer edge, exactly.

    Its circle has radius ``r``, its centre lies ``w + r`` from the axis on the lane's outer side
    (so it touches the edge line) and ``Ro + r`` from the roundabout's centre (so it touches the
    outer curb from outside): ``along = sqrt((Ro + r)^2 - (w + r)^2)``.

    Returns
    -------
    dict
        ``center``, ``radius``, ``axial`` (the centre's distance along the axis),
        ``edge_point`` (tangent point on the edge line), ``curb_point`` (tangent point on the outer
        curb), ``corner`` (where the edge line meets the outer curb), ``inner_corner`` (a point of the
        edge line inside the outer curb, half way from the centre's foot to ``corner``).
    """
    g = roundabout.legs[leg]
    ro, w, r = roundabout.outer_radius, g.lane_width, g.radius(lane)
    side = lane_side(roundabout, lane)
    axial = math.sqrt((ro + r) ** 2 - (w + r) ** 2)
    center = leg_point(roundabout, leg, axial, side * (w + r))
    c = np.asarray(roundabout.center)
    return {
        "center": center,
        "radius": r,
        "axial": axial,
        "edge_point": leg_point(roundabout, leg, axial, side * w),
        "curb_point": c + (center - c) * (ro / (ro + r)),
        "corner": leg_point(roundabout, leg, math.sqrt(ro * ro - w * w), side * w),
        "inner_corner": leg_point(roundabout, leg, math.sqrt(ro * ro - w * w) / 2.0, side * w),
    }


def _lane_names(leg: int, lane: str) -> dict[str, str]:
    return {
        "outer": f"leg {leg} {lane} lane outer edge",
        "centre": f"leg {leg} centre line",
        "end": f"leg {leg} end",
        "start": f"leg {leg} start",
        "fillet": f"leg {leg} {lane} fillet",
    }


def _strip(roundabout: Roundabout, leg: int, lo: float, hi: float, names: Sequence[str]) -> ConvexPolygon:
    """The part ``lo <= across <= hi`` of leg ``leg`` from the centre to its end; names: lo, end, hi, start."""
    end = roundabout.outer_radius + roundabout.legs[leg].length
    corners = [(0.0, lo), (end, lo), (end, hi), (0.0, hi)]
    return ConvexPolygon(tuple(tuple(leg_point(roundabout, leg, a, s)) for a, s in corners), tuple(names))


def lane_shape(roundabout: Roundabout, leg: int, lane: str) -> Shape:
    """The exact strip of a lane: half of its leg, from the centre out to ``Ro + length``."""
    w, side, names = roundabout.legs[leg].lane_width, lane_side(roundabout, lane), _lane_names(leg, lane)
    lo, hi = (0.0, w) if side > 0 else (-w, 0.0)
    lo_name, hi_name = (names["centre"], names["outer"]) if side > 0 else (names["outer"], names["centre"])
    return _strip(roundabout, leg, lo, hi, (lo_name, names["end"], hi_name, names["start"]))


def fillet_shape(roundabout: Roundabout, leg: int, lane: str) -> Shape:
    """The exact region between a lane's outer edge, the outer curb and the fillet arc.

    It is the triangle (edge point, curb point, a point of the edge line inside the curb) without
    the curb's disc and the fillet's disc. Starting the triangle inside the curb rather than at the
    corner changes nothing exactly and leaves no slivers between the polygons near the corner.
    """
    f, names = fillet_geometry(roundabout, leg, lane), _lane_names(leg, lane)
    triangle = ConvexPolygon(
        (tuple(f["inner_corner"]), tuple(f["edge_point"]), tuple(f["curb_point"])),
        (names["outer"], f"{names['fillet']} chord", f"{names['fillet']} curb chord"),
    )
    curb = Disc(roundabout.center, roundabout.outer_radius, "outer curb")
    return Difference(triangle, Union((curb, Disc(tuple(f["center"]), f["radius"], names["fillet"]))))


def _inner_name(roundabout: Roundabout) -> str:
    return "apron" if roundabout.apron_width > 0.0 else "island"


def ring_region(roundabout: Roundabout, tol: float = CIRCLE_TOL) -> Region:
    """The ring roadway, the annulus between Ri and Ro."""
    c = roundabout.center
    shape = Difference(
        Disc(c, roundabout.outer_radius, "outer curb"), Disc(c, roundabout.inner_radius, _inner_name(roundabout))
    )
    return Region("ring roadway", shape, tol)


def apron_region(roundabout: Roundabout, tol: float = CIRCLE_TOL) -> Region:
    """The apron, the annulus between ``Ri - apron_width`` and Ri (empty without an apron)."""
    c = roundabout.center
    shape = Difference(
        Disc(c, roundabout.inner_radius, "apron outer edge"), Disc(c, roundabout.island_radius, "island")
    )
    return Region("apron", shape, tol)


def island_region(roundabout: Roundabout, tol: float = CIRCLE_TOL) -> Region:
    """The raised central island, the disc of radius ``Ri - apron_width``."""
    return Region("island", Disc(roundabout.center, roundabout.island_radius, "island"), tol)


def lane_region(roundabout: Roundabout, leg: int, lane: str, tol: float = CIRCLE_TOL) -> Region:
    """A lane's strip (half of leg ``leg``, from the centre out to ``Ro + length``)."""
    return Region(f"leg {leg} {lane} lane", lane_shape(roundabout, leg, lane), tol)


def fillet_region(roundabout: Roundabout, leg: int, lane: str, tol: float = CIRCLE_TOL) -> Region:
    """The curb fillet region of a lane (between its outer edge, the outer curb and the fillet arc)."""
    return Region(f"leg {leg} {lane} fillet", fillet_shape(roundabout, leg, lane), tol)


def _leg_outside_shape(roundabout: Roundabout, leg: int) -> Shape:
    """Leg ``leg`` beyond the outer curb: both lanes and both fillets."""
    w = roundabout.legs[leg].lane_width
    strip = _strip(roundabout, leg, -w, w, ("a", "b", "c", "d"))
    parts = (strip, fillet_shape(roundabout, leg, "entry"), fillet_shape(roundabout, leg, "exit"))
    return Difference(Union(parts), Disc(roundabout.center, roundabout.outer_radius, "outer curb"))


def _check_overlaps(roundabout: Roundabout) -> None:
    """Legs must not overlap outside Ro: strips exactly, fillets on polygons within OVERLAP_TOL."""
    legs, ro = roundabout.legs, roundabout.outer_radius
    strips = [_strip(roundabout, i, -g.lane_width, g.lane_width, "abcd").polygon() for i, g in enumerate(legs)]
    c = np.asarray(roundabout.center)
    for j in range(len(legs)):
        for i in range(j):
            common = strips[i].intersection(strips[j])
            if common.area > 1e-12 and np.hypot(*(np.asarray(common.exterior.coords) - c).T).max() > ro + 1e-9:
                raise InputError(
                    f"roundabout.legs[{j}].angle",
                    f"leg {j} (angle {legs[j].angle_deg:g} deg) "
                    f"overlaps leg {i} (angle {legs[i].angle_deg:g} deg) outside the outer curb",
                )
    outside = [_leg_outside_shape(roundabout, i).polygon(OVERLAP_TOL) for i in range(len(legs))]
    for i in range(len(legs)):
        for lane in LANES:
            fillet = fillet_shape(roundabout, i, lane).polygon(OVERLAP_TOL)
            for j in range(len(legs)):
                if j != i and fillet.intersection(outside[j]).area > OVERLAP_AREA:
                    raise InputError(
                        f"roundabout.legs[{i}].{lane}_radius",
                        f"leg {i}'s {lane} fillet overlaps leg {j} outside the outer curb",
                    )


def check_lane_width(roundabout: Roundabout, body_width: float) -> None:
    """Raise InputError ``roundabout.legs[i].lane_width`` for the first lane not wider than ``body_width``."""
    for i, leg in enumerate(roundabout.legs):
        if not leg.lane_width > body_width:
            raise InputError(
                f"roundabout.legs[{i}].lane_width",
                f"{leg.lane_width:g} m is not wider than the vehicle ({body_width:g} m)",
            )


def apron_allowed(roundabout: Roundabout, body: str) -> bool:
    """Whether ``body`` ("vehicle" or "trailer") may sweep over the apron under ``apron_use``."""
    if body not in BODIES:
        raise ValueError(f"body must be one of {BODIES}, got {body!r}")
    return roundabout.apron_use == "all" or (roundabout.apron_use == "trailer" and body == "trailer")


# --------------------------------------------------------------------------- routes


@dataclass(frozen=True)
class Route:
    """A route through the roundabout.

    Parameters
    ----------
    enter : int
        Index of the leg the vehicle comes from.
    exit : int
        The n-th exit after the entry, counted in the circulation direction; with k legs, k is the U-turn.
    start_distance, goal_distance : float
        Start and goal lie ``Ro + distance`` from the centre along the entry and exit leg axes, m.
    """

    enter: int
    exit: int
    start_distance: float = 30.0
    goal_distance: float = 30.0


def _is_int(value: object) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def _check_enter(roundabout: Roundabout, enter: object, key: str = "route.enter") -> int:
    k = len(roundabout.legs)
    if not (_is_int(enter) and 0 <= enter < k):
        raise InputError(key, f"must be a leg index 0..{k - 1}, got {enter!r}")
    return int(enter)


def _exit_deltas(roundabout: Roundabout, enter: int) -> list[float]:
    """For every leg, the angle in degrees turned in the circulation direction from the entry axis, in (0, 360]."""
    a0 = roundabout.legs[enter].angle_deg
    return [(roundabout.circulation * (g.angle_deg - a0)) % 360.0 or 360.0 for g in roundabout.legs]


def exit_order(roundabout: Roundabout, enter: int) -> list[int]:
    """Leg indices in the order a driver entering from ``enter`` meets them; the entry leg is last."""
    deltas = _exit_deltas(roundabout, _check_enter(roundabout, enter))
    return sorted(range(len(deltas)), key=deltas.__getitem__)


def exit_leg(roundabout: Roundabout, route: Route) -> int:
    """Index of the leg the route leaves by (its ``exit``-th exit after the entry)."""
    order = exit_order(roundabout, route.enter)
    if not (_is_int(route.exit) and 1 <= route.exit <= len(order)):
        raise InputError(
            "route.exit", f"must be an exit number 1..{len(order)} (the U-turn is {len(order)}), got {route.exit!r}"
        )
    return order[route.exit - 1]


def sweep(roundabout: Roundabout, route: Route) -> float:
    """Signed angle from the entry axis to the exit axis turned in the circulation direction (ccw > 0).

    In (0, 2 pi] for right-hand traffic, [-2 pi, 0) for left-hand; the U-turn is +-2 pi.
    """
    j = exit_leg(roundabout, route)
    return roundabout.circulation * math.radians(_exit_deltas(roundabout, route.enter)[j])


def heading_change(roundabout: Roundabout, route: Route) -> float:
    """theta(Tf) - theta(0): ``sweep - pi`` (right-hand traffic) or ``sweep + pi`` (left-hand).

    On a four-leg right-hand roundabout: -pi/2 at the first exit (a right turn), 0 straight on,
    +pi for the U-turn.
    """
    return sweep(roundabout, route) - roundabout.circulation * math.pi


def _check_distance(roundabout: Roundabout, leg: int, value: object, key: str) -> float:
    length = roundabout.legs[leg].length
    if not (_finite(value) and 0.0 <= value <= length):
        raise InputError(key, f"must lie on the leg, 0 <= distance <= length = {length:g} m, got {value!r}")
    return float(value)


def start_pose(roundabout: Roundabout, route: Route) -> tuple[float, float, float]:
    """(x, y, theta) at t = 0: middle of the entry lane at ``Ro + start_distance``, heading to the centre.

    theta is the direction of the leg axis pointing to the centre, in (-pi, pi].
    """
    e = _check_enter(roundabout, route.enter)
    d = _check_distance(roundabout, e, route.start_distance, "route.start_distance")
    g = roundabout.legs[e]
    x, y = leg_point(roundabout, e, roundabout.outer_radius + d, lane_side(roundabout, "entry") * g.lane_width / 2)
    heading_deg = (g.angle_deg + 180.0) % 360.0
    theta = math.radians(heading_deg - 360.0 if heading_deg > 180.0 else heading_deg)
    return float(x), float(y), wrap_angle(theta)


def goal_pose(roundabout: Roundabout, route: Route) -> tuple[float, float, float]:
    """(x, y, theta) at Tf: middle of the exit lane at ``Ro + goal_distance``, heading away from the centre.

    theta = theta(0) + heading_change (not wrapped: it says which way the vehicle went round).
    """
    j = exit_leg(roundabout, route)
    d = _check_distance(roundabout, j, route.goal_distance, "route.goal_distance")
    g = roundabout.legs[j]
    x, y = leg_point(roundabout, j, roundabout.outer_radius + d, lane_side(roundabout, "exit") * g.lane_width / 2)
    theta0 = start_pose(roundabout, route)[2]
    return float(x), float(y), theta0 + heading_change(roundabout, route)


def exit_taken(roundabout: Roundabout, route_enter: int, path_xy: np.ndarray) -> int | None:
    """The n-th exit a path actually leaves by, counted as a driver counts them.

    The exit leg is the one whose exit lane (with its fillet, beyond the outer curb) contains the
    path's last point; extra full turns round the centre add ``k`` each. Returns None when the
    last point lies in no exit lane; a result < 1 means the path went round against the circulation.

    Parameters
    ----------
    roundabout : Roundabout
    route_enter : int
        Index of the entry leg.
    path_xy : array (n, 2)
        The reference point's path, from the start.
    """
    enter = _check_enter(roundabout, route_enter)
    xy = np.asarray(path_xy, float).reshape(-1, 2)
    end = xy[-1:]
    legs = [j for j in range(len(roundabout.legs)) if _exit_lane_outside(roundabout, j).contains(end)[0]]
    if not legs:
        return None
    j = legs[0]
    order = exit_order(roundabout, enter)
    rel = xy - np.asarray(roundabout.center)
    turned = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    swept = roundabout.circulation * float(turned[-1] - turned[0])
    loops = round((swept - math.radians(_exit_deltas(roundabout, enter)[j])) / (2.0 * math.pi))
    return order.index(j) + 1 + len(order) * loops


def _exit_lane_outside(roundabout: Roundabout, leg: int) -> Shape:
    parts = (lane_shape(roundabout, leg, "exit"), fillet_shape(roundabout, leg, "exit"))
    return Difference(Union(parts), Disc(roundabout.center, roundabout.outer_radius, "outer curb"))


# --------------------------------------------------------------------------- corridor


def corridor_shape(roundabout: Roundabout, route: Route, apron: bool = False) -> Shape:
    """The exact allowed area of a route (see ``corridor``)."""
    e = _check_enter(roundabout, route.enter)
    x = exit_leg(roundabout, route)
    c = roundabout.center
    parts = (
        Disc(c, roundabout.outer_radius, "outer curb"),
        lane_shape(roundabout, e, "entry"),
        fillet_shape(roundabout, e, "entry"),
        lane_shape(roundabout, x, "exit"),
        fillet_shape(roundabout, x, "exit"),
    )
    inner = (
        Disc(c, roundabout.island_radius, "island")
        if apron
        else Disc(c, roundabout.inner_radius, _inner_name(roundabout))
    )
    return Difference(Union(parts), inner)


def corridor(roundabout: Roundabout, route: Route, apron: bool = False, tol: float = CIRCLE_TOL) -> Region:
    """The area a body may occupy on ``route``.

    The ring roadway, plus the entry lane (with its fillet) of the entry leg, plus the exit lane
    (with its fillet) of the exit leg, all outside the circle Ri; with ``apron=True`` the apron
    annulus too (outside the island instead).

    Returns
    -------
    Region
        Exact point test and boundary ``edges``; ``polygon`` is within ``tol`` of it.
    """
    name = f"corridor leg {route.enter} to leg {exit_leg(roundabout, route)}" + (" with apron" if apron else "")
    return Region(name, corridor_shape(roundabout, route, apron), tol)


def edges(roundabout: Roundabout, route: Route, apron: bool = False) -> tuple[Edge, ...]:
    """The primitives that bound the route's corridor, with the pieces where each one applies.

    Each ``Edge`` is a half-plane (``normal . p >= offset``, e.g. "leg 0 entry lane outer edge",
    "leg 2 centre line", "leg 0 end") or a circle kept inside ("outer curb") or outside ("island",
    "apron", "leg 0 entry fillet").
    """
    return corridor(roundabout, route, apron).edges


# --------------------------------------------------------------------------- bodies


def rectangle_corners(
    x: float, y: float, heading: float, length: float, width: float, rear_overhang: float
) -> np.ndarray:
    """Corners (4, 2), counter-clockwise, of a rectangle fixed to a rear axle centre (x, y)."""
    u = np.array([math.cos(heading), math.sin(heading)])
    n = np.array([-u[1], u[0]])
    back, front, half = -rear_overhang, length - rear_overhang, width / 2.0
    p = np.array([x, y], float)
    return np.stack(
        [p + back * u - half * n, p + front * u - half * n, p + front * u + half * n, p + back * u + half * n]
    )


def rectangle(x: float, y: float, heading: float, length: float, width: float, rear_overhang: float) -> Polygon:
    """The body polygon of a rigid rectangle whose reference point (x, y) is its rear axle centre.

    Parameters
    ----------
    x, y, heading : float
        Rear axle centre (m) and heading (rad).
    length, width : float
        Bumper to bumper and side to side, m.
    rear_overhang : float
        Rear axle to rear bumper, m (the front bumper is ``length - rear_overhang`` ahead).
    """
    return Polygon(rectangle_corners(x, y, heading, length, width, rear_overhang))
