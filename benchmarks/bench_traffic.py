"""Benchmark: the truck autopilot against SUMO's own driver on a grid of traffic cells.

Usage: python benchmarks/bench_traffic.py [--vehicles truck semitrailer] [--turns right straight left]
       [--rates 200 450 700] [--seeds 5] [--drivers sumo autopilot cooperative] [--junction-rule] [--entry-rule]
       [--no-follow-rule] [--out runs.jsonl]

Each cell is a vehicle (the rigid truck of examples/traffic-roundabout.toml, the EU semitrailer
of examples/roundabout-semitrailer.toml), a turn from leg 0 (right = 1st exit, straight = 2nd,
left = 3rd) and a rate q (veh/h) on each of the three other legs (exit shares 1/3 each, no
U-turn), warm-up 20 s, time limit 120 s. Both drivers run the same seeds 0..K-1 through
``model.traffic.run.one_run`` (the code of ``roundabout traffic``); the autopilot's plan is
solved once per vehicle and turn. Each run's summary is one JSON line of ``--out``; the table
printed is the median delay per cell and driver, collisions, least distance, largest braking.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.autopilot import plan_of  # noqa: E402
from model.traffic.run import one_run, solve_plan  # noqa: E402
from model.traffic.sumo import find_sumo  # noqa: E402

TURNS = {"right": 1, "straight": 2, "left": 3}
EXAMPLES = {"truck": "traffic-roundabout.toml", "semitrailer": "roundabout-semitrailer.toml"}


def document(vehicle: str, turn: str, rate: float) -> dict:
    """The cell's scenario: the traffic example's roundabout and [traffic], the vehicle's own example."""
    base = tomllib.loads((ROOT / "examples" / "traffic-roundabout.toml").read_text())
    own = tomllib.loads((ROOT / "examples" / EXAMPLES[vehicle]).read_text())
    data = {k: own[k] for k in ("name", "vehicle", "bounds", "roundabout", "route", "problem")}
    data["route"] = dict(data["route"], exit=TURNS[turn])
    data["traffic"] = dict(base["traffic"], time_limit=120.0)
    data["traffic"]["flows"] = [
        {"leg": leg, "vehicles_per_hour": rate, "exits": [1 / 3, 1 / 3, 1 / 3, 0.0]} for leg in (1, 2, 3)
    ]
    return data


def run_grid(args) -> list[dict]:
    """Every cell, driver and seed; each summary appended to ``args.out`` as it finishes."""
    sumo, results = find_sumo(), []
    for vehicle in args.vehicles:
        for turn in args.turns:
            plan = None
            for rate in args.rates:
                scenario = parse_scenario(document(vehicle, turn, rate))
                if set(args.drivers) - {"sumo"} and plan is None:
                    sol, seconds = solve_plan(scenario)
                    tf = sol.trajectory["t"].iloc[-1]
                    print(f"# plan {vehicle} {turn}: {sol.status} {seconds:.1f} s Tf {tf:.2f}", flush=True)
                    plan = plan_of(sol, scenario.ocp.vehicle) if sol.ok else None
                for driver in args.drivers:
                    for seed in range(args.seeds):
                        if driver != "sumo" and plan is None:
                            continue
                        with tempfile.TemporaryDirectory() as tmp:
                            rules = {"junction_rule": args.junction_rule, "entry_rule": args.entry_rule,
                                     "follow_rule": not args.no_follow_rule}  # fmt: skip
                            summary, _, _ = one_run(scenario, sumo, Path(tmp), driver, seed, plan, **rules)
                        summary |= {"vehicle": vehicle, "turn": turn, "rate": rate}
                        results.append(summary)
                        with open(args.out, "a") as f:
                            f.write(json.dumps(summary) + "\n")
    return results


def table(results: list[dict]) -> str:
    """Markdown: per cell and driver the median delay, travel time, entry wait, worst cases."""
    lines = ["| vehicle | turn | veh/h | driver | arrived | median delay s | median travel s | mean entry wait s |"
             " collisions | least distance m | max braking caused m/s^2 (without truck) | min clearance m |"
             " max decision s (CPU s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    cells: dict[tuple, list[dict]] = {}
    for r in results:
        cells.setdefault((r["vehicle"], r["turn"], r["rate"], r["driver"]), []).append(r)
    for (vehicle, turn, rate, driver), runs in cells.items():

        def vals(key, runs=runs):
            return [r[key] for r in runs if r.get(key) is not None]

        def fmt(x, digits=2):
            return "-" if x is None else f"{x:.{digits}f}"

        arrived = sum(bool(r["arrived"]) for r in runs)
        delay = float(np.median(vals("delay"))) if vals("delay") else None
        travel = float(np.median(vals("travel_time"))) if vals("travel_time") else None
        wait = float(np.mean(vals("entry_wait"))) if vals("entry_wait") else None
        dist = min(vals("min_distance"), default=None)
        brake = max(vals("max_braking_caused"), default=None)
        alone = max(vals("max_braking_without_truck"), default=None)
        clear = min(vals("min_clearance"), default=None)
        decide = max(vals("solve_seconds_max"), default=None)
        cpu = max(vals("solve_cpu_seconds_max"), default=None)
        lines.append(f"| {vehicle} | {turn} | {rate:g} | {driver} | {arrived}/{len(runs)} | {fmt(delay)} | "
                     f"{fmt(travel)} | {fmt(wait)} | {sum(r['collisions'] for r in runs)} | {fmt(dist)} | "
                     f"{fmt(brake)} ({fmt(alone)}) | {fmt(clear)} | {fmt(decide, 3)} ({fmt(cpu, 3)}) |")  # fmt: skip
    return "\n".join(lines)


def compare(columns: dict[str, list[dict]]) -> str:
    """Markdown: per cell the median delay (and median travel time) of each labelled set of runs."""
    labels = list(columns)
    lines = ["| vehicle | turn | veh/h | " + " | ".join(f"{k}: median delay s (travel s)" for k in labels) + " |",
             "|---|---|---|" + "---|" * len(labels)]  # fmt: skip
    cells = sorted({(r["vehicle"], r["turn"], r["rate"]) for runs in columns.values() for r in runs},
                   key=lambda c: (list(EXAMPLES).index(c[0]), list(TURNS).index(c[1]), c[2]))  # fmt: skip
    for cell in cells:
        out = []
        for k in labels:
            runs = [r for r in columns[k] if (r["vehicle"], r["turn"], r["rate"]) == cell]
            delay = [r["delay"] for r in runs if r.get("delay") is not None]
            travel = [r["travel_time"] for r in runs if r.get("travel_time") is not None]
            out.append(f"{np.median(delay):.2f} ({np.median(travel):.1f})" if delay else "-")
        lines.append(f"| {cell[0]} | {cell[1]} | {cell[2]:g} | " + " | ".join(out) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicles", nargs="+", default=list(EXAMPLES), choices=list(EXAMPLES))
    ap.add_argument("--turns", nargs="+", default=list(TURNS), choices=list(TURNS))
    ap.add_argument("--rates", type=float, nargs="+", default=[200.0, 450.0, 700.0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--drivers", nargs="+", default=["sumo", "autopilot"], choices=["sumo", "autopilot", "cooperative"])
    ap.add_argument(
        "--junction-rule",
        action="store_true",
        help="the autopilot with SUMO's exit junction rule (off in roundabout traffic; measured worse)",
    )
    ap.add_argument(
        "--entry-rule",
        action="store_true",
        help="the autopilot with the entry half of SUMO's junction rule (off in roundabout traffic)",
    )
    ap.add_argument(
        "--no-follow-rule",
        action="store_true",
        help="the autopilot without its follower rule (on in roundabout traffic; FOLLOWER_DECEL)",
    )
    ap.add_argument("--out", default="traffic-runs.jsonl", help="JSON lines, one run each (appended)")
    ap.add_argument("--table", help="only print the table of an existing --out file")
    ap.add_argument("--compare", nargs="+", metavar="LABEL=FILE:DRIVER",
                    help="only print the median delays of labelled runs side by side")  # fmt: skip
    args = ap.parse_args(argv)
    if args.compare:
        columns = {}
        for item in args.compare:
            label, rest = item.split("=", 1)
            path, driver = rest.rsplit(":", 1)
            runs = [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]
            columns[label] = [r for r in runs if r["driver"] == driver]
        print(compare(columns))
        return 0
    if args.table:
        results = [json.loads(line) for line in Path(args.table).read_text().splitlines() if line.strip()]
    else:
        results = run_grid(args)
    print(table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
