"""The truck in traffic, one run drawn: a time-space diagram of the conflict zone, snapshots, an animation.

The run is a kept run of one cell (workflows/scripts/traffic_cell.py --keep); the drawing is
model.plotting.traffic's, every vehicle to scale.
"""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from studies_common import plt  # noqa: E402, F401  (the Agg backend)

from model.plotting.figures import save  # noqa: E402
from model.plotting.traffic import animation, snapshots, time_space  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.study import cell_document, read_columns  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cell-json", type=Path, required=True)
    ap.add_argument("--run", type=Path, required=True, help="a kept run folder (traffic.csv, trajectory.csv)")
    ap.add_argument("--out", type=Path, required=True, help="folder for time-space, snapshots and the GIF")
    ap.add_argument("--link", required=True, help="the folder as the paper links it")
    ap.add_argument("--fragment", type=Path, required=True, help="the Markdown fragment with the figures")
    args = ap.parse_args()
    cell = json.loads(args.cell_json.read_text())
    doc = cell_document(tomllib.loads(Path(cell["template"]).read_text()), cell["rate"], cell["seed"])
    ocp = parse_scenario(doc, default_name=cell["cell"]).ocp
    traffic, trajectory = read_columns(args.run / "traffic.csv"), read_columns(args.run / "trajectory.csv")
    seed = json.loads((args.run / "summary.json").read_text())["seed"]
    record = next((r for r in cell["runs"] if r.get("seed") == seed), {})
    save(time_space(ocp, traffic, trajectory, record), args.out / "time-space")
    save(snapshots(ocp, traffic, trajectory, record), args.out / "snapshots")
    animation(ocp, traffic, trajectory, record, args.out / "traffic.gif")
    args.fragment.write_text(
        f"One run drawn ({cell['cell']}, seed {seed}): the conflict zone in time and space and snapshots,"
        f" every vehicle to scale; the run's animation is [{args.link}/traffic.gif]({args.link}/traffic.gif)"
        f" (not a figure: its frames are the snapshots' scene).\n\n![Time-space diagram]({args.link}/time-space.png)"
        f"\n\n![Snapshots]({args.link}/snapshots.png)\n"
    )


if __name__ == "__main__":
    main()
