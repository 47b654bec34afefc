"""Benchmark: Ipopt configurations on one built NLP (linear solvers, MUMPS orderings).

Usage: python benchmarks/bench_ipopt.py [--sizes 400 1600] [--repeat 2]

The model and its derivatives are built once per N; every configuration then solves
from the same guess (best of R runs). A linear solver this Ipopt build does not have
(HSL, SPRAL, Pardiso) is reported as unavailable. Any configuration can be used with
``roundabout solve --ipopt KEY=VALUE`` or ``ocp.solve(options={...})``.
"""

from __future__ import annotations

import argparse
import gc
import platform
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from model.direct.solve import load_start  # noqa: E402
from model.direct.transcription import build_model  # noqa: E402
from model.nlp.casadi_nlp import CasadiNLP  # noqa: E402
from model.nlp.ipopt import run_ipopt  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.search.multistart import start_values  # noqa: E402

CONFIGS: dict[str, dict] = {
    "project default (MUMPS + QAMD ordering)": {},
    "MUMPS, Ipopt's automatic ordering": {"mumps_pivot_order": 7},
    "MUMPS + METIS ordering": {"mumps_pivot_order": 5},
    "MUMPS + AMD ordering": {"mumps_pivot_order": 0},
    "MUMPS + AMF ordering": {"mumps_pivot_order": 2},
    "MUMPS + PORD ordering": {"mumps_pivot_order": 4},
    "MUMPS + QAMD, no permuting scaling": {"mumps_permuting_scaling": 0},
    "MUMPS + QAMD, adaptive barrier update": {"mu_strategy": "adaptive"},
    "MA27 (HSL)": {"linear_solver": "ma27"},
    "MA57 (HSL)": {"linear_solver": "ma57"},
    "SPRAL": {"linear_solver": "spral"},
    "Pardiso (pardiso-project.org)": {"linear_solver": "pardiso"},
}


def run(nlp: CasadiNLP, x0, options: dict, repeat: int) -> dict:
    best = None
    for _ in range(repeat):
        gc.collect()
        try:
            res = run_ipopt(nlp, options, x0=x0)
        except Exception as err:  # noqa: BLE001  (an option this build rejects)
            return {"status": f"unavailable ({type(err).__name__})"}
        if res.status in ("invalid_option", "solver_error") or res.code in (-12, -11):
            return {"status": f"unavailable ({res.message[:40]})"}
        if best is None or res.seconds < best["seconds"]:
            best = {
                "status": res.status,
                "seconds": res.seconds,
                "iterations": res.iterations,
                "objective": res.objective,
            }
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[400, 1600])
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "format-example.toml"))
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)
    ocp = load_scenario(args.scenario).ocp
    print(f"# {platform.node()} {platform.machine()}, python {platform.python_version()}, best of {args.repeat}")
    print("| configuration | " + " | ".join(f"N = {n}: Ipopt s (iters)" for n in args.sizes) + " |")
    print("|---|" + "---|" * len(args.sizes))
    nlps = {}
    for n in args.sizes:
        m = build_model(ocp, n, "ccw")
        load_start(m, start_values(ocp, n, "ccw", None))
        nlp = CasadiNLP(m)
        nlps[n] = (nlp, nlp.init_primals())
    for name, options in CONFIGS.items():
        cells = []
        for n in args.sizes:
            r = run(*nlps[n], options, args.repeat)
            ok = "seconds" in r and r["status"] == "optimal"
            cells.append(f"{r['seconds']:.3f} ({r['iterations']})" if ok else r["status"])
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
