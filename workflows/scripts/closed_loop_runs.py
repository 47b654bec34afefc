"""One setting of the closed-loop study (issue 13, item 5): a geometry x a disturbance level x a controller.

The scenario file's ``[disturbance]`` is the level-1 disturbance; level ``L`` scales it
(``disturbance_at``): speed gain 1 + L (g - 1), steering bias, drift and noise times L, true lengths
model + L (true - model), the actuator delay rounded to whole samples (L x its samples, halves up).
Level 0 is the undisturbed, noise-free plant: deterministic, so it runs once whatever ``--runs``.
The open-loop optimum is solved in-process (the default solve, as ``roundabout simulate``) once for
every controller named, then per controller K closed loops run with seeds seed, seed + 1, ... and a
fresh controller each (as ``simulate_runs``).

Writes into ``--out``: the first run's ``closed_loop.csv`` and ``summary.json``
(docs/closed-loop-format.md), ``runs.csv`` (one line per run, plus its ``objective``: the
scenario's own, weighted energy or time), ``optimum/`` (the open-loop optimum) and ``row.json``:
the setting and its numbers for the study's table (``ROW_KEYS``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from model.outputs import write_atomically as write_text  # noqa: E402
from model.problem.closed_loop import Disturbance  # noqa: E402
from model.problem.scenario import Scenario, load_scenario  # noqa: E402
from model.simulation.loop import ClosedLoop, make_controller, runs_csv, simulate  # noqa: E402

# The study's numbers of one setting (row.json's "numbers"), in table order.
ROW_KEYS = (
    "runs",
    "reach_rate",
    "position_error_mean",
    "position_error_worst",
    "heading_error_mean",
    "heading_error_worst",
    "energy_ratio_mean",
    "energy_ratio_worst",
    "objective_ratio_mean",
    "objective_ratio_worst",
    "violations",
    "min_clearance",
    "failed_steps",
    "steps",
    "step_seconds_mean",
    "step_seconds_max",
    "realtime_factor",
)


def model_lengths(scenario: Scenario) -> dict[str, float]:
    """The vehicle's own lengths by scenario key (``wheelbase``, ``trailer_wheelbase``, ...)."""
    v = scenario.ocp.vehicle
    values = v.parameters()
    return {key: float(values[name]) for name, key in v.parameter_keys.items()}


def disturbance_at(scenario: Scenario, level: float) -> Disturbance:
    """The scenario's disturbance scaled by ``level`` (0: none; 1: the file's own)."""
    d, h = scenario.disturbance, scenario.control.sample_time
    model = model_lengths(scenario)
    delay_samples = math.floor(level * scenario.control.delay_samples(d) + 0.5)
    return Disturbance(
        speed_gain=1.0 + level * (d.speed_gain - 1.0),
        steering_bias=level * d.steering_bias,
        drift=(level * d.drift[0], level * d.drift[1]),
        wheelbase={k: model[k] + level * (v - model[k]) for k, v in d.wheelbase.items() if level != 0},
        delay=delay_samples * h,
        noise=level * d.noise,
        seed=d.seed,
    )


def objective(scenario: Scenario, columns: dict[str, np.ndarray]) -> float:
    """The scenario's own objective of a closed loop: the final time, or the (weighted) energy under the hold."""
    cost = scenario.ocp.cost
    if cost.objective != "energy":
        return float(columns["t"][-1])
    return cost.energy.integral(columns, scenario.ocp.vehicle.controls, rule="zoh")


def run_row(i: int, seed: int, result: ClosedLoop, scenario: Scenario) -> dict:
    """One line of runs.csv: the run's summary numbers and booleans, and its objective."""
    keep = {k: v for k, v in result.summary.items() if isinstance(v, bool | int | float) or v is None}
    return {"run": i, "seed": seed, **keep, "objective": objective(scenario, result.columns)}


def run_all(scenario: Scenario, sol, controller: str, disturbance: Disturbance, runs: int) -> list[ClosedLoop]:
    """``runs`` closed loops with seeds seed, seed + 1, ... and a fresh controller each (as ``simulate_runs``)."""
    factory = make_controller(controller, sol, scenario.control, disturbance)
    seeds = [dataclasses.replace(disturbance, seed=disturbance.seed + i) for i in range(runs)]
    return [simulate(scenario, sol, factory(), d, scenario.control) for d in seeds]


def _stat(rows: list[dict], key: str, how) -> float | None:
    vals = [float(r[key]) for r in rows if r.get(key) is not None]
    return float(how(vals)) if vals else None


def numbers(rows: list[dict], optimum_energy: float, optimum_objective: float) -> dict:
    """The setting's table numbers from its runs (``ROW_KEYS``)."""
    ratios = [{"ratio": r["energy"] / optimum_energy, "cost": r["objective"] / optimum_objective} for r in rows]
    clear = [r["min_clearance"] for r in rows if r.get("min_clearance") is not None]
    return {
        "runs": len(rows),
        "reach_rate": float(np.mean([bool(r["reached_goal"]) for r in rows])),
        "position_error_mean": _stat(rows, "final_position_error", np.mean),
        "position_error_worst": _stat(rows, "final_position_error", np.max),
        "heading_error_mean": _stat(rows, "final_heading_error", np.mean),
        "heading_error_worst": _stat(rows, "final_heading_error", np.max),
        "energy_ratio_mean": _stat(ratios, "ratio", np.mean),
        "energy_ratio_worst": _stat(ratios, "ratio", np.max),
        "objective_ratio_mean": _stat(ratios, "cost", np.mean),
        "objective_ratio_worst": _stat(ratios, "cost", np.max),
        "violations": sum(c < 0 for c in clear) if clear else None,
        "min_clearance": min(clear) if clear else None,
        "failed_steps": int(sum(int(r["failed_steps"]) for r in rows)),
        "steps": int(sum(int(r["steps"]) for r in rows)),
        "step_seconds_mean": _stat(rows, "solve_seconds_mean", np.mean),
        "step_seconds_max": _stat(rows, "solve_seconds_max", np.max),
        "realtime_factor": _stat(rows, "realtime_factor", np.max),
    }


def setting(scenario: Scenario, geometry: str, level: float, controller: str, disturbance: Disturbance) -> dict:
    """What was run: geometry, level, controller, the scaled disturbance and the control settings."""
    ocp = scenario.ocp
    return {
        "geometry": geometry,
        "title": ocp.title,
        "level": level,
        "controller": controller,
        "vehicle": ocp.vehicle.model,
        "lengths": model_lengths(scenario),
        "objective": ocp.cost.objective,
        "weights": dict(getattr(ocp.cost, "weights", {}) or {}),
        "sample_time": scenario.control.sample_time,
        "horizon": scenario.control.horizon,
        "disturbance": dataclasses.asdict(disturbance),
        "level1_disturbance": dataclasses.asdict(scenario.disturbance),
        "safety": min((ob.safety for ob in ocp.obstacles), default=None),
    }


def solve_optimum(scenario: Scenario):
    """The open-loop optimum by the default solve (as ``roundabout simulate``)."""
    from model.problem.methods import DEFAULT_SOLVE, load_method

    return scenario.ocp.solve(intervals=scenario.intervals, method=load_method(DEFAULT_SOLVE))


def optimum_record(sol) -> dict:
    """row.json's ``optimum``: the open-loop optimum's status and numbers."""
    return {
        "status": sol.status,
        "valid": sol.ok,
        "energy": sol.energy,
        "objective": sol.objective,
        "final_time": sol.final_time,
        "certified": bool(sol.certificate.get("passed")),
    }


def run_setting(scenario: Scenario, sol, geometry: str, level: float, controller: str, runs: int, out: Path) -> dict:
    """Run one controller's closed loops on the solved optimum, write the files; return row.json's content."""
    disturbance = disturbance_at(scenario, level)
    runs = 1 if disturbance.none else runs
    sol.write(out / "optimum")
    row = setting(scenario, geometry, level, controller, disturbance)
    row["optimum"] = optimum_record(sol)
    if not sol.ok:
        row["numbers"] = None
        write_text(out / "row.json", json.dumps(row, indent=2) + "\n")
        return row
    load = os.getloadavg()[0]
    results = run_all(scenario, sol, controller, disturbance, runs)
    row["machine"] = {"cpus": os.cpu_count(), "load_before": load, "load_after": os.getloadavg()[0]}
    results[0].write(out)
    rows = [run_row(i, disturbance.seed + i, r, scenario) for i, r in enumerate(results)]
    write_text(out / "runs.csv", runs_csv(rows))
    result = results[0]
    row["controller_name"] = result.summary["controller"]
    row["goal_tolerance"] = result.summary["goal_tolerance"]
    row["numbers"] = numbers(rows, sol.energy, sol.objective)
    write_text(out / "row.json", json.dumps(row, indent=2, default=float) + "\n")
    return row


def run_settings(path: Path, geometry: str, level: float, controllers: list[str], runs: int, out: Path) -> list[dict]:
    """Solve the open-loop optimum once, then each controller's setting into ``out/<controller>``.

    With one controller its files go to ``out`` itself (one setting, one folder).
    """
    scenario = load_scenario(path)
    sol = solve_optimum(scenario)
    folders = [out] if len(controllers) == 1 else [out / c for c in controllers]
    return [run_setting(scenario, sol, geometry, level, c, runs, f) for c, f in zip(controllers, folders, strict=True)]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", type=Path, required=True, help="TOML with the level-1 [disturbance]")
    ap.add_argument("--geometry", help="the setting's geometry name (default: the file's stem)")
    ap.add_argument("--level", type=float, required=True)
    ap.add_argument(
        "--controller",
        nargs="+",
        choices=["open-loop", "tracking", "mpc"],
        required=True,
        help="one or more; the optimum is solved once for all of them",
    )
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument(
        "--out",
        type=Path,
        required=True,
        help="the setting's folder (one controller), or the folder of one sub-folder per controller",
    )
    args = ap.parse_args(argv)
    rows = run_settings(
        args.scenario, args.geometry or args.scenario.stem, args.level, args.controller, args.runs, args.out
    )
    for row in rows:
        n = row["numbers"] or {}
        print(
            f"{row['geometry']} level {row['level']:g} {row['controller']}: {n.get('runs')} runs, "
            f"reach rate {n.get('reach_rate')}, position error mean {n.get('position_error_mean')}",
            file=sys.stderr,
        )


if __name__ == "__main__":
    main()
