"""Benchmark: the default solve of a road scenario (issue 11: a semitrailer left turn through a
40 m roundabout at N = 200 in under 10 s), against the previous search policy in the same run.

Usage: python benchmarks/bench_roads.py [--scenario workflows/roads/semitrailer-left-turn.toml]
       [--intervals 200] [--repeat 3]

Rows: ``default`` (``ocp.solve(intervals=N)``: screening on N / 4, refinement at N, accuracy
check) and ``every start at N`` (``screen=False``: each cold start solved at N, as before
screening existed). Each is timed ``--repeat`` times in this process (after one warm-up solve
that fills the derivation cache and imports), minimum and median reported, with the phases
of the fastest run, the objective, and the load average of the machine.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.problem.scenario import load_scenario  # noqa: E402

POLICIES = {"default": {}, "every start at N": {"screen": False}}


def timed(ocp, n: int, options: dict) -> tuple[float, object]:
    gc.collect()
    t0 = time.perf_counter()
    sol = ocp.solve(intervals=n, **options)
    return time.perf_counter() - t0, sol


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor())  # fmt: skip
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "workflows/roads/semitrailer-left-turn.toml"))
    ap.add_argument("--intervals", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    ocp = load_scenario(args.scenario).ocp
    timed(ocp, 40, {})  # warm-up: imports, derivation cache
    print(f"## Road solve: {Path(args.scenario).stem}, N = {args.intervals}\n")
    print(f"machine: {machine()}; load average before: {os.getloadavg()[0]:.2f}\n")
    print("| policy | min s | median s | objective | valid | N kept | Ipopt s | build s | setup s | analysis s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, options in POLICIES.items():
        runs = [timed(ocp, args.intervals, options) for _ in range(args.repeat)]
        best_s, sol = min(runs, key=lambda r: r[0])
        ph = sol.timings.get("all_starts", {})
        print(f"| {name} | {best_s:.2f} | {statistics.median(r[0] for r in runs):.2f} | {sol.objective:.8g} | {sol.ok} "
              f"| {sol.intervals} | {ph.get('ipopt', 0):.2f} | {ph.get('model_build', 0):.2f} "
              f"| {ph.get('derivative_setup', 0):.2f} | {ph.get('analysis', 0):.2f} |")  # fmt: skip
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
