"""Where the kinematic plan holds (issue 43, item 5): a kinematic plan driven on the dynamic plant at rising speed.

A cell is one manoeuvre (a road scenario's document: a roundabout, a route, a vehicle at its
operational limits) planned with the kinematic model under a bound on the lateral acceleration
(``bounds.lateral_acceleration = [-L, L]``; a larger L lets the time-optimal plan drive faster), then
driven by the tracking controller (time-varying LQR, ``model.simulation``) twice: on the kinematic
plant (the planning model itself, no disturbance: what the plan promises under the same controller
and samples) and on the dynamic single-track plant (``[plant] model = "single-track"``: CommonRoad's
single-track model for a rigid vehicle, the yaw-plane tractor-semitrailer for an articulated one).

``run_cell`` returns one record (``RECORD_KEYS``, units in the names): the plan's speed, lateral
acceleration and body clearance, both runs' least corridor clearance of the bodies at the samples
(exact rectangles, ``model.simulation.loop.min_clearance``) and largest distance from the plan's path,
the dynamic plant's side slip, lateral acceleration, friction use and goal error, and the clearance
the dynamics cost: ``clearance_lost_m`` = kinematic-plant clearance - dynamic-plant clearance. A cell
is ``safe`` when the dynamic plant's bodies stay in the corridor (clearance >= 0) and it reaches the goal.
``first_unsafe`` finds, per manoeuvre, the lowest level at which the plan stops being safe.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from model.errors import InputError
from model.problem.closed_loop import PlantSettings
from model.problem.scenario import Scenario, parse_scenario
from model.simulation.loop import make_controller, simulate
from model.simulation.single_track import path_distance

CONTROLLER = "tracking"  # the plan's own tracking controller: the gap is the plant's, not a re-planner's
RECORD_KEYS = (
    "manoeuvre", "vehicle", "exit", "lateral_acceleration_bound_mps2", "intervals", "status", "plan_valid",
    "final_time_s", "plan_max_speed_mps", "plan_max_lateral_acceleration_mps2", "plan_min_clearance_m",
    "kinematic_min_clearance_m", "kinematic_max_lateral_deviation_m", "kinematic_reached_goal",
    "plant_min_clearance_m", "plant_max_lateral_deviation_m", "plant_max_side_slip_rad",
    "plant_max_lateral_acceleration_mps2", "plant_max_friction_use", "plant_max_speed_mps",
    "plant_final_position_error_m", "plant_reached_goal", "clearance_lost_m", "safe",
    "solve_cpu_s", "simulate_cpu_s",
)  # fmt: skip


def cell_scenario(document: Mapping[str, Any], lateral_acceleration: float, exit: int | None = None,
                  intervals: int | None = None, name: str | None = None) -> Scenario:  # fmt: skip
    """One cell's scenario: the template ``document`` (a road scenario's TOML dictionary) with its plan's
    bound on the lateral acceleration, its exit and N, driven on the single-track plant.

    Parameters
    ----------
    document : mapping
        A road scenario's document (``[roundabout]``, ``[route]``, a vehicle); it is not changed.
    lateral_acceleration : float
        L > 0 (m/s^2): the plan's ``bounds.lateral_acceleration = [-L, L]``.
    exit : int, optional
        ``route.exit`` (the template's when None).
    intervals : int, optional
        ``problem.intervals`` (the template's when None).
    name : str, optional
        The scenario's name (the template's when None).

    Returns
    -------
    Scenario
        With ``plant.model == "single-track"`` (the template's ``[plant]`` numbers kept).

    Raises
    ------
    InputError
        ``plant_study.lateral_acceleration`` not a finite number > 0, ``route`` missing, or any key
        the scenario parser refuses.
    """
    bound = lateral_acceleration
    if isinstance(bound, bool) or not (isinstance(bound, int | float) and math.isfinite(bound) and bound > 0):
        raise InputError("plant_study.lateral_acceleration", f"must be a number > 0 (m/s^2), got {bound!r}")
    if "route" not in document:
        raise InputError("route", "the plant study drives a road manoeuvre: the template needs [route]")
    data = copy.deepcopy(dict(document))
    data.setdefault("bounds", {})["lateral_acceleration"] = [-float(lateral_acceleration), float(lateral_acceleration)]
    data.setdefault("plant", {})["model"] = "single-track"
    if exit is not None:
        data["route"]["exit"] = exit
    if intervals is not None:
        data.setdefault("problem", {})["intervals"] = intervals
    if name is not None:
        data["name"] = name
    return parse_scenario(data, default_name=name or "plant-study")


def run_cell(scenario: Scenario, time_limit: float | None = None, clock: str = "cpu",
             labels: Mapping[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """Plan ``scenario`` with the kinematic model, drive the plan on both plants; the cell's record.

    Parameters
    ----------
    scenario : Scenario
        A cell of ``cell_scenario`` (a road with bodies, ``plant.model == "single-track"``).
    time_limit : float, optional
        Seconds for the plan's search (``OCP.solve``'s ``time_limit``); None: no limit.
    clock : str
        What ``time_limit`` counts: "cpu" (the default: a cell's budget whatever the load) or "wall".
    labels : mapping, optional
        ``manoeuvre``, ``vehicle`` (and anything else) copied into the record.

    Returns
    -------
    dict
        ``RECORD_KEYS``; the closed-loop numbers are None when the plan did not validate (``status``
        says why). Lengths m, speeds m/s, accelerations m/s^2, angles rad, times s.
    """
    if scenario.plant.model != "single-track":
        raise ValueError(f"the plant study drives the single-track plant, the scenario's is {scenario.plant.model!r}")
    t0 = time.process_time()
    options = {"time_limit": time_limit, "clock": clock} if time_limit is not None else {}
    sol = scenario.ocp.solve(intervals=scenario.intervals, **options)
    record = dict.fromkeys(RECORD_KEYS) | plan_record(scenario, sol) | dict(labels or {})
    record["solve_cpu_s"] = time.process_time() - t0
    if not sol.ok:
        return record
    t1 = time.process_time()
    record |= closed_loop_record(scenario, sol)
    record["simulate_cpu_s"] = time.process_time() - t1
    return record


def plan_record(scenario: Scenario, solution) -> dict[str, Any]:
    """The plan's part of a record: the bound, status, Tf, N, speed, lateral acceleration and clearance."""
    ocp = scenario.ocp
    record = {
        "manoeuvre": manoeuvre_name(scenario) if ocp.road is not None else None,
        "exit": ocp.road.route.exit if ocp.road is not None else None,
        "lateral_acceleration_bound_mps2": float(ocp.bounds["lateral_acceleration"][1]),
        "intervals": int(solution.intervals),
        "status": solution.status,
        "plan_valid": bool(solution.ok),
    }
    if not solution.ok:
        return record
    summary = solution.summary()
    clearances = [c for c in (summary.get("min_clearance"), summary.get("min_clearance_dense")) if c is not None]
    return record | {
        "final_time_s": float(solution.final_time),
        "plan_max_speed_mps": float(np.max(np.abs(solution.columns[ocp.vehicle.roles.speed]))),
        "plan_max_lateral_acceleration_mps2": float(summary["lateral_acceleration"]["max_abs_dense"]),
        "plan_min_clearance_m": min(clearances) if clearances else None,
    }


def closed_loop_record(scenario: Scenario, solution) -> dict[str, Any]:
    """The tracking controller on the kinematic and on the single-track plant: the record's closed-loop part."""
    kinematic = drive(dataclasses.replace(scenario, plant=PlantSettings()), solution)
    dynamic = drive(scenario, solution)
    s, plant = dynamic.summary, dynamic.summary["plant"]
    lost = None
    if kinematic.summary["min_clearance"] is not None and s["min_clearance"] is not None:
        lost = kinematic.summary["min_clearance"] - s["min_clearance"]
    return {
        "kinematic_min_clearance_m": kinematic.summary["min_clearance"],
        "kinematic_max_lateral_deviation_m": deviation(scenario, kinematic.columns, solution.columns),
        "kinematic_reached_goal": kinematic.reached_goal,
        "plant_min_clearance_m": s["min_clearance"],
        "plant_max_lateral_deviation_m": plant["max_lateral_deviation"],
        "plant_max_side_slip_rad": plant["max_side_slip"],
        "plant_max_lateral_acceleration_mps2": plant["max_lateral_acceleration"],
        "plant_max_friction_use": plant["max_friction_use"],
        "plant_max_speed_mps": float(np.max(np.abs(dynamic.columns["plant_speed"]))),
        "plant_final_position_error_m": s["final_position_error"],
        "plant_reached_goal": dynamic.reached_goal,
        "clearance_lost_m": lost,
        "safe": bool(s["min_clearance"] is not None and s["min_clearance"] >= 0.0 and dynamic.reached_goal),
    }


def drive(scenario: Scenario, solution):
    """One undisturbed closed loop of the tracking controller on the scenario's plant (a ``ClosedLoop``)."""
    factory = make_controller(CONTROLLER, solution, scenario.control, scenario.disturbance)
    return simulate(scenario, solution, factory(), scenario.disturbance, scenario.control)


def deviation(scenario: Scenario, columns: Mapping[str, np.ndarray], plan: Mapping[str, np.ndarray]) -> float:
    """The largest distance (m) of a run's reference point from the plan's path (its nodes joined by segments),
    the measure of the summary's ``plant.max_lateral_deviation``."""
    px, py = scenario.ocp.vehicle.position
    points = np.column_stack([columns[px], columns[py]])
    return float(np.max(path_distance(points, np.column_stack([plan[px], plan[py]]))))


def manoeuvre_name(scenario: Scenario) -> str:
    """The route's turn as a driver names it: "right turn", "straight on", "left turn" or "U-turn".

    From the legs' angles: the exit leg's direction (the leg of the route's exit-th exit) less the entry's driving
    direction (towards the centre), wrapped to (-180, 180] degrees; within 45 degrees of 0 straight on, beyond 135
    a U-turn, negative right.
    """
    road = scenario.ocp.road
    legs, route = road.roundabout.legs, road.route
    turn = (legs[road.exit_leg].angle_deg - legs[route.enter].angle_deg - 180.0) % 360.0
    turn = turn - 360.0 if turn > 180.0 else turn
    if abs(turn) <= 45.0:
        return "straight on"
    if abs(turn) >= 135.0:
        return "U-turn"
    return "right turn" if turn < 0 else "left turn"


def first_unsafe(records: Sequence[Mapping[str, Any]]) -> dict[tuple[str, int], dict[str, Any] | None]:
    """Per manoeuvre (vehicle, exit): the record of the lowest bound whose plan validated but whose dynamic
    plant left the corridor or missed the goal (``safe`` false); None when every validated level was safe."""
    out: dict[tuple[str, int], dict[str, Any] | None] = {}
    ordered = sorted(records, key=lambda r: r["lateral_acceleration_bound_mps2"])
    for r in ordered:
        key = (r["vehicle"], r["exit"])
        out.setdefault(key, None)
        if out[key] is None and r["plan_valid"] and not r["safe"]:
            out[key] = dict(r)
    return out


__all__ = ["RECORD_KEYS", "cell_scenario", "closed_loop_record", "deviation", "drive", "first_unsafe",
           "manoeuvre_name", "plan_record", "run_cell"]  # fmt: skip
