"""The road tables of a scenario file: [roundabout], [[roundabout.legs]] and [route] (roundabout-format.md)."""

from __future__ import annotations

from typing import Any

from model.errors import InputError
from model.problem.tables import array_of_tables, no_unknown, number
from model.scene.lanelet_map import MapRoute
from model.scene.road import Road
from model.scene.roundabout import Leg, Roundabout, Route

ROUNDABOUT_KEYS = {"center", "inscribed_diameter", "circulatory_width", "apron_width", "apron_use", "traffic", "legs"}
LEG_KEYS = {"angle", "lane_width", "entry_radius", "exit_radius", "length"}
ROUTE_KEYS = {"enter", "exit", "start_distance", "goal_distance"}
FREE_AT_START = ("phi", "theta1")  # the only states [initial] / [final] may set beside a route


def parse_road(data: dict[str, Any]) -> Road | None:
    """The Road of a scenario document, or None without a [roundabout]."""
    if "roundabout" not in data and "route" not in data:
        return None
    if "obstacles" in data and "roundabout" in data:
        raise InputError("obstacles", "a scenario has either [[obstacles]] or a [roundabout], not both")
    for key in ("roundabout", "route"):
        if key not in data:
            raise InputError(key, f"missing: a {'[route]' if key == 'route' else '[roundabout]'} needs it")
        if not isinstance(data[key], dict):
            raise InputError(key, f"must be a table ([{key}])")
    table = data["roundabout"]
    no_unknown(table, ROUNDABOUT_KEYS, "roundabout.")
    for key in ("center", "inscribed_diameter", "circulatory_width", "legs"):
        if key not in table:
            raise InputError(f"roundabout.{key}", "missing")
    roundabout = Roundabout(
        center=table["center"],
        inscribed_diameter=number(table, "inscribed_diameter", "roundabout."),
        circulatory_width=number(table, "circulatory_width", "roundabout."),
        apron_width=number(table, "apron_width", "roundabout.", 0.0),
        apron_use=table.get("apron_use", "trailer"),
        traffic=table.get("traffic", "right"),
        legs=_legs(table["legs"]),
    )
    route = data["route"]
    no_unknown(route, ROUTE_KEYS, "route.")
    for key in ("enter", "exit"):
        if key not in route:
            raise InputError(f"route.{key}", "missing")
    road = Road(roundabout, Route(route["enter"], route["exit"], number(route, "start_distance", "route.", 30.0),
                                  number(route, "goal_distance", "route.", 30.0)))  # fmt: skip
    road.start(), road.goal()  # checks the route's indices and distances
    return road


def _legs(items: Any) -> list[Leg]:
    if not items:
        raise InputError("roundabout.legs", "must be one or more [[roundabout.legs]] tables")
    legs = []
    for _, where, item in array_of_tables(items, "roundabout.legs"):
        no_unknown(item, LEG_KEYS, where)
        for key in ("angle", "lane_width", "entry_radius", "exit_radius"):
            if key not in item:
                raise InputError(where + key, "missing")
        values = {k: number(item, k, where) for k in LEG_KEYS if k in item}
        legs.append(Leg(values.pop("angle"), **values))
    return legs



def road_boundary_values(road: Road | MapRoute, initial: dict[str, float], final: dict[str, float],
                         states) -> tuple[dict, dict]:  # fmt: skip
    """[initial] and [final] of a routed scenario (a roundabout's or a map's): the route's poses plus
    phi / theta1 where given."""
    for where, values in (("initial", initial), ("final", final)):
        for key in values:
            if key not in FREE_AT_START:
                raise InputError(f"{where}.{key}", "set by the [route]: only phi and theta1 may be given with a route")
    x, y, theta = road.start()
    start = {"x": x, "y": y, "theta": theta, "phi": 0.0, "theta1": theta}
    gx, gy, gtheta = road.goal()
    goal = {"x": gx, "y": gy, "theta": gtheta}
    start = {k: v for k, v in {**start, **initial}.items() if k in states}
    goal = {k: v for k, v in {**goal, **final}.items() if k in states}
    return start, goal
