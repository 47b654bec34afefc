"""Figures across scenarios: the phase rate of the controls (Fig. 8), the paths together (Fig. 9), and the
cases of one scenario overlaid (their controls, path and energy in one figure)."""

from __future__ import annotations

import argparse
from pathlib import Path

from model.plotting import figures as plotting
from model.plotting.results import load_result
from model.problem.scenario import load_scenario


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=["phase-rate", "paths", "cases"])
    ap.add_argument("--scenarios", nargs="+", type=Path, required=True, help="scenario files")
    ap.add_argument("--results", nargs="+", type=Path, required=True, help="solve folders, same order")
    ap.add_argument("--order", nargs="+", required=True, help="every scenario name (fixes the colours)")
    ap.add_argument("--out", type=Path, required=True, help="output stem (no suffix)")
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args(argv)
    plotting.apply_style()
    results = [load_result(d, name=f.stem) for f, d in zip(args.scenarios, args.results, strict=True)]
    if args.kind == "phase-rate":
        fig = plotting.phase_rate_figure(results, args.order)
    else:
        draw = plotting.paths_figure if args.kind == "paths" else plotting.cases_figure
        fig = draw(results, [load_scenario(f).ocp for f in args.scenarios], args.order)
    plotting.save(fig, args.out, args.formats)


if __name__ == "__main__":
    main()
