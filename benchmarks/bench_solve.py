"""Benchmark: this project's Pyomo -> CasADi -> cyipopt route against CasADi Opti.

The peer runs twice: with detect_simple_bounds (bounds and boundary values as variable
bounds: the same NLP as the project's presolved one) and with Opti's defaults.

Usage: python benchmarks/bench_solve.py [--sizes 100 400 1600 3200] [--scenario FILE]

Both solve the same trapezoid transcription from the same guess to the same tolerance,
one after the other in this process; the table reports build, derivative setup, Ipopt
and total wall times, iterations, objectives and the ratio total(project)/total(Opti).
"""

from __future__ import annotations

import argparse
import gc
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.opti_peer import solve_with_opti  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.search.multistart import solve_pass  # noqa: E402


def project(ocp, n: int, passing: str) -> dict:
    gc.collect()  # each timing starts from a clean heap (as timeit and pyperf do)
    t0 = time.perf_counter()
    sol = solve_pass(ocp, n, passing)
    total = time.perf_counter() - t0
    t = sol.timings
    return {
        "build": t["model_build"],
        "setup": t["derivative_setup"],
        "ipopt": t["ipopt"],
        "total": t["model_build"] + t["derivative_setup"] + t["ipopt"],
        "total_with_post": total,
        "iterations": sol.iterations,
        "objective": sol.objective,
        "status": sol.status,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 400, 1600, 3200])
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "format-example.toml"))
    ap.add_argument("--pass", dest="passing", default="ccw")
    ap.add_argument("--repeat", type=int, default=1, help="best of R runs of each")
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args(argv)
    ocp = load_scenario(args.scenario).ocp
    rows = []
    print(f"# {platform.node()} {platform.processor() or platform.machine()}, python {platform.python_version()}")
    print(f"# scenario {Path(args.scenario).name}, pass {args.passing}, best of {args.repeat}")
    head = (
        "| N | build s | setup s | Ipopt s | total s | iters | Opti total s (iters) | ratio "
        "| Opti default total s (iters) | ratio | objective rel. diff |"
    )
    print(head)
    print("|" + "---|" * 11)
    for n in args.sizes:
        ours = min((project(ocp, n, args.passing) for _ in range(args.repeat)), key=lambda r: r["total"])
        peer = min((solve_with_opti(ocp, n, args.passing) for _ in range(args.repeat)), key=lambda r: r["total"])
        plain = min(
            (solve_with_opti(ocp, n, args.passing, simple_bounds=False) for _ in range(args.repeat)),
            key=lambda r: r["total"],
        )
        ratio = ours["total"] / peer["total"]
        diff = abs(ours["objective"] - peer["objective"]) / max(abs(peer["objective"]), 1e-12)
        rows.append({"N": n, "project": ours, "opti": peer, "opti_default": plain, "ratio": ratio,
                     "objective_rel_diff": diff})  # fmt: skip
        print(
            f"| {n} | {ours['build']:.3f} | {ours['setup']:.3f} | {ours['ipopt']:.3f} | {ours['total']:.3f} | "
            f"{ours['iterations']} | {peer['total']:.3f} ({peer['iterations']}) | {ratio:.2f} | "
            f"{plain['total']:.3f} ({plain['iterations']}) | {ours['total'] / plain['total']:.2f} | {diff:.1e} |",
            flush=True,
        )
    if len(rows) > 1:
        for who in ("project", "opti"):
            total = _slope(rows, lambda r, w=who: r[w]["total"])
            per_iter = _slope(rows, lambda r, w=who: r[w]["total"] / max(r[w]["iterations"], 1))
            print(f"# {who}: cost exponent (log-log slope vs N) total {total:.2f}, per iteration {per_iter:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


def _slope(rows: list[dict], value) -> float:
    return float(np.polyfit(np.log([r["N"] for r in rows]), np.log([value(r) for r in rows]), 1)[0])


if __name__ == "__main__":
    sys.exit(main())
