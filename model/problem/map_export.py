"""One geometry, two routes: a roundabout scenario as a CommonRoad map and a map scenario on it.

``export_commonroad`` turns the ``[roundabout]`` of a scenario document into a lanelet map
(``model.scene.roundabout_map``) and the document itself into a map scenario (docs/map-format.md)
that poses the same manoeuvre on that map: the same vehicle, bounds, problem and boundary values,
``[map] file`` the exported file, ``[route]`` from the entry leg's entry lanelet to the exit leg's
exit lanelet with the offsets of the parametric start and goal. Before anything is returned, the map
is read back by commonroad-io and our own reader and the map scenario parsed as ``roundabout solve``
parses it, so what is returned is known to load.
"""

from __future__ import annotations

import copy
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from model.problem.scenario import parse_scenario
from model.problem.tables import toml_text
from model.scene.lanelet_map import CentreLine, LaneletMap, MapRoute, read_map
from model.scene.road import Road
from model.scene.roundabout_map import (
    TOLERANCE,
    RoundaboutNetwork,
    commonroad_xml,
    corridor_mismatch,
    roundabout_lanelets,
    route_lanelets,
)

DROPPED = ("roundabout", "route", "traffic")  # tables the map scenario does not take over


@dataclass
class Export:
    """What ``export_commonroad`` makes.

    Attributes
    ----------
    xml : bytes
        The CommonRoad map.
    toml : str
        The map scenario (its ``map.file`` the relative path it was given).
    network : RoundaboutNetwork
    route : MapRoute
        The map scenario's route, on the map as read back from ``xml``.
    mismatch : dict
        Per body corridor ("lanes", and "with_apron" where the map has an apron), the symmetric
        difference with the parametric corridor (``corridor_mismatch``).
    pose_error : dict
        ``start`` and ``goal``: the distance (m) and heading difference (rad) between the map
        scenario's pose and the parametric one.
    """

    xml: bytes
    toml: str
    network: RoundaboutNetwork
    route: MapRoute
    mismatch: dict[str, dict[str, float]]
    pose_error: dict[str, dict[str, float]]


def export_commonroad(data: dict[str, Any], road: Road, map_file: str, ring_lanes: int = 1,
                      tolerance: float = TOLERANCE) -> Export:  # fmt: skip
    """The CommonRoad map of a roundabout scenario and the map scenario of the same manoeuvre.

    Parameters
    ----------
    data : dict
        The roundabout scenario's TOML document (already valid).
    road : Road
        Its parsed roundabout and route.
    map_file : str
        ``map.file`` as the map scenario will name it (relative to the map scenario's folder).
    ring_lanes, tolerance
        As in ``roundabout_lanelets``.

    Raises
    ------
    InputError
        A roundabout that cannot be exported, or a map scenario that does not load (the key at fault).
    """
    network = roundabout_lanelets(road.roundabout, ring_lanes, tolerance)
    xml = commonroad_xml(network, str(data.get("name", "Roundabout")))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "map.xml"
        path.write_bytes(xml)
        lanelet_map = read_map(path)
        document = map_document(data, network, road, lanelet_map, ring_lanes)
        probe = copy.deepcopy(document)
        probe["map"]["file"] = str(path)
        scenario = parse_scenario(probe, default_name=str(data.get("name", "scenario")), path=Path(folder) / "s.toml")
        route = scenario.ocp.map_route
        mismatch = {"lanes": corridor_mismatch(road.roundabout, road.route, route.lanes)}
        if network.apron is not None:
            mismatch["with_apron"] = corridor_mismatch(road.roundabout, road.route, route.with_apron, apron=True)
        errors = {"start": pose_error(route.start(), road.start()), "goal": pose_error(route.goal(), road.goal())}
    document["map"]["file"] = map_file
    return Export(xml, header(data) + toml_text(document), network, route, mismatch, errors)


def map_document(data: dict[str, Any], network: RoundaboutNetwork, road: Road, lanelet_map: LaneletMap,
                 ring_lanes: int) -> dict[str, Any]:  # fmt: skip
    """The map scenario's document: ``data`` with ``[map]`` and a map ``[route]`` for its roundabout tables."""
    first, last = route_lanelets(network, road.roundabout, road.route)
    entry = CentreLine(np.asarray(lanelet_map.lanelet(first).center_vertices, float))
    leave = CentreLine(np.asarray(lanelet_map.lanelet(last).center_vertices, float))
    start_offset = float(entry.project(np.array(road.start()[:2]))[()])
    goal_offset = float(leave.project(np.array(road.goal()[:2]))[()]) - leave.length
    route: dict[str, Any] = {"from_lanelet": first, "to_lanelet": last, "start_offset": round(start_offset, 6)}
    if goal_offset < -1e-6:  # otherwise the goal is the lanelet's end, the default
        route["goal_offset"] = round(goal_offset, 6)
    if ring_lanes > 1:
        route["lane_changes"] = True
    if network.apron is not None:
        route["apron_lanelets"] = [network.apron]
        route["apron_use"] = road.roundabout.apron_use
    out: dict[str, Any] = {}
    for key, value in data.items():
        if key == "roundabout":
            out["map"] = {"file": ""}
        elif key == "route":
            out["route"] = route
        elif key not in DROPPED:
            out[key] = copy.deepcopy(value)
    if "name" in out:
        out["name"] = f"{out['name']}-map"
    return out


def header(data: dict[str, Any]) -> str:
    """The map scenario's first lines: where it comes from."""
    name = data.get("name", "the scenario")
    return (f"# Written by `roundabout export-commonroad` from {name}: the same manoeuvre on the exported\n"
            "# CommonRoad map ([map] file), for `roundabout solve` (docs/map-format.md).\n\n")  # fmt: skip


def pose_error(pose: tuple[float, float, float], reference: tuple[float, float, float]) -> dict[str, float]:
    """Distance (m) and heading difference (rad, not wrapped) between two poses (x, y, heading)."""
    return {"distance": float(math.hypot(pose[0] - reference[0], pose[1] - reference[1])),
            "heading": float(pose[2] - reference[2])}  # fmt: skip
