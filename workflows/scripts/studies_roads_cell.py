"""Road study (b), cells: a design vehicle turns left through one roundabout size, with or without an apron.

``--cell`` takes one or more cells (the pipeline passes a row: one vehicle and apron, every ICD), solved in
turn in this process, each written to its ``--out`` file (the same count) as soon as it is done: the
imports (Pyomo, SymPy, CasADi, cyipopt with SciPy; about 2 s of CPU) are paid once per row, not per cell.
Each cell's budgets count from its own start.

The cell's scenario is the template (workflows/scenarios/roads/left-turn.toml) with the preset,
the inscribed diameter and the apron set (model.studies.roads.cell_document), at the preset's operational
limits unless ``--no-operational`` (model.studies.roads.operational_document: the acceleration, jerk, steering
rate and lateral acceleration bounds, entering at the crawl speed). Solves the minimum
time; if that is valid, the apron used and the swept width of its exact rectangles, and the
energy-optimal solve at ``--energy-ratio`` x the minimum time (started from the time solution).
A failed solve is written as failed, with its diagnosis; it is never a solution.
"""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from studies_common import run_and_leave, write_json  # noqa: E402

from model.cli import checked_time_limit  # noqa: E402
from model.errors import InputError  # noqa: E402
from model.nlp.imports import settled_heap  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.studies.roads import cell_document, cell_measures, parse_cell  # noqa: E402
from model.studies.sweeps import as_energy  # noqa: E402
from model.vehicles import operational_limits  # noqa: E402

KEEP = ("t", "x", "y", "theta", "phi", "theta1", "u1", "u2", "v", "a", "j")


def limits_measured(measures: dict) -> dict:
    """The largest |lateral acceleration| (nodes, between them) and the acceleration's range of a solve."""
    lateral, longitudinal = measures.get("lateral_acceleration") or {}, measures.get("longitudinal") or {}
    return {
        "max_abs_lateral_acceleration": lateral.get("max_abs_nodes"),
        "max_abs_lateral_acceleration_dense": lateral.get("max_abs_dense"),
        "max_acceleration": longitudinal.get("max_acceleration"),
        "min_acceleration": longitudinal.get("min_acceleration"),
    }


def outcome(sol) -> dict:
    """One solve as a record: status, validity, objective, Tf, clearances, diagnosis."""
    measures = sol.validation.get("measures", {})
    out = {
        "status": sol.status,
        "valid": bool(sol.ok),
        "objective": sol.objective,
        "final_time": sol.final_time,
        "energy": sol.energy,
        "iterations": sol.iterations,
        "intervals": sol.intervals,
        "solve_seconds": sol.solve_seconds,
        "min_clearance": measures.get("min_clearance"),
        "min_clearance_dense": measures.get("min_clearance_dense"),
        "exit_taken": measures.get("exit_taken"),
        **limits_measured(measures),
    }
    if not sol.ok:
        out["diagnosis"] = sol.diagnosis or {"message": f"solver status {sol.status}, validation failed"}
    return out


def solve_cell(template: Path, cell: str, intervals: int, energy_ratio: float, time_limit: float | None = None,
               clock: str = "wall", energy_time_limit: float | None = None,
               operational: bool = True) -> dict:  # fmt: skip
    """The cell's record: its minimum-time solve (``time_limit`` seconds of ``clock``, "wall" or "cpu"),
    measures and energy-optimal solve (``energy_time_limit`` seconds of the same clock) where it is valid,
    and its wall and CPU seconds; with ``operational`` at the preset's operational limits (``limits``: the
    preset's, as ``model.vehicles.operational_limits`` gives them; None without)."""
    preset_name, icd, apron = parse_cell(cell)
    doc = cell_document(tomllib.loads(template.read_text()), preset_name, icd, apron, intervals, operational)
    ocp = parse_scenario(doc).ocp
    start, cpu = time.perf_counter(), time.process_time()
    sol = ocp.solve(intervals=intervals, time_limit=time_limit, clock=clock)
    record = {
        "cell": cell,
        "preset": preset_name,
        "icd": icd,
        "apron": apron,
        "apron_use": ocp.road.roundabout.apron_use,
        "intervals": intervals,
        "time_limit": time_limit,
        "time_limit_clock": clock,
        "energy_time_limit": energy_time_limit,
        "template": str(template),
        "operational": operational,
        "limits": limits_record(preset_name) if operational else None,
        "speed_bound": list(ocp.bounds.get(ocp.vehicle.roles.speed, ())),
        "initial_speed": ocp.initial.get(ocp.vehicle.roles.speed),
        "time": outcome(sol),
        "energy_ratio": energy_ratio,
        "energy": None,
    }
    if sol.ok:
        record["measures"] = cell_measures(ocp, sol.columns)
        record["trajectory"] = {k: [float(v) for v in sol.columns[k]] for k in KEEP if k in sol.columns}
        tf = energy_ratio * sol.final_time
        # on the time answer's grid (2N where the goal-accuracy rule refined it: on N the energy answer drifts too,
        # and its N solve was thrown away; EU-semitrailer ICD 45 m: 3.6 s of 9.2 s). With a budget: EU-semitrailer
        # ICD 30 m no apron, the start from the time answer ran 2858 iterations (215 s) to "infeasible" before the
        # geometry continuation found 485.803 in 37 s; at 120 s CPU the start is cut at 30 s, the same 485.803
        esol = as_energy(ocp, tf).solve(intervals=sol.intervals, guess=sol.trajectory, time_limit=energy_time_limit,
                                        clock=clock)  # fmt: skip
        record["energy"] = {"final_time_set": tf, "intervals_asked": sol.intervals, **outcome(esol)}
    record["seconds"] = time.perf_counter() - start
    record["cpu_seconds"] = time.process_time() - cpu
    return record


def limits_record(preset_name: str) -> dict:
    """The preset's operational limits as a JSON record (``model.vehicles.operational_limits``)."""
    lim = operational_limits(preset_name)
    return {"acceleration": list(lim.acceleration), "jerk": list(lim.jerk), "speed": lim.speed,
            "steering_rate": lim.steering_rate, "lateral_acceleration": lim.lateral_acceleration,
            "rollover_threshold": lim.rollover_threshold, "crawl_speed": lim.crawl_speed}  # fmt: skip


def budget(flag: str, text: str | None) -> float | None:
    """A budget flag's seconds (None: not given or 'inf'); bad input is an InputError naming ``flag``."""
    try:
        return None if text is None else checked_time_limit(text)
    except InputError as err:
        raise InputError(flag, err.message) from None


def checked_cell(name: str) -> None:
    """An InputError naming ``--cell`` unless ``name`` reads as VEHICLE_icdD_apronA."""
    try:
        parse_cell(name)
    except ValueError:
        raise InputError("--cell", f"{name!r} is not VEHICLE_icdD_apronA (e.g. WB-62_icd40_apron2)") from None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument(
        "--cell",
        required=True,
        nargs="+",
        help="one or more cells, e.g. WB-62_icd40_apron2 (model.studies.roads.cell_name)",
    )
    ap.add_argument("--intervals", type=int, required=True)
    ap.add_argument("--energy-ratio", type=float, default=1.2)
    ap.add_argument("--time-limit", default=None,
                    help="seconds for the minimum-time search ('inf' or not given: none); past it, the best answer or "
                         "a refusal")  # fmt: skip
    ap.add_argument(
        "--energy-time-limit",
        default=None,
        help="seconds for the energy-optimal search ('inf' or not given: none), on the same clock",
    )
    ap.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="what --time-limit and --energy-time-limit count: wall seconds or the process's CPU seconds",
    )
    ap.add_argument("--operational", action=argparse.BooleanOptionalAction, default=True,
                    help="the preset's operational limits (default; --no-operational: the kinematic model, the "
                         "speed a control)")  # fmt: skip
    ap.add_argument("--out", type=Path, required=True, nargs="+", help="each cell's JSON file, in --cell's order")
    args = ap.parse_args()
    try:  # the CLI's own check of --time-limit (a number > 0 or 'inf'), for both budgets
        limit, energy_limit = (
            budget("--time-limit", args.time_limit),
            budget("--energy-time-limit", args.energy_time_limit),
        )
        if len(args.out) != len(args.cell):
            raise InputError("--out", f"{len(args.out)} files for {len(args.cell)} cells (one per --cell)")
        for cell in args.cell:
            checked_cell(cell)
    except InputError as err:
        print(err, file=sys.stderr)
        sys.exit(2)
    for cell, out in zip(args.cell, args.out, strict=True):
        with settled_heap():  # the last cell's garbage collected, the survivors frozen (model/nlp/imports.py)
            record = solve_cell(args.template, cell, args.intervals, args.energy_ratio, limit, args.clock, energy_limit,
                                args.operational)
        write_json(out, record)


if __name__ == "__main__":
    run_and_leave(main)
