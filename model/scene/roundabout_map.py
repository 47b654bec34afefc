"""A parametric roundabout as a CommonRoad lanelet network (docs/map-format.md, "Export").

``roundabout_lanelets`` turns a ``Roundabout`` (model/scene/roundabout.py) into lanelets on the
same exact geometry, sampled so finely that no vertex-to-vertex chord leaves its circle by more
than ``tolerance``:

- the ring: ``ring_lanes`` concentric lanes of equal width between the inner radius Ri and the
  outer curb Ro, each split into arcs at the legs' junctions and linked in the circulation
  direction (counter-clockwise for right-hand traffic), the lanes adjacent in the same direction;
- per leg an entry and an exit lanelet, adjacent in opposite directions across the leg's centre
  line: from the leg's end along the lane's outer edge, its curb fillet and the outer curb to the
  junction, where the entry merges into (the exit leaves) the outer ring lane; the entry's inner
  bound curves from the leg's centre line at the curb to the outer ring lane's inner edge within
  the ring, so the entry lanelet overlaps the ring there, as the real rounD maps' entries do;
- the apron (``apron_width > 0``): one closed lanelet of type ``border``, its own predecessor and
  successor, as the truck apron of the rounD map DEU_Kackertstrasse-1 (its lanelet 50).

The traffic side is honoured: the driver's right bound is the curb side for right-hand traffic,
the inner side for left-hand traffic. ``commonroad_xml`` writes the network with commonroad-io's
``CommonRoadFileWriter``; ``corridor_mismatch`` measures the symmetric difference between a
route's corridor in the exported map and the parametric corridor. Knows no vehicle and no solver.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from model.errors import InputError
from model.scene.roundabout import LANES, Roundabout, Route, corridor, exit_leg, fillet_geometry, lane_side, leg_point

TOLERANCE = 1e-3  # m: the largest distance between a sampled circle's chords and the circle
JUNCTION_SHARE = 1 / 3  # the junction moves past the fillet by at most this share of the gap to the next one
JUNCTION_ARC = 0.5  # ... and by at most this many ring widths of arc along the outer curb
APRON_ID = 1
MAX_LEGS = 99
MAX_RING_LANES = 8


@dataclass
class LaneletData:
    """One lanelet before commonroad-io: bounds (n, 2) in the driving direction and its links."""

    lanelet_id: int
    left: np.ndarray
    right: np.ndarray
    kind: str = "urban"  # "urban" or "border"
    predecessors: list[int] = field(default_factory=list)
    successors: list[int] = field(default_factory=list)
    adj_left: tuple[int, bool] | None = None  # (id, same direction)
    adj_right: tuple[int, bool] | None = None
    marking_left: str = "no_marking"
    marking_right: str = "no_marking"


@dataclass
class RoundaboutNetwork:
    """The lanelets of a roundabout and which lanelet is which.

    Attributes
    ----------
    lanelets : dict of int to LaneletData
    entry, exit : list of int
        The entry and exit lanelet of each leg, in the order of the legs.
    ring : list of list of int
        Per ring lane (0 the outer one), its arcs in the circulation direction.
    apron : int or None
        The apron's border lanelet (None without an apron).
    """

    lanelets: dict[int, LaneletData]
    entry: list[int]
    exit: list[int]
    ring: list[list[int]]
    apron: int | None


def arc_points(radius: float, sweep: float, tol: float) -> int:
    """How many points sample an arc of ``radius`` and angle ``sweep`` with chords within ``tol`` of it."""
    step = math.sqrt(8.0 * tol / radius) if radius > 0 else math.inf
    return max(2, math.ceil(abs(sweep) / step) + 1)


def _arc(center, radius: float, a0: float, a1: float, n: int) -> np.ndarray:
    a = np.linspace(a0, a1, n)
    return np.asarray(center, float) + radius * np.stack([np.cos(a), np.sin(a)], -1)


def _angle(point, center) -> float:
    d = np.asarray(point, float) - np.asarray(center, float)
    return math.atan2(d[1], d[0])


def _relative(angle: float, reference: float) -> float:
    """``angle - reference`` wrapped into (-pi, pi]."""
    return math.remainder(angle - reference, 2 * math.pi)


# --------------------------------------------------------------------------- junctions


def fillet_angle(roundabout: Roundabout, leg: int, lane: str) -> float:
    """How far (rad, > 0) round the outer curb the lane's fillet meets it, seen from the leg's axis."""
    f = fillet_geometry(roundabout, leg, lane)
    return abs(_relative(_angle(f["curb_point"], roundabout.center), roundabout.legs[leg].angle))


def junction_offset(roundabout: Roundabout) -> float:
    """The angle (rad) every junction lies beyond its fillet's curb point along the outer curb.

    Raises
    ------
    InputError
        ``roundabout.legs[i].entry_radius`` when leg i's entry fillet reaches past the next leg's exit fillet.
    """
    legs, c = roundabout.legs, roundabout.circulation
    order = sorted(range(len(legs)), key=lambda i: (c * legs[i].angle) % (2 * math.pi))
    gaps = []
    for k, i in enumerate(order):
        j = order[(k + 1) % len(order)]
        between = (c * (legs[j].angle - legs[i].angle)) % (2 * math.pi) or 2 * math.pi
        gap = between - fillet_angle(roundabout, i, "entry") - fillet_angle(roundabout, j, "exit")
        if gap <= 0:
            raise InputError(f"roundabout.legs[{i}].entry_radius", f"leg {i}'s entry fillet meets the outer curb past "
                             f"leg {j}'s exit fillet: no ring between them to join it to")  # fmt: skip
        gaps.append(gap)
    width = roundabout.circulatory_width / roundabout.outer_radius
    return min(JUNCTION_ARC * width, JUNCTION_SHARE * min(gaps))


def junction_angle(roundabout: Roundabout, leg: int, lane: str, offset: float) -> float:
    """The absolute angle (rad, unwrapped near the leg's axis) of a lane's junction with the ring."""
    side = lane_side(roundabout, lane)
    return roundabout.legs[leg].angle + side * (fillet_angle(roundabout, leg, lane) + offset)


# --------------------------------------------------------------------------- legs


def _dedupe(curb: np.ndarray, inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop points where neither bound moves (pieces share their end points)."""
    step = np.maximum(np.hypot(*np.diff(curb, axis=0).T), np.hypot(*np.diff(inner, axis=0).T))
    keep = np.concatenate([[True], step > 1e-9])
    return curb[keep], inner[keep]


def leg_bounds(roundabout: Roundabout, leg: int, lane: str, offset: float, inner_radius: float,
               tol: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The curb-side and the centre-line-side bound of a lane, from the leg's end to its ring junction.

    Three pieces with matched points: the straight lane (outer edge | centre line) to the fillet's
    tangent point; the fillet arc | the centre line on to the outer curb; the outer curb to the
    junction | a curve from the outer curb to ``inner_radius`` at the junction (polar: the angle
    grows with tau^2, the radius falls with 2 tau - tau^2, so it leaves the curb along the leg
    and meets the circle tangentially, and never leaves the annulus).
    """
    g, ro, c = roundabout.legs[leg], roundabout.outer_radius, np.asarray(roundabout.center)
    f, side = fillet_geometry(roundabout, leg, lane), lane_side(roundabout, lane)
    w, end = g.lane_width, ro + g.length
    curb = [np.array([leg_point(roundabout, leg, end, side * w), f["edge_point"]])]
    inner = [np.array([leg_point(roundabout, leg, end, 0.0), leg_point(roundabout, leg, f["axial"], 0.0)])]
    a0, a1 = _angle(f["edge_point"], f["center"]), _angle(f["curb_point"], f["center"])
    sweep = _relative(a1, a0)
    n = arc_points(f["radius"], sweep, tol)
    curb.append(_arc(f["center"], f["radius"], a0, a0 + sweep, n))
    t = np.linspace(0.0, 1.0, n)[:, None]
    inner.append((1 - t) * leg_point(roundabout, leg, f["axial"], 0.0) + t * leg_point(roundabout, leg, ro, 0.0))
    theta_cp, theta_j = _angle(f["curb_point"], c), junction_angle(roundabout, leg, lane, offset)
    theta_cp = g.angle + _relative(theta_cp, g.angle)
    n = max(arc_points(ro, theta_j - theta_cp, tol), 2 * arc_points(inner_radius, theta_j - g.angle, tol))
    curb.append(_arc(c, ro, theta_cp, theta_j, n))
    tau = np.linspace(0.0, 1.0, n)
    angle = g.angle + (theta_j - g.angle) * tau**2
    radius = ro - (ro - inner_radius) * (2 * tau - tau**2)
    inner.append(c + radius[:, None] * np.stack([np.cos(angle), np.sin(angle)], -1))
    return _dedupe(np.vstack(curb), np.vstack(inner))


# --------------------------------------------------------------------------- the network


def roundabout_lanelets(roundabout: Roundabout, ring_lanes: int = 1, tolerance: float = TOLERANCE) -> RoundaboutNetwork:
    """The roundabout's lanelets (see the module docstring).

    Parameters
    ----------
    roundabout : Roundabout
    ring_lanes : int
        Concentric lanes the ring roadway is split into (equal widths).
    tolerance : float
        m: the largest distance between a sampled circle's chords and the circle.

    Raises
    ------
    InputError
        ``--ring-lanes`` or ``--tolerance`` out of range, more than 99 legs, or a leg's fillets
        that leave no ring between two junctions.
    """
    if isinstance(ring_lanes, bool) or not isinstance(ring_lanes, int) or not 1 <= ring_lanes <= MAX_RING_LANES:
        raise InputError("--ring-lanes", f"must be a whole number 1..{MAX_RING_LANES}, got {ring_lanes!r}")
    if not (isinstance(tolerance, float | int) and 1e-6 <= tolerance <= 0.1):
        raise InputError("--tolerance", f"must lie in [1e-6, 0.1] m, got {tolerance!r}")
    if len(roundabout.legs) > MAX_LEGS:
        raise InputError("roundabout.legs", f"at most {MAX_LEGS} legs can be exported, got {len(roundabout.legs)}")
    offset = junction_offset(roundabout)
    lanelets: dict[int, LaneletData] = {}
    entry = [100 + i for i in range(len(roundabout.legs))]
    exits = [200 + i for i in range(len(roundabout.legs))]
    ring = _ring(roundabout, ring_lanes, offset, tolerance, lanelets)
    _legs(roundabout, ring_lanes, offset, tolerance, lanelets, entry, exits)
    _link_junctions(roundabout, offset, lanelets, entry, exits, ring[0])
    apron = _apron(roundabout, offset, tolerance, lanelets) if roundabout.apron_width > 0 else None
    return RoundaboutNetwork(lanelets, entry, exits, ring, apron)


def _by_side(roundabout: Roundabout, outer: np.ndarray, inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) of a lanelet whose bounds are its curb or outer side and its inner side."""
    return (inner, outer) if roundabout.traffic == "right" else (outer, inner)


def _junctions(roundabout: Roundabout, offset: float) -> list[tuple[float, str, int]]:
    """Every junction as (angle in the circulation direction in [0, 2 pi), lane, leg), in that order."""
    c = roundabout.circulation
    found = [((c * junction_angle(roundabout, i, lane, offset)) % (2 * math.pi), lane, i)
             for i in range(len(roundabout.legs)) for lane in LANES]  # fmt: skip
    return sorted(found)


def ring_angles(roundabout: Roundabout, offset: float, tol: float) -> list[np.ndarray]:
    """The absolute angles (rad) at which each ring arc is sampled, the arcs from junction to junction in
    the circulation direction; every ring lane and the apron use them, so their shared bounds share vertices."""
    c, cuts = roundabout.circulation, [a for a, _, _ in _junctions(roundabout, offset)]
    out = []
    for j, a0 in enumerate(cuts):
        a1 = cuts[(j + 1) % len(cuts)] + (2 * math.pi if j + 1 == len(cuts) else 0.0)
        out.append(c * np.linspace(a0, a1, arc_points(roundabout.outer_radius, a1 - a0, tol)))
    return out


def _circle(center, radius: float, angles: np.ndarray) -> np.ndarray:
    return np.asarray(center, float) + radius * np.stack([np.cos(angles), np.sin(angles)], -1)


def _ring(roundabout: Roundabout, lanes: int, offset: float, tol: float,
          lanelets: dict[int, LaneletData]) -> list[list[int]]:  # fmt: skip
    """The ring's arcs per lane, linked in the circulation direction and to their neighbour lanes."""
    ro, centre = roundabout.outer_radius, roundabout.center
    width = roundabout.circulatory_width / lanes
    arcs = ring_angles(roundabout, offset, tol)
    ids = [[1000 * (lane + 1) + j for j in range(len(arcs))] for lane in range(lanes)]
    for lane in range(lanes):
        r_out, r_in = ro - lane * width, ro - (lane + 1) * width
        for j, angles in enumerate(arcs):
            outer, inner = _circle(centre, r_out, angles), _circle(centre, r_in, angles)
            left, right = _by_side(roundabout, outer, inner)
            item = LaneletData(ids[lane][j], left, right, predecessors=[ids[lane][j - 1]],
                               successors=[ids[lane][(j + 1) % len(arcs)]])  # fmt: skip
            outer_side = (ids[lane - 1][j], True) if lane > 0 else None
            inner_side = (ids[lane + 1][j], True) if lane + 1 < lanes else None
            marks = ("dashed" if lane > 0 else "solid", "dashed" if lane + 1 < lanes else "solid")
            if roundabout.traffic == "right":
                item.adj_left, item.adj_right = inner_side, outer_side
                item.marking_left, item.marking_right = marks[1], marks[0]
            else:
                item.adj_left, item.adj_right = outer_side, inner_side
                item.marking_left, item.marking_right = marks
            lanelets[item.lanelet_id] = item
    return ids


def _legs(roundabout: Roundabout, lanes: int, offset: float, tol: float, lanelets: dict[int, LaneletData],
          entry: list[int], exits: list[int]) -> None:  # fmt: skip
    """Each leg's entry and exit lanelet, adjacent in opposite directions across the leg's centre line."""
    inner_radius = roundabout.outer_radius - roundabout.circulatory_width / lanes
    for i in range(len(roundabout.legs)):
        for lane, ids in (("entry", entry), ("exit", exits)):
            curb, centre_side = leg_bounds(roundabout, i, lane, offset, inner_radius, tol)
            if lane == "exit":  # driven outwards
                curb, centre_side = curb[::-1], centre_side[::-1]
            left, right = _by_side(roundabout, curb, centre_side)
            item = LaneletData(ids[i], left, right)
            other = (exits if lane == "entry" else entry)[i]
            if roundabout.traffic == "right":
                item.adj_left, item.marking_left, item.marking_right = (other, False), "solid", "solid"
            else:
                item.adj_right, item.marking_left, item.marking_right = (other, False), "solid", "solid"
            lanelets[item.lanelet_id] = item


def _link_junctions(roundabout: Roundabout, offset: float, lanelets: dict[int, LaneletData], entry: list[int],
                    exits: list[int], outer_ring: list[int]) -> None:  # fmt: skip
    """An entry's successor is the outer ring arc that starts at its junction; an exit's predecessor the arc
    that ends at its own."""
    for j, (_, lane, leg) in enumerate(_junctions(roundabout, offset)):
        if lane == "entry":
            lanelets[entry[leg]].successors.append(outer_ring[j])
            lanelets[outer_ring[j]].predecessors.append(entry[leg])
        else:
            before = outer_ring[j - 1]
            lanelets[before].successors.append(exits[leg])
            lanelets[exits[leg]].predecessors.append(before)


def _apron(roundabout: Roundabout, offset: float, tol: float, lanelets: dict[int, LaneletData]) -> int:
    """The apron: one closed border lanelet round the island, in the circulation direction, its outer bound
    on the inner ring lane's vertices (so that their union has no crack along the circle Ri)."""
    arcs = ring_angles(roundabout, offset, tol)
    angles = np.concatenate([arcs[0], *(a[1:] for a in arcs[1:])])
    outer = _circle(roundabout.center, roundabout.inner_radius, angles)
    inner = _circle(roundabout.center, roundabout.island_radius, angles)
    outer[-1], inner[-1] = outer[0], inner[0]  # closed: the same point, not one 2 pi on
    left, right = _by_side(roundabout, outer, inner)
    lanelets[APRON_ID] = LaneletData(APRON_ID, left, right, kind="border", predecessors=[APRON_ID],
                                     successors=[APRON_ID], marking_left="solid", marking_right="solid")  # fmt: skip
    return APRON_ID


# --------------------------------------------------------------------------- writing and checking


def commonroad_xml(network: RoundaboutNetwork, map_name: str = "Roundabout",
                   source: str = "roundabout export-commonroad", dt: float = 0.1) -> bytes:  # fmt: skip
    """The network as a CommonRoad scenario file (XML bytes, format 2020a, no obstacles), by commonroad-io.

    The scenario id is ``ZAM_<map_name>-1`` (ZAM: an artificial map); ``dt`` its time step (s).
    """
    from commonroad.common.common_lanelet import LaneletType, LineMarking, RoadUser
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
    from commonroad.scenario.scenario import Location, Scenario, ScenarioID, Tag

    items = []
    for d in network.lanelets.values():
        left, right = np.asarray(d.left, float), np.asarray(d.right, float)
        items.append(Lanelet(
            left, (left + right) / 2, right, d.lanelet_id, predecessor=list(d.predecessors),
            successor=list(d.successors),
            adjacent_left=d.adj_left[0] if d.adj_left else None,
            adjacent_left_same_direction=d.adj_left[1] if d.adj_left else None,
            adjacent_right=d.adj_right[0] if d.adj_right else None,
            adjacent_right_same_direction=d.adj_right[1] if d.adj_right else None,
            line_marking_left_vertices=LineMarking(d.marking_left),
            line_marking_right_vertices=LineMarking(d.marking_right),
            lanelet_type={LaneletType.BORDER if d.kind == "border" else LaneletType.URBAN},
            user_one_way={RoadUser.VEHICLE},
        ))  # fmt: skip
    name = "".join(ch for ch in map_name.title() if ch.isalnum()) or "Roundabout"
    scenario = Scenario(dt=dt, scenario_id=ScenarioID(country_id="ZAM", map_name=name, map_id=1))
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list(items))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "map.xml"
        writer = CommonRoadFileWriter(scenario, PlanningProblemSet(), author="roundabout-ocp", affiliation="",
                                      source=source, tags={Tag.URBAN}, location=Location())  # fmt: skip
        writer.write_to_file(str(path), OverwriteExistingFile.ALWAYS)
        return path.read_bytes()


def corridor_mismatch(roundabout: Roundabout, route: Route, lanelet_corridor, apron: bool = False) -> dict[str, float]:
    """The symmetric difference between a corridor of the map and the parametric one.

    Parameters
    ----------
    roundabout, route : the parametric roundabout and the route.
    lanelet_corridor : shapely geometry
        The union of the route's corridor lanelets in the exported map (``MapRoute.lanes`` or ``with_apron``).
    apron : bool
        Compare with the parametric corridor that includes the apron.

    Returns
    -------
    dict
        ``area`` of the parametric corridor (m^2), ``difference`` (m^2: the symmetric difference),
        ``fraction`` (difference / area), ``outside`` (m^2 of the map corridor outside the parametric
        one) and ``missing`` (m^2 of the parametric corridor the map misses).
    """
    exact = corridor(roundabout, route, apron=apron).polygon
    outside = shapely.difference(lanelet_corridor, exact).area
    missing = shapely.difference(exact, lanelet_corridor).area
    return {"area": float(exact.area), "difference": float(outside + missing),
            "fraction": float((outside + missing) / exact.area), "outside": float(outside),
            "missing": float(missing)}  # fmt: skip


def route_lanelets(network: RoundaboutNetwork, roundabout: Roundabout, route: Route) -> tuple[int, int]:
    """(from_lanelet, to_lanelet) of a parametric route: its entry leg's entry and its exit leg's exit lanelet."""
    return network.entry[route.enter], network.exit[exit_leg(roundabout, route)]
