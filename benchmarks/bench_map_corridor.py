"""Benchmark of the item-2 prototype (docs/map-corridor.md): strip solves on real rounD routes.

Usage: python benchmarks/bench_map_corridor.py [--intervals 60] [--margin 0.5] [--sigma 2.0]

For each route and vehicle: the route through the map, the sequence of fixed-projection strip
solves (``model.direct.map_corridor.solve_map``) from the centre-line start, and per solve its
status, Tf, Ipopt iterations, how far the projections moved, the exact rectangles' least
clearance in the shapely corridor at the nodes and between them (linear sub-steps), and the time.
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.direct.map_corridor import exact_clearance, solve_map, strips  # noqa: E402
from model.errors import InputError  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402

VEHICLES = {
    "SU-30": {"preset": "SU-30"},
    "EU 16.5 m": {"preset": "EU-semitrailer"},
}
# (label, dataset, from_lanelet, to_lanelet, start_offset for SU-30, for the semitrailer, goal_offset)
ROUTES = [
    ("Kackertstrasse 90 -> 102 (east -> south, left)", "rounD/DEU_Kackertstrasse-1", 90, 102, 19.0, 20.0, -12.0),
    ("Thiergarten 21 -> 90 (the second exit, straight on)", "rounD/DEU_Thiergarten-1", 21, 90, 12.0, 20.0, -8.0),
    ("Thiergarten 21 -> 50 (the first exit, right)", "rounD/DEU_Thiergarten-1", 21, 50, 12.0, 20.0, -12.0),
    ("Thiergarten 21 -> 23 (U-turn)", "rounD/DEU_Thiergarten-1", 21, 23, 12.0, 20.0, -10.0),
    ("Neuweiler 119 -> 107 (open ring)", "rounD/DEU_Neuweiler-1", 119, 107, 12.0, 20.0, -12.0),
]


def scenario(dataset: str, a: int, b: int, offset: float, goal: float, vehicle: dict, intervals: int):
    bounds = {"u1": [0.0, 6.944444444444445], "u2": [-0.5, 0.5], "phi": [-0.6, 0.6]}
    if vehicle["preset"] == "EU-semitrailer":
        bounds["articulation"] = [-1.2, 1.2]
    data = {
        "name": "bench", "vehicle": dict(vehicle), "bounds": bounds,
        "map": {"dataset": dataset},
        "route": {"from_lanelet": a, "to_lanelet": b, "start_offset": offset, "goal_offset": goal},
        "problem": {"objective": "time", "intervals": intervals},
    }  # fmt: skip
    return parse_scenario(data).ocp


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--intervals", type=int, default=60)
    ap.add_argument("--margin", type=float, default=0.5, help="m beyond the disc radius of the conservative window")
    ap.add_argument("--sigma", type=float, default=2.0, help="m, the Gaussian smoothing of the centre line")
    ap.add_argument("--slack", type=float, default=0.03, help="the cover discs reach this fraction of the half-width")
    ap.add_argument("--only", default="", help="run only the routes whose label contains this text")
    ap.add_argument("--trust", type=float, default=None, help="m: a trust region along the frame (default none)")
    ap.add_argument("--iterations", type=int, default=8, help="at most this many strip solves")
    ap.add_argument("--method", choices=("disc", "ray"), default="disc", help="how the strips are measured")
    args = ap.parse_args()
    print(f"N = {args.intervals}, window = disc radius + {args.margin} m, sigma = {args.sigma} m, "
          f"cover slack {args.slack}, trust region {args.trust} m, strips {args.method}\n")  # fmt: skip
    print("| route | vehicle | solve | status | Tf (s) | iterations | moved (m) | clearance nodes (m) | "
          "dense (m) | time (s) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, dataset, a, b, off_rigid, off_semi, goal in ROUTES:
        if args.only not in label:
            continue
        for name, vehicle in VEHICLES.items():
            offset = off_semi if "semitrailer" in vehicle["preset"] else off_rigid
            try:
                ocp = scenario(dataset, a, b, offset, goal, vehicle, args.intervals)
            except InputError as err:
                print(f"| {label} | {name} | - | refused: {err} | | | | | | |")
                continue
            t0 = time.perf_counter()
            st = strips(ocp, sigma=args.sigma, margin=args.margin, slack=args.slack, method=args.method)
            result = solve_map(ocp, args.intervals, iterations=args.iterations, st=st, trust=args.trust)
            for i, it in enumerate(result.iterates):
                sol = it.solution
                cols = {k: sol.columns[k] for k in ocp.vehicle.states}
                dense = exact_clearance(ocp, cols, dense=True)
                valid = "" if sol.validation["passed"] else " (validation failed)"
                valid += f", {it.narrow_rows} rows narrower than the disc" if it.narrow_rows else ""
                print(f"| {label} | {name} | {i + 1} | {sol.status}{valid} | {sol.final_time:.4f} | {sol.iterations} | "
                      f"{it.moved:.3f} | {it.exact_clearance:+.3f} | {dense:+.3f} | {it.seconds:.1f} |")
            print(f"| {label} | {name} | total | | | | | | | {time.perf_counter() - t0:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
