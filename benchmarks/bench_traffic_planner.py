"""Benchmark: the autopilot's two speed planners side by side ([traffic] speed_planner = "rules" | "qp").

Usage: python benchmarks/bench_traffic_planner.py [--rates 300 600] [--seeds 3] [--turn straight]
       [--longitudinal LO HI] [--out runs.jsonl] [--table FILE]

Each cell is the rigid truck of examples/traffic-roundabout.toml (the cells of
benchmarks/bench_traffic.py: a rate q veh/h on each of the three other legs, warm-up 20 s, time
limit 120 s) driven by the autopilot with each planner on the same seeds 0..K-1 and the same plan
(solved once), through ``model.traffic.run.one_run`` (the code of ``roundabout traffic``).
``--longitudinal LO HI``: the truck at longitudinal limits ([vehicle.longitudinal] acceleration =
[LO, HI], bounds.v = the example's u1 bounds, [initial] v = ``ROLL_IN``), so that both
planners keep the same acceleration bounds. Each run's summary is one JSON line of ``--out``; the
table printed is per cell and planner: arrived, collisions, least distance, median and mean delay,
max braking caused (and without the truck), worst decision CPU time, the QP's share of decisions.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.bench_traffic import document  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.autopilot import plan_of  # noqa: E402
from model.traffic.run import one_run, solve_plan  # noqa: E402
from model.traffic.sumo import find_sumo  # noqa: E402

PLANNERS = ("rules", "qp")
ROLL_IN = 5.0  # m/s: with longitudinal limits the truck appears rolling in at this speed ([initial] v)


def cell_document(turn: str, rate: float, planner: str, longitudinal: tuple[float, float] | None) -> dict:
    """The cell's scenario with ``planner`` (and the longitudinal limits, if given)."""
    data = document("truck", turn, rate)
    data["traffic"] = dict(data["traffic"], speed_planner=planner)
    if longitudinal is not None:
        bounds = dict(data["bounds"])
        speed = bounds.pop("u1")
        data["bounds"] = bounds | {"v": speed}
        data["vehicle"] = dict(data["vehicle"], longitudinal={"acceleration": list(longitudinal)})
        data["initial"] = {"v": min(ROLL_IN, float(speed[1]))}
    return data


def run_grid(args) -> list[dict]:
    """Every rate, planner and seed; each summary appended to ``args.out`` as it finishes."""
    sumo, results, plan = find_sumo(), [], None
    limits = tuple(args.longitudinal) if args.longitudinal else None
    for rate in args.rates:
        for planner in PLANNERS:
            scenario = parse_scenario(cell_document(args.turn, rate, planner, limits))
            if plan is None:
                sol, seconds = solve_plan(scenario)
                print(f"# plan: {sol.status} {seconds:.1f} s Tf {sol.trajectory['t'].iloc[-1]:.2f}", flush=True)
                plan = plan_of(sol, scenario.ocp.vehicle)
            for seed in range(args.seeds):
                with tempfile.TemporaryDirectory() as tmp:
                    summary, _, _ = one_run(scenario, sumo, Path(tmp), "autopilot", seed, plan)
                summary |= {"planner": planner, "rate": rate, "turn": args.turn, "longitudinal": limits,
                            "load": os.getloadavg()[0]}  # fmt: skip
                results.append(summary)
                print(f"# {rate:g} {planner} seed {seed}: delay {summary['delay']} min_distance "
                      f"{summary['min_distance']:.2f} decisions {summary.get('decisions')}", flush=True)  # fmt: skip
                with open(args.out, "a") as f:
                    f.write(json.dumps(summary) + "\n")
    return results


def table(results: list[dict]) -> str:
    """Markdown: per cell and planner the safety, delay, braking caused and decision time."""
    lines = ["| veh/h | planner | arrived | collisions | least distance m | median delay s | mean delay s |"
             " max braking caused m/s^2 (without truck) | worst decision CPU s (of step) | qp decisions (overridden) |",
             "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    cells: dict[tuple, list[dict]] = {}
    for r in results:
        cells.setdefault((r["rate"], r["planner"]), []).append(r)
    for (rate, planner), runs in sorted(cells.items(), key=lambda c: (c[0][0], PLANNERS.index(c[0][1]))):
        delay = [r["delay"] for r in runs if r.get("delay") is not None]
        dist = min(r["min_distance"] for r in runs if r.get("min_distance") is not None)
        brake = max(r["max_braking_caused"] for r in runs if r.get("max_braking_caused") is not None)
        alone = max(r["max_braking_without_truck"] for r in runs if r.get("max_braking_without_truck") is not None)
        cpu = max(r["solve_cpu_seconds_max"] for r in runs)
        step = cpu / max(r["realtime_factor_cpu"] for r in runs) if cpu > 0 else 0.1
        qp = sum(r["decisions"].get("qp", 0) for r in runs)
        total = sum(sum(r["decisions"].values()) for r in runs)
        share = f"{qp}/{total} ({total - qp})" if planner == "qp" else "-"
        lines.append(f"| {rate:g} | {planner} | {sum(bool(r['arrived']) for r in runs)}/{len(runs)} | "
                     f"{sum(r['collisions'] for r in runs)} | {dist:.2f} | {np.median(delay):.2f} | "
                     f"{np.mean(delay):.2f} | {brake:.2f} ({alone:.2f}) | {cpu:.3f} ({cpu / step:.2f}) | "
                     f"{share} |")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rates", type=float, nargs="+", default=[300.0, 600.0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--turn", default="straight", choices=["right", "straight", "left"])
    ap.add_argument("--longitudinal", type=float, nargs=2, metavar=("LO", "HI"),
                    help="[vehicle.longitudinal] acceleration = [LO, HI] for both planners")  # fmt: skip
    ap.add_argument("--out", default="traffic-planner-runs.jsonl", help="JSON lines, one run each (appended)")
    ap.add_argument("--table", help="only print the table of an existing --out file")
    args = ap.parse_args(argv)
    if args.table:
        results = [json.loads(line) for line in Path(args.table).read_text().splitlines() if line.strip()]
    else:
        print(f"# {platform.node()} {platform.processor() or platform.machine()} {os.cpu_count()} cpus, "
              f"load {os.getloadavg()}", flush=True)  # fmt: skip
        results = run_grid(args)
    print(table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
