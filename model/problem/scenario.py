"""Scenario files (TOML) to OCP objects, with one clear error per bad key.

The format is the public contract in shared/scenario-format.md: unknown keys are
errors, every state is fixed at t = 0, any subset at Tf.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from model.errors import InputError
from model.problem.closed_loop import ControlSettings, Disturbance, PlantSettings, parse_closed_loop, parse_plant
from model.problem.costs import Energy, Time
from model.problem.maps import check_poses, parse_map
from model.problem.ocp import OCP, PASSES
from model.problem.roads import parse_road, road_boundary_values
from model.problem.tables import (
    array_of_tables,
    check_document,
    choice,
    is_number,
    no_unknown,
    number,
    numbers,
    string,
    table_of,
)
from model.problem.traffic import TrafficSettings, parse_traffic
from model.scene.moving import MovingVehicle
from model.scene.obstacles import Circle
from model.scene.roundabout import check_lane_width
from model.vehicles import VEHICLES, Body, Longitudinal, Vehicle, operational_limits, preset

TOP_KEYS = {
    "name", "title", "vehicle", "bounds", "obstacles", "initial", "final", "problem", "roundabout", "route",
    "disturbance", "control", "moving_obstacles", "map", "traffic", "plant",
}  # fmt: skip
PROBLEM_KEYS = {"objective", "final_time", "intervals", "scheme", "pass", "weights", "steering_weight"}
OBSTACLE_KEYS = {"center", "radius", "safety"}
MOVING_KEYS = {"length", "width", "safety", "trajectory", "start", "speed", "yaw_rate"}
OBJECTIVES = {"energy": Energy, "time": Time}


@dataclass
class Scenario:
    """A parsed scenario: the problem plus how to discretise it, and how its closed loop runs."""

    ocp: OCP
    intervals: int = 100
    scheme: str = "trapezoid"
    path: Path | None = None
    disturbance: Disturbance = field(default_factory=Disturbance)
    control: ControlSettings = field(default_factory=ControlSettings)
    traffic: TrafficSettings | None = None
    plant: PlantSettings = field(default_factory=PlantSettings)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; raise InputError naming the bad key."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8"))  # TOML is UTF-8 whatever the locale
    except FileNotFoundError:
        raise InputError("", f"{path}: no such file") from None
    except OSError as err:  # a folder, no permission, ...
        raise InputError("", f"{path}: cannot be read ({err.strerror or err})") from None
    except UnicodeDecodeError:
        raise InputError("", f"{path}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as err:
        raise InputError("", f"{path}: malformed TOML: {err}") from None
    except ValueError:  # tomllib lets int() refuse a literal of more than 4300 digits
        raise InputError("", f"{path}: malformed TOML: an integer with too many digits") from None
    except RecursionError:
        raise InputError("", f"{path}: malformed TOML: arrays or tables nested too deeply") from None
    return parse_scenario(data, default_name=path.stem, path=path)


def parse_scenario(data: dict[str, Any], default_name: str = "scenario", path: Path | None = None) -> Scenario:
    """Build a Scenario from the TOML document's dictionary."""
    check_document(data)
    no_unknown(data, TOP_KEYS, "")
    has_route = "route" in data or "map" in data  # the route sets the start: no [initial] needed
    required = ("vehicle", "bounds", "problem") if has_route else ("vehicle", "bounds", "initial", "problem")
    for key in required:
        if key not in data:
            raise InputError(key, "missing required table")
    vehicle, bodies, preset_bounds = _vehicle(table_of(data, "vehicle"))
    problem = table_of(data, "problem")
    no_unknown(problem, PROBLEM_KEYS, "problem.")
    objective = choice(problem, "objective", OBJECTIVES, "problem.", required=True)
    scheme = choice(problem, "scheme", {"trapezoid": None}, "problem.", default="trapezoid")
    passing = choice(problem, "pass", dict.fromkeys(PASSES), "problem.", default="auto")
    intervals = problem.get("intervals", 100)
    if isinstance(intervals, bool) or not isinstance(intervals, int) or intervals < 1:
        raise InputError("problem.intervals", f"must be a whole number >= 1, got {intervals!r}")
    final_time = number(problem, "final_time", "problem.") if "final_time" in problem else None
    disturbance, control = parse_closed_loop(data, vehicle)
    plant = parse_plant(data, vehicle, disturbance)
    map_route = parse_map(data, path.parent if path is not None else None)
    road = parse_road(data) if map_route is None else None
    traffic = parse_traffic(data, road)
    routed = road is not None or map_route is not None
    initial = numbers(table_of(data, "initial") if "initial" in data or not routed else {}, "initial.")
    final = numbers(table_of(data, "final") if "final" in data else {}, "final.")
    if road is not None:
        for body in bodies.values():
            check_lane_width(road.roundabout, body.width)
        initial, final = road_boundary_values(road, initial, final, vehicle)
    if map_route is not None:
        initial, final = road_boundary_values(map_route, initial, final, vehicle)
        check_poses(map_route, vehicle, bodies, initial, final)
    ocp = OCP(
        vehicle=vehicle,
        cost=_cost(objective, problem, vehicle),
        bounds=_all_bounds(vehicle, preset_bounds, _bounds(table_of(data, "bounds"))),
        initial=initial,
        final=final,
        obstacles=_obstacles(data.get("obstacles", [])),
        final_time=final_time,
        passing=passing,
        bodies=bodies,
        road=road,
        map_route=map_route,
        name=string(data, "name", default_name),
        title=string(data, "title", ""),
        moving_obstacles=_moving_obstacles(data.get("moving_obstacles", [])),
    )
    return Scenario(
        ocp=ocp, intervals=intervals, scheme=scheme, path=path,
        disturbance=disturbance, control=control, traffic=traffic, plant=plant,
    )  # fmt: skip


def _cost(objective: str, problem: dict[str, Any], vehicle: Vehicle):
    """The objective; ``weights`` = {control = w > 0} weighs the energy's squared controls.

    ``steering_weight`` = w >= 0 adds w * integral of u2^2 dt to the time objective.
    """
    if "steering_weight" in problem:
        if objective != "time":
            raise InputError(
                "problem.steering_weight", f"applies to the time objective only (objective = {objective!r})"
            )
        if vehicle.roles.turning is None:
            raise InputError("problem.steering_weight", f"the {vehicle.model} model has no steering-rate control")
        return Time(steering_weight=number(problem, "steering_weight", "problem."))
    if "weights" not in problem:
        return OBJECTIVES[objective]()
    if objective != "energy":
        raise InputError("problem.weights", f"weights the energy objective only (objective = {objective!r})")
    table = problem["weights"]
    if not isinstance(table, dict):
        raise InputError("problem.weights", f"must be a table {{u1 = w1, u2 = w2}}, got {table!r}")
    no_unknown(table, set(vehicle.controls), "problem.weights.")
    weights = {k: number(table, k, "problem.weights.") for k in table}
    for key, w in weights.items():
        if not w > 0:
            raise InputError(f"problem.weights.{key}", f"must be > 0, got {w:g}")
    return Energy(weights=weights)


BODY_TABLES = {"body": "vehicle", "trailer_body": "trailer"}  # [vehicle.<table>] -> body name
LONGITUDINAL_KEYS = {"acceleration", "jerk"}


def _vehicle(table: dict[str, Any]) -> tuple[Vehicle, dict[str, Body], dict[str, tuple[float, float]]]:
    """The vehicle, its bodies and the bounds its preset gives (the file's keys override the preset's)."""
    base, preset_bounds = _preset(table)
    merged = {**base, **table}
    model = choice(merged, "model", VEHICLES, "vehicle.", required=True)
    cls = VEHICLES[model]
    fields = {f.name for f in dataclasses.fields(cls)}
    no_unknown(table, fields | {"model", "preset", "longitudinal", "operational"} | set(BODY_TABLES), "vehicle.")
    kwargs = {k: number(merged, k, "vehicle.") for k in fields if k in merged}
    bodies = {}
    for key, name in BODY_TABLES.items():
        if key in merged:
            bodies[name] = _body({**base.get(key, {}), **_subtable(table, key, "vehicle.")}, f"vehicle.{key}")
    operational = _operational(table)
    longitudinal = {**operational.get("longitudinal", {}), **_subtable(table, "longitudinal", "vehicle.")}
    vehicle, limits = _longitudinal(cls(**kwargs), longitudinal)
    by_role = {"steering_rate": vehicle.roles.steering_rate, "speed": vehicle.roles.speed}
    extra = {by_role.get(key, key): pair for key, pair in operational.get("bounds", {}).items()}
    extra.pop(None, None)  # a model without a steering rate takes no steering-rate bound
    return vehicle, bodies, _speed_bound(vehicle, preset_bounds) | extra | limits


def _operational(table: dict[str, Any]) -> dict[str, Any]:
    """``[vehicle] operational = true``: the preset's ``[vehicle.longitudinal]`` and bounds (of the lateral
    acceleration, and by role of the speed and the steering rate), from ``operational_limits``; nothing when
    false or absent."""
    flag = table.get("operational", False)
    if not isinstance(flag, bool):
        raise InputError("vehicle.operational", f"must be true or false, got {flag!r}")
    if not flag:
        return {}
    if "preset" not in table:
        raise InputError("vehicle.operational", "needs a preset ([vehicle] preset = ...) whose limits it applies")
    limits = operational_limits(table["preset"])
    if limits is None:
        raise InputError("vehicle.operational", f"the preset {table['preset']!r} has no operational limits")
    lat = limits.lateral_acceleration
    return {
        "longitudinal": {"acceleration": list(limits.acceleration), "jerk": list(limits.jerk)},
        "bounds": {"speed": (0.0, limits.speed), "lateral_acceleration": (-lat, lat),
                   "steering_rate": (-limits.steering_rate, limits.steering_rate)},
    }  # fmt: skip


def _longitudinal(vehicle: Vehicle, table: dict[str, Any]) -> tuple[Vehicle, dict[str, tuple[float, float]]]:
    """``[vehicle.longitudinal]`` (docs/dynamics-format.md): the vehicle with the speed as the state ``v``,
    and the bounds of the acceleration (and jerk) it gives; the vehicle unchanged without the table."""
    if not table:
        return vehicle, {}
    where = "vehicle.longitudinal."
    no_unknown(table, LONGITUDINAL_KEYS, where)
    if "acceleration" not in table:
        raise InputError(where + "acceleration", "missing: [vehicle.longitudinal] needs acceleration = [lo, hi] m/s^2")
    r = vehicle.roles
    if r.speed is None or r.speed not in vehicle.controls:
        raise InputError("vehicle.longitudinal", f"the {vehicle.model} model has no speed control to integrate")
    integrated = Longitudinal(vehicle, jerk="jerk" in table)
    out = {}
    for key, role in (("acceleration", integrated.roles.acceleration), ("jerk", integrated.roles.jerk)):
        if key in table:
            out[role] = _signed_pair(table[key], where + key, "m/s^2" if key == "acceleration" else "m/s^3")
    return integrated, out


def _signed_pair(val: Any, key: str, unit: str) -> tuple[float, float]:
    """[lo, hi] with finite lo < 0 < hi, or InputError naming ``key``."""
    if not (isinstance(val, list) and len(val) == 2 and all(is_number(x) for x in val)):
        raise InputError(key, f"must be [lo, hi] (two numbers, {unit}), got {val!r}")
    lo, hi = float(val[0]), float(val[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < 0 < hi):
        raise InputError(key, f"must be finite with lo < 0 < hi ({unit}), got [{lo:g}, {hi:g}]")
    return lo, hi


def _preset(table: dict[str, Any]) -> tuple[dict[str, Any], dict[str, tuple[float, float]]]:
    """The named preset's [vehicle] keys and bounds, or nothing."""
    if "preset" not in table:
        return {}, {}
    name = table["preset"]
    if not isinstance(name, str):
        raise InputError("vehicle.preset", f"must be a name (string), got {name!r}")
    data = preset(name)
    keys = {k: v for k, v in data.items() if k in {"model", "wheelbase", "hitch_offset", "trailer_wheelbase"}}
    keys.update({k: data[k] for k in BODY_TABLES if data.get(k)})
    return keys, {k: (float(lo), float(hi)) for k, (lo, hi) in data.get("bounds", {}).items()}


def _subtable(table: dict[str, Any], key: str, where: str) -> dict[str, Any]:
    val = table.get(key, {})
    if not isinstance(val, dict):
        raise InputError(where + key, f"must be a table ([{where}{key}]), got {type(val).__name__}")
    return val


def _body(table: dict[str, Any], key: str) -> Body:
    no_unknown(table, {"length", "width", "rear_overhang"}, key + ".")
    for name in ("length", "width", "rear_overhang"):
        if name not in table:
            raise InputError(f"{key}.{name}", "missing")
    return Body(*(number(table, k, key + ".") for k in ("length", "width", "rear_overhang")), key=key)


def _speed_bound(vehicle: Vehicle, preset_bounds: dict) -> dict[str, tuple[float, float]]:
    """A preset's bounds; with longitudinal dynamics its bound of the speed control is the state v's."""
    out = dict(preset_bounds)
    if isinstance(vehicle, Longitudinal) and vehicle.base.roles.speed in out:
        out[vehicle.roles.speed] = out.pop(vehicle.base.roles.speed)
    return out


def _all_bounds(vehicle: Vehicle, preset_bounds: dict, file_bounds: dict) -> dict[str, tuple[float, float]]:
    """The file's bounds over the preset's; with longitudinal dynamics the speed's bound is ``bounds.v``
    (required), and one of the speed control is an error."""
    if not isinstance(vehicle, Longitudinal):
        return {**preset_bounds, **file_bounds}
    control, speed = vehicle.base.roles.speed, vehicle.roles.speed
    if control in file_bounds:
        raise InputError(f"bounds.{control}", f"the speed is the state {speed} with [vehicle.longitudinal]: "
                         f"bound it as bounds.{speed}")  # fmt: skip
    out = {**preset_bounds, **file_bounds}
    if speed not in out:
        raise InputError(f"bounds.{speed}", "required with [vehicle.longitudinal]: the speed's bounds [lo, hi] m/s")
    return out


def _bounds(table: dict[str, Any]) -> dict[str, tuple[float, float]]:
    out = {}
    for key, val in table.items():
        if not (isinstance(val, list) and len(val) == 2 and all(is_number(x) for x in val)):
            raise InputError(f"bounds.{key}", f"must be [lower, upper] (two numbers), got {val!r}")
        out[key] = (float(val[0]), float(val[1]))
    return out


def _obstacles(items: Any) -> list[Circle]:
    out = []
    for _, where, item in array_of_tables(items, "obstacles"):
        no_unknown(item, OBSTACLE_KEYS, where)
        center = item.get("center")
        if not (isinstance(center, list) and len(center) == 2 and all(is_number(x) for x in center)):
            raise InputError(where + "center", f"must be [x, y] (two numbers), got {center!r}")
        if "radius" not in item:
            raise InputError(where + "radius", "missing")
        safety = number(item, "safety", where) if "safety" in item else 0.0
        out.append(Circle((float(center[0]), float(center[1])), number(item, "radius", where), safety))
    return out


def _moving_obstacles(items: Any) -> tuple[MovingVehicle, ...]:
    """[[moving_obstacles]]: a rectangle and its motion (docs/scenario-format.md)."""
    out = []
    for i, where, item in array_of_tables(items, "moving_obstacles"):
        no_unknown(item, MOVING_KEYS, where)
        for key in ("length", "width"):
            if key not in item:
                raise InputError(where + key, "missing")
        sizes = {key: number(item, key, where) for key in ("length", "width")}
        safety = number(item, "safety", where, 0.0)
        out.append(MovingVehicle(**sizes, safety=safety, **_motion(item, where), key=f"moving_obstacles[{i}]"))
    return tuple(out)


def _motion(item: dict[str, Any], where: str) -> dict[str, Any]:
    """Either ``trajectory`` [[t, x, y, heading], ...] or ``start`` [x, y, heading] with ``speed``, ``yaw_rate``."""
    forms = [key for key in ("trajectory", "start") if key in item]
    if len(forms) != 1:
        got = "both" if forms else "neither"
        raise InputError(where + "trajectory", f"give exactly one of trajectory and start (got {got})")
    if forms == ["start"]:
        start = item["start"]
        if not (isinstance(start, list) and len(start) == 3 and all(is_number(v) for v in start)):
            raise InputError(where + "start", f"must be [x, y, heading] (3 numbers), got {start!r}")
        if "speed" not in item:
            raise InputError(where + "speed", "missing: start = [x, y, heading] needs a speed (m/s)")
        return {"start": tuple(float(v) for v in start), "speed": number(item, "speed", where),
                "yaw_rate": number(item, "yaw_rate", where, 0.0)}  # fmt: skip
    extra = [key for key in ("speed", "yaw_rate") if key in item]
    if extra:
        raise InputError(where + extra[0], "belongs to start = [x, y, heading], not to a trajectory")
    samples = item["trajectory"]
    if not isinstance(samples, list) or not samples:
        raise InputError(where + "trajectory", "must be an array of samples [[t, x, y, heading], ...]")
    for j, row in enumerate(samples):
        if not (isinstance(row, list) and len(row) == 4 and all(is_number(v) for v in row)):
            raise InputError(f"{where}trajectory[{j}]", f"must be [t, x, y, heading] (4 numbers), got {row!r}")
    return {"trajectory": tuple(tuple(float(v) for v in row) for row in samples)}
