"""One road scenario's figure: the manoeuvre to scale with its bodies (or the failure, written as such).

Its heading says the limits the run was held to, or that it ran without operational limits and how far its
lateral acceleration goes beyond what the preset allows (model.studies.roads.road_limits_note)."""

from __future__ import annotations

import argparse
import json
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from roads_section import driving  # noqa: E402

from model.plotting.figures import save  # noqa: E402
from model.plotting.roads import driving_label, road_figure, road_note  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402
from model.studies.roads import road_limits_note  # noqa: E402


def heading_note(scenario: Path, summary: dict, ocp, columns, limits: bool = False) -> str:
    """``road_note`` with the road's own driving label (at operational limits, where it is); with ``limits``
    its limits note too (the paper's caption states it, so its figure leaves it out)."""
    note = road_note(summary, ocp, columns).replace(driving_label(ocp), driving(scenario, ocp))
    return note + ("\n" + textwrap.fill(road_limits_note(scenario, summary), 100) if limits else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--result", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True, help="output stem")
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args()
    ocp = load_scenario(args.scenario).ocp
    summary = json.loads((args.result / "summary.json").read_text())
    if summary.get("valid"):
        columns = pd.read_csv(args.result / "trajectory.csv")
        fig = road_figure(ocp, columns, note=heading_note(args.scenario, summary, ocp, columns))
    else:
        fig, ax = plt.subplots(figsize=(6, 2))
        ax.axis("off")
        reason = (summary.get("diagnosis") or {}).get("message", summary.get("status"))
        ax.text(0.5, 0.5, f"{ocp.name}: FAILED\n{reason}", ha="center", va="center", wrap=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save(fig, args.out, args.formats)


if __name__ == "__main__":
    main()
