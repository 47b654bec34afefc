"""Benchmark: a warm-started re-solve after a small change of Tf against a cold solve.

Usage: python benchmarks/bench_resolve.py [--sizes 100 400 1600] [--delta -0.1]

Cold: build the model, set up derivatives, solve from the geometric guess. Warm: change
the final-time Param of the built model and re-solve from the previous primal-dual point
(model/direct/resolve.py). Both include the post-processing (costates, validation, certificate);
the garbage of earlier solves is collected before each timing.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.direct.resolve import Resolver  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.search.multistart import solve_pass  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 400, 1600])
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "format-example.toml"))
    ap.add_argument("--delta", type=float, default=-0.1, help="change of the final time, s")
    args = ap.parse_args(argv)
    base = load_scenario(args.scenario).ocp
    print("| N | cold s (Ipopt s, iters) | warm s (Ipopt s, iters) | warm/cold | objective rel. diff |")
    print("|---|---|---|---|---|")
    for n in args.sizes:
        first = solve_pass(base, n, "ccw")
        changed = load_scenario(args.scenario).ocp
        changed.final_time = base.final_time + args.delta
        gc.collect()  # each timing starts from a clean heap (as timeit and pyperf do)
        t0 = time.perf_counter()
        cold = solve_pass(changed, n, "ccw")
        t_cold = time.perf_counter() - t0
        gc.collect()
        t0 = time.perf_counter()
        warm = Resolver(first).solve(final_time=changed.final_time)
        t_warm = time.perf_counter() - t0
        diff = abs(warm.objective - cold.objective) / abs(cold.objective)
        print(
            f"| {n} | {t_cold:.3f} ({cold.solve_seconds:.3f}, {cold.iterations}) | "
            f"{t_warm:.3f} ({warm.solve_seconds:.3f}, {warm.iterations}) | {t_warm / t_cold:.2f} | {diff:.1e} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
