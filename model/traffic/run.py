"""One ``roundabout traffic`` run and K runs: the files and the summary of docs/traffic-format.md.

Metrics are computed from exact geometry, not from SUMO's collision check: each body of the truck
is a rectangle from the states (``model.analysis.bodies.body_corners``), each other vehicle a
rectangle from its ``traffic.csv`` row, and their distance is shapely's (``rectangle_gaps``:
negative when they overlap).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from model.analysis.bodies import body_corners, rectangle_gaps, road_measures
from model.problem.costs import Energy
from model.problem.scenario import Scenario
from model.traffic.autopilot import plan_of
from model.traffic.cooperative import commands_text
from model.traffic.cosim import (
    BRAKING_RADIUS,
    STILL_SPEED,
    Pass,
    autopilot_drive,
    drive,
    reconstruct,
    replay,
    states_of,
    write_sumo_files,
)
from model.traffic.network import truck_geometry, truck_limits
from model.traffic.sumo import Sumo
from model.vehicles.body import centred_rectangle

TRAFFIC_COLUMNS = ("t", "id", "type", "x", "y", "heading", "speed", "length", "width")  # names: contract columns
SAME_FOR_ALL = ("longitudinal_limits", "sumo_vtype")  # summary keys equal in every run: summary.json only
DRIVERS = ("autopilot", "sumo", "cooperative", "reservation")  # the last two: the autopilot among connected vehicles
MANAGED = ("cooperative", "reservation")  # the drivers that set the other vehicles' speeds (commands.csv)
LIMIT_TOLERANCE = 1e-6  # relative: a driven value this far beyond its bound still keeps it (the plan's rounding)


def other_corners(row: tuple) -> np.ndarray:
    """Corners (4, 2) of another vehicle's rectangle from its traffic.csv row."""
    _, _, _, x, y, heading, _, length, width = row
    return centred_rectangle(x, y, heading, length, width)


def encounter(scenario: Scenario, cols: dict[str, np.ndarray], scored: Pass) -> dict:
    """Collisions, min_distance and max_braking_caused over the truck's steps (exact rectangles)."""
    ocp = scenario.ocp
    index = {round(float(t), 6): k for k, t in enumerate(cols["t"])}
    corners = body_corners(ocp, {s: cols[s] for s in ocp.vehicle.states})
    by_time: dict[float, list[tuple]] = {}
    for row in scored.rows:
        if row[0] in index:
            by_time.setdefault(row[0], []).append(row)
    collisions, min_distance, braking = 0, math.inf, 0.0
    for t, rows in by_time.items():
        k = index[t]
        others = np.array([other_corners(r) for r in rows])
        gaps = np.min([rectangle_gaps(np.repeat(c[k][None], len(rows), 0), others) for c in corners.values()], axis=0)
        collisions += int(np.any(gaps <= 0.0))
        min_distance = min(min_distance, float(gaps.min()))
        near = [r[1] for r, g in zip(rows, gaps, strict=True) if g <= BRAKING_RADIUS]
        braking = max([braking, *(scored.braking.get(t, {}).get(vid, 0.0) for vid in near)])
    return {
        "collisions": collisions,
        "min_distance": None if math.isinf(min_distance) else min_distance,
        "max_braking_caused": braking,
    }


def solve_plan(scenario: Scenario) -> tuple[object, float]:
    """The autopilot's plan: the scenario's optimum by the default method (quick search), and its seconds."""
    from model.problem.methods import DEFAULT_SOLVE, load_method

    t0 = time.perf_counter()
    sol = scenario.ocp.solve(intervals=scenario.intervals, method=load_method(DEFAULT_SOLVE), search="quick")
    return sol, time.perf_counter() - t0


def one_run(scenario: Scenario, sumo: Sumo, folder: Path, driver: str, seed: int, plan=None,
            junction_rule: bool = False, entry_rule: bool = False,
            follow_rule: bool = True) -> tuple[dict, dict, list]:  # fmt: skip
    """One run into ``folder/sumo``: (summary, trajectory columns, traffic rows); ``plan`` for the autopilot.

    ``junction_rule``: the autopilot with SUMO's exit junction rule (``autopilot_drive``; off by default);
    ``entry_rule``: with its entry half (off by default); ``follow_rule``: the autopilot's follower
    check at its entry (``Autopilot.follower_braking``; on by default).
    """
    traffic = scenario.traffic
    sumo_dir = folder / "sumo"
    write_sumo_files(scenario, sumo_dir, sumo, seed)
    wall = time.perf_counter()
    if driver == "sumo":
        driven = drive(scenario, sumo, sumo_dir)
        free = drive(scenario, sumo, sumo_dir, "routes_free_flow.rou.xml")
        cols = reconstruct(scenario, driven) if driven.truck else {}
        poses = {t: p[:3] for t, p in driven.truck.items()}
        scored = replay(sumo, sumo_dir, poses, driven.end, traffic.step)
    else:
        rules = {"junction_rule": junction_rule, "entry_rule": entry_rule, "follow_rule": follow_rule}
        managed = driver if driver in MANAGED else False
        driven = autopilot_drive(scenario, sumo, sumo_dir, plan, **rules, cooperate=managed)
        if managed:  # the speeds set on the others, for the replay (docs/traffic-format.md)
            (sumo_dir / "commands.csv").write_text(commands_text(driven.commands))
        free = autopilot_drive(scenario, sumo, sumo_dir, plan, "routes_free_flow.rou.xml")
        cols = states_of(scenario, driven) if driven.states else {}
        scored = driven
    alone = replay(sumo, sumo_dir, {}, driven.end, traffic.step, "routes_without_truck.rou.xml")
    wall = time.perf_counter() - wall
    summary = summarise(scenario, driver, seed, sumo, driven, free, cols, scored, alone)
    if driver != "sumo":
        worst = max(driven.decision_seconds, default=0.0)
        summary |= {"solve_seconds_max": worst, "realtime_factor": worst / traffic.step}
        # the same decisions in CPU seconds (time.process_time): the computation without the machine's load
        cpu = max(driven.decision_cpu_seconds, default=0.0)
        summary |= {"solve_cpu_seconds_max": cpu, "realtime_factor_cpu": cpu / traffic.step}
        summary["decisions"] = {name: driven.decisions.count(name) for name in sorted(set(driven.decisions))}
        if driven.management:  # the cooperative driver: the steps it waited, by what its priority request said
            summary["management"] = driven.management
    summary["wall_seconds"] = wall
    return summary, cols, scored.rows


def summarise(scenario, driver, seed, sumo, driven, free, cols, scored, alone) -> dict:
    """summary.json's keys for one run."""
    traffic, ocp = scenario.traffic, scenario.ocp
    arrived = driven.arrived and bool(cols)
    travel = (max(driven.truck) - traffic.warmup) if arrived else None
    free_time = (max(free.truck) - traffic.warmup) if free.arrived and free.truck else None
    out = {"driver": driver, "arrived": arrived, "travel_time": travel, "free_flow_time": free_time}
    out["delay"] = travel - free_time if travel is not None and free_time is not None else None
    out |= {"entry_wait": entry_wait(scenario, cols) if cols else None}
    if cols:
        out |= encounter(scenario, cols, scored)
        # the same measure on the run without the truck (same seed, the truck's poses as the places):
        # the braking the traffic does anyway (e.g. to its normal deceleration before the give-way line)
        out["max_braking_without_truck"] = encounter(scenario, cols, alone)["max_braking_caused"]
        road = road_measures(ocp, {s: cols[s] for s in ocp.vehicle.states})
        out["min_clearance"] = road["min_clearance"]
        out["exit_taken"] = road["exit_taken"]
        out["energy"] = Energy().integral(cols, ocp.vehicle.controls, rule="zoh")  # each row's controls held
        out["limits_driven"] = limits_driven(scenario, cols)
        out["within_limits"] = out["limits_driven"]["within"]
    else:
        out |= {"collisions": 0, "min_distance": None, "max_braking_caused": 0.0, "min_clearance": None, "energy": None}
    out["others_time_loss"] = float(sum(scored.time_loss.values()))
    out["others_time_loss_without_truck"] = float(sum(alone.time_loss.values()))
    out |= {"solve_seconds_max": 0.0, "realtime_factor": 0.0, "sumo_version": sumo.version, "seed": seed}
    out["other_vehicles"] = len(scored.time_loss)
    out |= limits_summary(scenario, driven.vtype)
    if driven.tracking:  # the autopilot: how far the truck's reference point was from where the plan wanted it
        out["tracking_error_max"] = float(max(driven.tracking))
    out["road_violation"] = out["min_clearance"] is not None and out["min_clearance"] < 0
    out["ok"] = bool(arrived and out["collisions"] == 0 and not out["road_violation"])
    return out


def limits_summary(scenario: Scenario, vtype: dict) -> dict:
    """``longitudinal_limits`` (the scenario's acceleration and speed bounds, or None without
    ``[vehicle.longitudinal]``) and ``sumo_vtype`` (SUMO's vType of the truck as it ran, and where its
    accel, decel and maxSpeed came from)."""
    ocp = scenario.ocp
    r = ocp.vehicle.roles
    limits = truck_limits(scenario)
    scenario_limits = None
    if limits is not None:
        scenario_limits = {"acceleration": list(ocp.bounds[r.acceleration]), "speed": list(ocp.bounds[r.speed])}
    source = "the scenario's limits" if limits is not None else "SUMO's defaults of the vClass"
    return {"longitudinal_limits": scenario_limits, "sumo_vtype": {**vtype, "source": source} if vtype else None}


def limits_driven(scenario: Scenario, cols: dict[str, np.ndarray]) -> dict:
    """What the truck drove against its bounds, over trajectory.csv's rows: for the speed, the acceleration, the
    jerk (where they are columns) and the lateral acceleration (``Vehicle.lateral_acceleration`` at each row's
    state under its held controls), the least and largest value, the bound (None if unbounded) and whether the
    values keep it within ``LIMIT_TOLERANCE`` (relative); ``within`` for all of them."""
    ocp, v = scenario.ocp, scenario.ocp.vehicle
    r = v.roles
    series = {name: cols[name] for name in (r.speed, r.acceleration, r.jerk) if name and name in cols}
    if "lateral_acceleration" in v.path_outputs():
        evaluate = v.path_function([v.path_outputs()["lateral_acceleration"]])
        series["lateral_acceleration"] = evaluate({k: cols[k] for k in v.states + v.controls})[0]
    out: dict = {}
    for name, values in series.items():
        bound = ocp.bounds.get(name)
        item = {"min": float(np.min(values)), "max": float(np.max(values)), "bound": list(bound) if bound else None}
        if bound:
            slack = LIMIT_TOLERANCE * max(abs(bound[0]), abs(bound[1]), 1.0)
            item["within"] = bool(item["min"] >= bound[0] - slack and item["max"] <= bound[1] + slack)
        out[name] = item
    out["within"] = all(item.get("within", True) for item in out.values())
    return out


def entry_wait(scenario: Scenario, cols: dict[str, np.ndarray]) -> float:
    """Seconds the truck stood still (speed < STILL_SPEED) with its front bumper outside the ring."""
    ra, v = scenario.ocp.road.roundabout, scenario.ocp.vehicle

    front = truck_geometry(scenario)["front"]
    px, py = v.position
    h = cols[v.roles.heading]
    fx = cols[px] + front * np.cos(h) - ra.center[0]
    fy = cols[py] + front * np.sin(h) - ra.center[1]
    outside = np.hypot(fx, fy) > ra.outer_radius
    still = np.abs(cols[v.roles.speed]) < STILL_SPEED
    return float(np.sum(outside & still) * scenario.traffic.step)


def csv_text(columns: list[str], rows) -> str:
    """Rows as CSV text (floats with repr precision)."""
    lines = [",".join(columns)]
    lines += [",".join(str(v) if not isinstance(v, float) else repr(v) for v in row) for row in rows]
    return "\n".join(lines) + "\n"


def trajectory_text(scenario: Scenario, cols: dict[str, np.ndarray]) -> str:
    """trajectory.csv: t, the states in the model's order, the controls."""
    v = scenario.ocp.vehicle
    names = ["t", *v.states, *v.controls]
    rows = zip(*(cols[n].tolist() for n in names), strict=True) if cols else []
    return csv_text(names, rows)


def aggregate(runs: list[dict]) -> dict:
    """The summary of K runs: means, worst cases and rates."""

    def vals(key):
        return [r[key] for r in runs if r.get(key) is not None]

    def mean(key):
        return float(np.mean(vals(key))) if vals(key) else None

    out = {"driver": runs[0]["driver"], "runs": len(runs), "sumo_version": runs[0]["sumo_version"],
           "seed": runs[0]["seed"], "arrived": all(r["arrived"] for r in runs),
           "arrival_rate": float(np.mean([r["arrived"] for r in runs])),
           "collision_rate": float(np.mean([r["collisions"] > 0 for r in runs]))}  # fmt: skip
    for key in ("travel_time", "free_flow_time", "delay", "entry_wait", "energy", "others_time_loss",
                "others_time_loss_without_truck"):  # fmt: skip
        out[key] = mean(key)
    out["collisions"] = int(sum(r["collisions"] for r in runs))
    for key in ("min_distance", "min_clearance"):
        out[key] = min(vals(key)) if vals(key) else None
    for key in ("max_braking_caused", "solve_seconds_max", "realtime_factor", "solve_cpu_seconds_max",
                "realtime_factor_cpu", "tracking_error_max"):  # fmt: skip
        out[key] = max(vals(key)) if vals(key) else None
    out["ok"] = all(r["ok"] for r in runs)
    for key in ("plan_status", "plan_seconds", "plan_final_time", "plan_valid", *SAME_FOR_ALL):
        if key in runs[0]:
            out[key] = runs[0][key]
    return out


def run_traffic(scenario: Scenario, sumo: Sumo, stage: Path, driver: str, runs: int) -> dict:
    """K runs (seeds seed, seed + 1, ...) into ``stage``; the last run's files at the top, each in run-k/ too."""
    results, plan, extra = [], None, {}
    if driver != "sumo":
        sol, seconds = solve_plan(scenario)
        extra = {"plan_status": sol.status, "plan_seconds": seconds,
                 "plan_final_time": float(sol.trajectory["t"].iloc[-1]), "plan_valid": bool(sol.ok)}  # fmt: skip
        if not sol.ok:
            summary = {"driver": driver, "arrived": False, "ok": False, "reason": "the plan's solve failed", **extra}
            (stage / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
            return summary
        plan = plan_of(sol, scenario.ocp.vehicle)
    for k in range(runs):
        seed = scenario.traffic.seed + k
        folder = stage if runs == 1 else stage / f"run-{k}"
        summary, cols, rows = one_run(scenario, sumo, folder, driver, seed, plan)
        summary |= extra
        (folder / "trajectory.csv").write_text(trajectory_text(scenario, cols))
        (folder / "traffic.csv").write_text(csv_text(list(TRAFFIC_COLUMNS), rows))
        (folder / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        results.append(summary)
    if runs > 1:
        # one column per number, flag or name; SAME_FOR_ALL are the summary's, once; tables such as limits_driven
        # or decisions stay in each run's own summary.json (run-k/)
        keys = [k for k in results[0] if k not in SAME_FOR_ALL and not isinstance(results[0][k], dict | list)]
        (stage / "runs.csv").write_text(csv_text(keys, [[r.get(k) for k in keys] for r in results]))
        summary = aggregate(results)
        (stage / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        return summary
    return results[0]


__all__ = ["DRIVERS", "MANAGED", "TRAFFIC_COLUMNS", "aggregate", "encounter", "entry_wait", "limits_summary", "one_run",
           "other_corners", "run_traffic", "trajectory_text"]  # fmt: skip
