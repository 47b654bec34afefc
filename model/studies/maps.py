"""A designer's turning-path study on a real roundabout (issue 21, item 7): every movement of a lanelet map.

Movements. ``movements`` enumerates them from the map's lanelet graph: an *entry* is a drivable
lanelet without a drivable predecessor (where traffic comes into the map), an *exit* one without a
drivable successor (where it leaves); a movement is an entry and an exit that a route of
successors connects through the circulating ring (the drivable lanelets on a cycle of the graph,
``ring_lanelets``). At Kackertstrasse: entries 11, 90, 104, 106, exits 19, 64, 84, 85, 102, so 20
movements (4 of them U-turns); the pair 18 -> 13, which bypasses the ring, is not one.

A cell (a vehicle preset, a movement, with or without the apron): ``cell_document`` makes its
scenario document from a template (a map scenario's TOML without ``[vehicle]`` and with the
route's apron lanelets): the preset, ``from_lanelet`` the entry, ``to_lanelet`` and the offsets
chosen so that every body's exact rectangle stands inside the corridor at the start and at the goal
(``route_poses``), ``apron_use`` as in the design-vehicle table (``model.studies.roads``): "trailer"
for an articulated vehicle, "all" for a single-unit truck, "none" for the passenger car P; without
the apron no apron lanelets at all. ``cell_measures`` reads what a designer reports from a solved
trajectory: the least exact clearance (nodes, sub-steps), the apron used (the area the bodies sweep
on the apron lanelets outside the lanes, and how deep they reach into it), the lanelets used.
``solve_cell`` solves a cell again on 2N where it fails only between the nodes.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import shapely

from model.analysis.bodies import swept_polygons
from model.analysis.validation import failed_checks, fails_only_between_nodes
from model.errors import InputError
from model.problem.maps import pose_clearances
from model.problem.ocp import OCP
from model.scene.lanelet_map import LaneletMap, MapRoute, shortest_path
from model.studies.roads import operational_document, preset_vehicle
from model.vehicles import VEHICLES, preset

MARGIN = 0.5  # m: first try, the start and goal this far clear of the vehicle's reach along the route
STEP = 1.0  # m: the start or goal moved by this much along the route while a body is outside the corridor
DRAWN = 0.01  # m: the swept paths kept in a cell's record are simplified to this (they are only drawn)
SAMPLE = 0.05  # m: spacing of the points at which the depth on the apron is measured
GAP = 0.1  # m: a lanelet's end this deep inside another drivable lanelet is a link the map leaves out


@dataclass(frozen=True)
class Movement:
    """An entry lanelet to an exit lanelet of a map, with the route's lanelets between them."""

    entry: int
    exit: int
    lanelets: tuple[int, ...]

    @property
    def name(self) -> str:
        """``"<entry>-<exit>"``, e.g. ``"90-102"`` (the cell names use it)."""
        return f"{self.entry}-{self.exit}"


def drivable_graph(lanelet_map: LaneletMap) -> dict[int, list[int]]:
    """The drivable lanelets and their drivable successors."""
    ids = [i for i in sorted(lanelet_map.ids) if lanelet_map.drivable(i)]
    keep = set(ids)
    return {i: [j for j in lanelet_map.successors(i) if j in keep] for i in ids}


def linked_graph(lanelet_map: LaneletMap) -> dict[int, list[int]]:
    """The drivable graph with the links a map leaves out.

    A lanelet without a drivable successor whose centre line ends inside another drivable lanelet
    leads into it; one without a drivable predecessor whose centre line begins inside another is
    led into from it (Neuweiler's ring, open in the map: 177 ends inside 150 and 152, 158 begins
    inside 155, the north entry 160 ends inside 159 and 163). Kackertstrasse and Thiergarten have
    no such ends.
    """
    graph = drivable_graph(lanelet_map)
    has_pred = {j for nexts in graph.values() for j in nexts}
    linked = {i: list(nexts) for i, nexts in graph.items()}
    for i, nexts in graph.items():
        if not nexts:
            linked[i] += _containing(lanelet_map, graph, i, -1)
        if i not in has_pred:
            for j in _containing(lanelet_map, graph, i, 0):
                linked[j].append(i)
    return linked


def _containing(lanelet_map: LaneletMap, graph: Mapping[int, list[int]], lanelet_id: int, end: int) -> list[int]:
    """The other drivable lanelets inside which the centre line's first (``end`` 0) or last (-1) point lies."""
    point = shapely.Point(lanelet_map.lanelet(lanelet_id).center_vertices[end])
    return [j for j in graph if j != lanelet_id and lanelet_map.polygon(j).buffer(-GAP).contains(point)]


def entries_and_exits(lanelet_map: LaneletMap) -> tuple[list[int], list[int]]:
    """Drivable lanelets without a predecessor (entries) and without a successor (exits) in ``linked_graph``."""
    graph = linked_graph(lanelet_map)
    has_pred = {j for nexts in graph.values() for j in nexts}
    return sorted(i for i in graph if i not in has_pred), sorted(i for i, nexts in graph.items() if not nexts)


def ring_lanelets(lanelet_map: LaneletMap) -> list[int]:
    """The drivable lanelets on a cycle of ``linked_graph`` (a roundabout's circulating ring), sorted."""
    graph = linked_graph(lanelet_map)
    return sorted(i for i in graph if i in _reach(graph, graph[i]))


def _reach(graph: Mapping[int, list[int]], seeds: list[int]) -> set[int]:
    seen, stack = set(seeds), list(seeds)
    while stack:
        for j in graph[stack.pop()]:
            if j not in seen:
                seen.add(j)
                stack.append(j)
    return seen


def movements(lanelet_map: LaneletMap) -> list[Movement]:
    """Every entry x exit that a route of successors connects through the ring, by entry then exit.

    The route is the shortest chain of successors (``model.scene.lanelet_map.shortest_path``), as a
    map scenario's ``[route]`` takes it. A map without a ring has no movements.
    """
    ring = set(ring_lanelets(lanelet_map))
    entries, exits = entries_and_exits(lanelet_map)
    out = []
    for a in entries:
        for b in exits:
            path = shortest_path(lanelet_map, a, b, lane_changes=False) if a != b else None
            lanelets = tuple(i for i, _ in path or [])
            if lanelets and ring & set(lanelets):
                out.append(Movement(a, b, lanelets))
    return out


def find_movement(lanelet_map: LaneletMap, name: str) -> Movement:
    """The movement named ``"<entry>-<exit>"``.

    Raises
    ------
    InputError
        ``movement``: no such movement in the map (the movements listed).
    """
    found = {m.name: m for m in movements(lanelet_map)}
    if name not in found:
        raise InputError("movement", f"{name!r} is not a movement of {lanelet_map.path.name} "
                         f"(movements: {', '.join(found) or 'none'})")  # fmt: skip
    return found[name]


# --------------------------------------------------------------------------- a cell's scenario


def apron_use(preset_name: str) -> str:
    """Who may mount the apron: "trailer" (articulated), "none" (the passenger car P) or "all" (single unit)."""
    roles = VEHICLES[preset(preset_name)["model"]].roles
    return "trailer" if roles.trailers else ("none" if preset_name == "P" else "all")


def straight_state(preset_name: str, heading: float = 0.0) -> dict[str, float]:
    """The preset's state at the origin, heading ``heading``, wheels straight, any trailer in line."""
    vehicle = preset_vehicle(preset_name)[0]
    r = vehicle.roles
    state = {r.x: 0.0, r.y: 0.0, r.heading: heading, **{t: heading for t in r.trailers}}
    return state | ({r.steering: 0.0} if r.steering else {})


def route_poses(lanelet_map: LaneletMap, movement: Movement, preset_name: str, apron_lanelets: tuple[int, ...],
                use: str, gap: float = 0.0) -> dict[str, float | int]:  # fmt: skip
    """The route keys ``from_lanelet``, ``to_lanelet``, ``start_offset``, ``goal_offset`` of a cell.

    The start: the least offset (from ``MARGIN`` behind the vehicle's rear reach, in ``STEP``s) at
    which every body's exact rectangle is inside its corridor, heading along the route. The goal:
    on the last lanelet after the ring where some offset from ``MARGIN`` ahead of the vehicle's
    front reach before its end (back in ``STEP``s, up to its start) puts every body inside.

    Raises
    ------
    InputError
        ``movement``: no start or no goal pose of the vehicle lies inside the corridor.
    """
    vehicle, bodies, _ = preset_vehicle(preset_name)
    rear, front = reach(preset_name)
    r = vehicle.roles
    ring = set(ring_lanelets(lanelet_map))
    last = max(k for k, i in enumerate(movement.lanelets) if i in ring)
    for to_lanelet in reversed(movement.lanelets[last + 1:]):
        length = lanelet_map.lengths[to_lanelet]
        offset = -(front + MARGIN)
        while offset <= 0.0 and offset >= -length:
            route = MapRoute(lanelet_map, movement.entry, to_lanelet, goal_offset=offset,
                             apron_lanelets=apron_lanelets, apron_use=use, apron_gap=gap)  # fmt: skip
            x, y, heading = route.goal()
            goal = straight_state(preset_name, heading) | {r.x: x, r.y: y}
            if min(pose_clearances(route, vehicle, bodies, goal).values()) >= 0:
                start = _start_offset(route, preset_name, rear)
                return {"from_lanelet": movement.entry, "to_lanelet": to_lanelet, "start_offset": start,
                        "goal_offset": offset}  # fmt: skip
            offset -= STEP
    raise InputError("movement", f"{movement.name}: no goal pose of the {preset_name} lies inside the corridor")


def _start_offset(route: MapRoute, preset_name: str, rear: float) -> float:
    vehicle, bodies, _ = preset_vehicle(preset_name)
    r = vehicle.roles
    offset = rear + MARGIN
    while offset <= route.goal_s:
        moved = MapRoute(route.map, route.from_lanelet, route.to_lanelet, start_offset=offset,
                         goal_offset=route.goal_offset, apron_lanelets=route.apron_lanelets,
                         apron_use=route.apron_use, apron_gap=route.apron_gap)  # fmt: skip
        x, y, heading = moved.start()
        state = straight_state(preset_name, heading) | {r.x: x, r.y: y}
        if min(pose_clearances(moved, vehicle, bodies, state).values()) >= 0:
            return float(offset)
        offset += STEP
    raise InputError("movement", f"{route.from_lanelet}-{route.to_lanelet}: no start pose of the {preset_name} "
                     "lies inside the corridor")  # fmt: skip


def reach(preset_name: str) -> tuple[float, float]:
    """How far the preset's bodies reach behind and ahead of its reference point when straight, m."""
    from model.studies.roads import corners

    vehicle, bodies, _ = preset_vehicle(preset_name)
    xs = np.concatenate([c[..., 0].ravel() for c in corners(vehicle, bodies, straight_state(preset_name)).values()])
    return float(-xs.min()), float(xs.max())


def cell_name(preset_name: str, movement: str, apron: bool) -> str:
    """The cell's file-name key, e.g. ``SU-30_90-102_apron`` (``_noapron`` without it)."""
    return f"{preset_name}_{movement}_{'apron' if apron else 'noapron'}"


def parse_cell(name: str) -> tuple[str, str, bool]:
    """Inverse of ``cell_name``: (preset, movement, apron).

    Raises
    ------
    InputError
        ``cell``: not of the form ``<preset>_<entry>-<exit>_apron`` or ``..._noapron``.
    """
    parts = name.rsplit("_", 2)
    if len(parts) != 3 or parts[2] not in ("apron", "noapron") or parts[1].count("-") != 1:
        raise InputError("cell", f"{name!r} is not <preset>_<entry>-<exit>_apron or _noapron")
    return parts[0], parts[1], parts[2] == "apron"


def cell_document(template: dict, lanelet_map: LaneletMap, preset_name: str, movement: str, apron: bool,
                  intervals: int, operational: bool = False) -> dict:  # fmt: skip
    """One cell's scenario document: the template with the preset, the movement's route and the apron set.

    Parameters
    ----------
    template : dict
        A map scenario document: ``[map]``, ``[bounds]`` (``phi`` kept only for a preset without a
        steering limit, ``articulation`` only for an articulated vehicle), ``[route] apron_lanelets``.
    lanelet_map : LaneletMap
        The template's map, read.
    preset_name, movement, apron, intervals
        The preset, the movement's name ``"<entry>-<exit>"``, whether the apron lanelets may be used
        (by the bodies ``apron_use`` allows), N.
    operational : bool
        At the preset's operational limits (``model.studies.roads.operational_document``: the template's
        speed bound that of ``v``, entering at the crawl speed, leaving at any speed).

    Raises
    ------
    InputError
        ``movement`` (not in the map, or no pose inside the corridor), ``preset`` (unknown).
    """
    data = preset(preset_name)
    roles = VEHICLES[data["model"]].roles
    found = find_movement(lanelet_map, movement)
    doc = copy.deepcopy(template)
    doc["vehicle"] = {"preset": preset_name}
    if operational:
        operational_document(doc, preset_name)
    bounds = doc.setdefault("bounds", {})
    if roles.steering in data.get("bounds", {}):
        bounds.pop(roles.steering, None)
    if not roles.trailers:
        bounds.pop("articulation", None)
    use = apron_use(preset_name) if apron else "none"
    aprons = tuple(doc.get("route", {}).get("apron_lanelets", [])) if apron else ()
    gap = float(doc.get("route", {}).get("apron_gap", 0.0)) if apron else 0.0
    doc["route"] = {**route_poses(lanelet_map, found, preset_name, aprons, use, gap), "apron_lanelets": list(aprons),
                    "apron_use": use, "apron_gap": gap}  # fmt: skip
    doc["problem"] = {**doc.get("problem", {}), "objective": "time", "intervals": int(intervals)}
    doc["name"] = cell_name(preset_name, movement, apron)
    doc["title"] = (f"{preset_name} from lanelet {found.entry} to lanelet {found.exit} "
                    + ("with the apron" if apron else "without the apron"))  # fmt: skip
    return doc


# --------------------------------------------------------------------------- what a designer reads


def apron_use_measures(ocp: OCP, states: Mapping[str, np.ndarray], apron_lanelets: tuple[int, ...]) -> dict:
    """The apron the bodies use: the area they sweep on the apron region outside the corridor's lanes (the
    apron lanelets and, with ``route.apron_gap``, the paved strip between them and the lanes; m^2) and how deep
    they reach into it from the lanes (m, the largest distance of a swept point on the apron from the lanes);
    both 0 without apron lanelets or where no body leaves the lanes."""
    route = ocp.map_route
    if not apron_lanelets or not ocp.bodies:
        return {"apron_area_m2": 0.0, "apron_used_m": 0.0}
    swept = shapely.union_all(list(swept_polygons(ocp, states).values()))
    apron = route.with_apron.difference(route.lanes)
    on_apron = swept.intersection(apron)
    if on_apron.is_empty or on_apron.area <= 0:
        return {"apron_area_m2": 0.0, "apron_used_m": 0.0}
    points = shapely.get_coordinates(shapely.segmentize(on_apron.boundary, SAMPLE))
    depth = float(np.max(shapely.distance(shapely.points(points), route.lanes)))
    return {"apron_area_m2": float(on_apron.area), "apron_used_m": depth}


def simplified(collection: dict, tolerance: float = DRAWN) -> dict:
    """A GeoJSON FeatureCollection of polygons with each geometry simplified to ``tolerance`` m (for drawing)."""
    features = [{**f, "geometry": shapely.geometry.mapping(shapely.simplify(shapely.geometry.shape(f["geometry"]),
                                                                            tolerance))}
                for f in collection["features"]]  # fmt: skip
    return {**collection, "features": features}


def apron_gap(route: MapRoute) -> float | None:
    """The least distance (m) from the corridor's lanes to its apron lanelets; None without apron lanelets.

    0 where they touch; more where the map leaves a strip between them that no lanelet covers (at
    Kackertstrasse the border lanelet 50 lies 2.1 m inside the ring's inner edge): a body reaches such an
    apron only with a route ``apron_gap`` wider than this (docs/map-format.md), which paves the strip.
    """
    if not route.apron_lanelets:
        return None
    return float(shapely.union_all([route.map.polygon(i) for i in route.apron_lanelets]).distance(route.lanes))


def solve_cell(ocp: OCP, intervals: int):
    """The cell's minimum-time solve: on ``intervals``, and once more on twice as many where it fails only
    between the nodes (every body inside at the nodes, a corner cut between two of them: the grid is too
    coarse, not the road too narrow).

    Returns
    -------
    tuple
        The last Solution and the list of (N, status, valid, failed checks) of each solve.
    """
    solution, tried = None, []
    for n in (intervals, 2 * intervals):
        solution = ocp.solve(intervals=n)
        failed = list(failed_checks(solution.validation))
        tried.append({"intervals": n, "status": solution.status, "valid": bool(solution.ok), "failed_checks": failed})
        if solution.ok or not fails_only_between_nodes(solution.validation):
            break
    return solution, tried


def cell_measures(ocp: OCP, solution) -> dict:
    """A cell's record of a solve: status, valid, Tf, clearances, apron used, lanelets, diagnosis if not valid.

    Parameters
    ----------
    ocp : OCP
        The cell's problem (with a ``map_route``).
    solution : Solution
        Its solve (on ``ocp``'s route or, from the search's last step, on its loop round the ring); the
        apron is measured, and the swept path (GeoJSON, simplified to ``DRAWN``) kept,
        only if it is valid.
    """
    measures = solution.validation.get("measures", {})
    lateral, longitudinal = measures.get("lateral_acceleration") or {}, measures.get("longitudinal") or {}
    route = solution.ocp.map_route  # the cell's route, or its loop round the ring (``model.search.maps``)
    out = {
        "status": solution.status,
        "valid": bool(solution.ok),
        "final_time": solution.final_time,
        "iterations": solution.iterations,
        "min_clearance": measures.get("min_clearance"),
        "min_clearance_dense": measures.get("min_clearance_dense"),
        "route_lanelets": list(route.lanelets),
        "route_loops": route.loops,
        "corridor_lanelets": list(route.corridor_lanelets),
        "lanelets_used": measures.get("lanelets_used"),
        "solves": len((solution.search or {}).get("solves", [])),
        "apron_gap_m": apron_gap(route),
        "max_abs_lateral_acceleration": lateral.get("max_abs_nodes"),
        "max_acceleration": longitudinal.get("max_acceleration"),
        "min_acceleration": longitudinal.get("min_acceleration"),
    }
    if solution.ok:
        states = {k: np.asarray(solution.columns[k]) for k in ("t", *ocp.vehicle.states)}
        out |= apron_use_measures(ocp, states, route.apron_lanelets)
        out["swept_path"] = simplified(solution.swept_path())
    else:
        diagnosis = solution.diagnosis or {"message": f"solver status {solution.status}, validation failed"}
        out["diagnosis"] = diagnosis
    return out
