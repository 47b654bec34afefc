"""One scenario's figures: the paper's four panels (solution) and the Pontryagin quantities (costates)."""

from __future__ import annotations

import argparse
from pathlib import Path

from model.plotting import figures as plotting
from model.plotting.results import load_result
from model.problem.scenario import load_scenario


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path, help="scenario file")
    ap.add_argument("--result", type=Path, required=True, help="solve folder (summary.json, trajectory.csv)")
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args(argv)
    plotting.apply_style()
    ocp = load_scenario(args.scenario).ocp
    result = load_result(args.result, name=args.scenario.stem)
    plotting.save(plotting.solution_figure(result, ocp), args.out / "solution", args.formats)
    plotting.save(plotting.costate_figure(result, ocp), args.out / "costates", args.formats)


if __name__ == "__main__":
    main()
