"""The map tables of a scenario file: [map] and its [route] (docs/map-format.md).

``parse_map`` reads them into a ``MapRoute`` (model/scene/lanelet_map.py); ``check_poses``
refuses a start or goal at which a body's exact rectangle is not inside its corridor.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from model.errors import InputError
from model.problem.ocp import end_pose
from model.problem.tables import is_number, no_unknown, number
from model.scene.geometry import clearance
from model.scene.lanelet_map import MapRoute, dataset_file, read_map
from model.vehicles import Body, Vehicle

MAP_KEYS = {"file", "dataset"}
ROUTE_KEYS = {"from_lanelet", "to_lanelet", "start_offset", "goal_offset", "lane_changes", "apron_lanelets",
              "apron_use", "apron_gap"}  # fmt: skip
ROUNDABOUT_ROUTE_KEYS = {"enter", "exit", "start_distance", "goal_distance"}  # model/problem/roads.py


def parse_map(data: dict[str, Any], base: Path | None = None) -> MapRoute | None:
    """The MapRoute of a scenario document, or None without a [map].

    Parameters
    ----------
    data : dict
        The TOML document.
    base : Path, optional
        The folder a relative ``map.file`` is read from (the scenario file's); default the current one.

    Raises
    ------
    InputError
        Naming the key at fault (``map``, ``map.file``, ``map.dataset``, ``route.<key>``).
    """
    check_route_format(data)
    if "map" not in data:
        return None
    for other in ("roundabout", "obstacles"):
        if other in data:
            also = "[[obstacles]]" if other == "obstacles" else "[roundabout]"
            raise InputError("map", f"a scenario has one of [[obstacles]], [roundabout] or [map]; it also has {also}")
    table, route = data["map"], data.get("route")
    if not isinstance(table, dict):
        raise InputError("map", "must be a table ([map])")
    if not isinstance(route, dict):
        raise InputError("route", "missing: a [map] needs a [route] table (from_lanelet, to_lanelet, ...)")
    no_unknown(table, MAP_KEYS, "map.")
    no_unknown(route, ROUTE_KEYS, "route.")
    return MapRoute(
        map=_read(table, base or Path(".")),
        from_lanelet=_lanelet_id(route, "from_lanelet"),
        to_lanelet=_lanelet_id(route, "to_lanelet"),
        start_offset=number(route, "start_offset", "route.", 0.0),
        goal_offset=number(route, "goal_offset", "route.") if "goal_offset" in route else None,
        lane_changes=_flag(route, "lane_changes"),
        apron_lanelets=_ids(route.get("apron_lanelets", [])),
        apron_use=route.get("apron_use", "trailer"),
        apron_gap=number(route, "apron_gap", "route.", 0.0),
    )


def map_of(data: dict[str, Any], base: Path | None = None):
    """The LaneletMap that a scenario document's ``[map]`` names (its ``[route]`` not read).

    Raises
    ------
    InputError
        ``map``, ``map.file`` or ``map.dataset``, as ``parse_map``.
    """
    table = data.get("map")
    if not isinstance(table, dict):
        raise InputError("map", "missing or not a table ([map] with file or dataset)")
    no_unknown(table, MAP_KEYS, "map.")
    return _read(table, base or Path("."))


def check_route_format(data: dict[str, Any]) -> None:
    """A [route] has the keys of one format only: a map's with a [map], a roundabout's without."""
    route = data.get("route")
    if not isinstance(route, dict):
        return
    has_map = "map" in data
    mine, theirs = (ROUTE_KEYS, ROUNDABOUT_ROUTE_KEYS) if has_map else (ROUNDABOUT_ROUTE_KEYS, ROUTE_KEYS)
    foreign = sorted(route.keys() & theirs)
    if foreign:
        kind, this = ("[roundabout]", "a [map]") if has_map else ("[map]", "a [roundabout] (no [map] given)")
        raise InputError(f"route.{foreign[0]}", f"a key of a {kind} route; this [route] is one of {this}: "
                         f"{', '.join(sorted(mine))}")  # fmt: skip


def _read(table: dict[str, Any], base: Path):
    if ("file" in table) == ("dataset" in table):
        raise InputError("map", "give exactly one of map.file (a CommonRoad XML file) or map.dataset "
                         "(for example 'rounD/DEU_Kackertstrasse-1')")  # fmt: skip
    key = "file" if "file" in table else "dataset"
    value = table[key]
    if not isinstance(value, str) or not value:
        raise InputError(f"map.{key}", f"must be a non-empty string, got {value!r}")
    path = base / value if key == "file" else dataset_file(value)
    return read_map(path, key=f"map.{key}")


def _lanelet_id(route: dict[str, Any], key: str) -> int:
    if key not in route:
        raise InputError(f"route.{key}", "missing (a lanelet id of the map)")
    value = route[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"route.{key}", f"must be a lanelet id (a whole number), got {value!r}")
    return value


def _flag(route: dict[str, Any], key: str) -> bool:
    value = route.get(key, False)
    if not isinstance(value, bool):
        raise InputError(f"route.{key}", f"must be true or false, got {value!r}")
    return value


def _ids(value: Any) -> tuple[int, ...]:
    if not isinstance(value, list) or any(isinstance(v, bool) or not isinstance(v, int) for v in value):
        raise InputError("route.apron_lanelets", f"must be a list of lanelet ids, got {value!r}")
    return tuple(value)


def check_poses(route: MapRoute, vehicle: Vehicle, bodies: dict[str, Body], initial: dict[str, float],
                final: dict[str, float]) -> None:  # fmt: skip
    """Every body's exact rectangle inside its corridor at the start and at the goal.

    The goal leaves phi and a trailer's heading free; it is checked with the trailer aligned
    (theta1 = theta) unless [final] sets theta1.

    Raises
    ------
    InputError
        ``route.start_offset`` or ``route.goal_offset``, with the body and by how far it leaves the corridor.
    """
    for key, state in (("start_offset", initial), ("goal_offset", end_pose(vehicle, final, initial))):
        for name, gap in pose_clearances(route, vehicle, bodies, state).items():
            if gap < 0:
                where = "start" if key == "start_offset" else "goal"
                raise InputError(f"route.{key}", f"at the {where} the {name} body leaves the corridor by {-gap:.3f} m "
                                 f"(move the {where} along the route)")  # fmt: skip


def pose_clearances(route: MapRoute, vehicle: Vehicle, bodies: dict[str, Body],
                    state: dict[str, float]) -> dict[str, float]:  # fmt: skip
    """Signed clearance (m, >= 0 inside) of each body's rectangle in its corridor at one state (what it leaves
    free completed as ``end_pose`` says: the steering 0, the trailers in line, v and a 0)."""
    poses = vehicle.body_poses()
    columns = {k: np.array([v]) for k, v in end_pose(vehicle, state).items() if is_number(v)}
    out = {}
    for name, body in bodies.items():
        x, y, heading = vehicle.state_function(list(poses[name]))(columns)
        out[name] = clearance(route.corridor(name), body.corners(x[0], y[0], heading[0]))
    return out
