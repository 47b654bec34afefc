"""One road scenario as an animated GIF: the vehicle driving its optimal trajectory over the roundabout plan."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.animation import PillowWriter  # noqa: E402

from model.plotting.animation import road_animation  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402


def failed(name: str, reason: str, out: Path) -> None:
    """A one-frame GIF saying that the scenario has no trajectory to animate."""
    fig, ax = plt.subplots(figsize=(5.6, 1.6), dpi=100)
    ax.axis("off")
    ax.text(0.5, 0.5, f"{name}: FAILED\n{reason}", ha="center", va="center", wrap=True)
    writer = PillowWriter(fps=1)
    with writer.saving(fig, out, 100):
        writer.grab_frame()
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--result", type=Path, required=True, help="folder with summary.json and trajectory.csv")
    ap.add_argument("--out", type=Path, required=True, help="the GIF to write")
    ap.add_argument("--fps", type=float, default=12.0)
    ap.add_argument("--duration", type=float, default=10.0, help="playing time of the motion, s")
    args = ap.parse_args()
    ocp = load_scenario(args.scenario).ocp
    summary = json.loads((args.result / "summary.json").read_text())
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if summary.get("valid"):
        road_animation(ocp, pd.read_csv(args.result / "trajectory.csv"), args.out, args.fps, args.duration)
    else:
        failed(ocp.name, str((summary.get("diagnosis") or {}).get("message", summary.get("status"))), args.out)


if __name__ == "__main__":
    main()
