"""The road tables of a scenario file: [roundabout], [[roundabout.legs]] and [route] (roundabout-format.md)."""

from __future__ import annotations

from typing import Any

from model.errors import InputError
from model.problem.tables import array_of_tables, no_unknown, number
from model.scene.lanelet_map import MapRoute
from model.scene.road import Road
from model.scene.roundabout import Leg, Roundabout, Route
from model.vehicles import Vehicle

ROUNDABOUT_KEYS = {"center", "inscribed_diameter", "circulatory_width", "apron_width", "apron_use", "traffic", "legs"}
LEG_KEYS = {"angle", "lane_width", "entry_radius", "exit_radius", "length"}
ROUTE_KEYS = {"enter", "exit", "start_distance", "goal_distance"}


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


def road_boundary_values(
    road: Road | MapRoute, initial: dict[str, float], final: dict[str, float], vehicle: Vehicle
) -> tuple[dict, dict]:
    """[initial] and [final] of a routed scenario (a roundabout's or a map's): the route's poses (the
    vehicle's position and heading, steering 0, the trailers in line at the start) plus the steering,
    the trailer headings and the longitudinal dynamics' states (``Vehicle.integrated_states``: v, a) where
    given; those left out of [final], and v and a left out of [initial], are free."""
    r = vehicle.roles
    free = tuple(s for s in (r.steering, *r.trailers) if s in vehicle.states) + vehicle.integrated_states
    for where, values in (("initial", initial), ("final", final)):
        for key in values:
            if key not in vehicle.states:
                raise InputError(f"{where}.{key}", f"not a state of the {vehicle.model} model")
            if key not in free:
                raise InputError(f"{where}.{key}", f"set by the [route]: only {' and '.join(free) or 'nothing'} "
                                 "may be given with a route")  # fmt: skip
    x, y, theta = road.start()
    start = {r.x: x, r.y: y, r.heading: theta, **({r.steering: 0.0} if r.steering else {})}
    start.update(dict.fromkeys(r.trailers, theta))
    gx, gy, gtheta = road.goal()
    goal = {r.x: gx, r.y: gy, r.heading: gtheta}
    return {**start, **initial}, {**goal, **final}
