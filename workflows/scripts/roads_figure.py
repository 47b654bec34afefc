"""One road scenario's figure: the manoeuvre to scale with its bodies (or the failure, written as such)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from model.plotting.figures import save  # noqa: E402
from model.plotting.roads import driving_label, road_figure, steering_changes  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402


def note(summary: dict, ocp=None, columns=None) -> str:
    """The lines under the figure's title: final time, energy and the least clearance at the nodes;
    with the problem and its node columns, how it drives (time-optimal or its design speed and limits),
    the largest |a_lat| at the nodes and between them, and how often u2 changes sign."""
    parts = [
        f"$T_f$ = {summary['final_time']:.2f} s" if summary.get("final_time") is not None else "",
        f"energy {summary['energy']:.1f}" if summary.get("energy") is not None else "",
    ]
    if summary.get("min_clearance") is not None:
        body = summary.get("min_clearance_body")
        parts.append(f"least clearance to a curb {summary['min_clearance']:.2f} m" + (f" ({body})" if body else ""))
    text = ", ".join(p for p in parts if p)
    if ocp is None or columns is None:
        return text
    driving = [driving_label(ocp)]
    lateral = summary.get("lateral_acceleration") or {}
    if lateral.get("max_abs_nodes") is not None:
        dense = lateral.get("max_abs_dense")
        between = f" ({dense:.3f} between nodes)" if dense is not None else ""
        driving.append(f"max $|a_{{lat}}|$ {lateral['max_abs_nodes']:.3f} m/s$^2${between}")
    driving.append(f"$u_2$ changes sign {steering_changes(ocp, columns)} times")
    return text + "\n" + ", ".join(driving)


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
        fig = road_figure(ocp, columns, note=note(summary, ocp, columns))
    else:
        fig, ax = plt.subplots(figsize=(6, 2))
        ax.axis("off")
        reason = (summary.get("diagnosis") or {}).get("message", summary.get("status"))
        ax.text(0.5, 0.5, f"{ocp.name}: FAILED\n{reason}", ha="center", va="center", wrap=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save(fig, args.out, args.formats)


if __name__ == "__main__":
    main()
