"""The truck in traffic, one run drawn: a time-space diagram of the conflict zone, snapshots, an animation.

The run is a kept run of one cell (workflows/scripts/traffic_cell.py --keep). Every vehicle is drawn
to scale: the truck's bodies as the exact rectangles of its states, every other vehicle as the
rectangle of its traffic.csv row. The time-space diagram shows, against time, the position along
the ring's centre line measured from the conflict line of the truck's entry (in the circulation
direction) of every vehicle on the ring, the truck's front bumper and the rear of its last body, the
stream's passages of the line, and the truck's arrival, entry and entry cleared.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from matplotlib.patches import Polygon as PolygonPatch  # noqa: E402
from PIL import Image  # noqa: E402
from studies_common import plt  # noqa: E402

from model.analysis.bodies import body_corners  # noqa: E402
from model.plotting.figures import save  # noqa: E402
from model.plotting.roads import BODY_COLORS, draw_roundabout, draw_scale_bar  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.run import TRAFFIC_COLUMNS, other_corners  # noqa: E402
from model.traffic.study import cell_document, read_columns  # noqa: E402

OTHER = "#7a7a7a"


def body_color(name: str) -> str:
    """The roads figures' colour of a body (the tractor's for any body without one)."""
    return BODY_COLORS.get(name, BODY_COLORS["vehicle"])


def ring_position(ra, axis: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Arc length (m) on the ring's centre line from the conflict line, in the circulation direction."""
    a = ra.circulation * (np.arctan2(y - ra.center[1], x - ra.center[0]) - axis)
    a = (a + math.pi) % (2 * math.pi) - math.pi
    return a * (ra.outer_radius + ra.inner_radius) / 2


def time_space(scenario, traffic, trajectory, record, stem: Path) -> None:
    ocp = scenario.ocp
    ra = ocp.road.roundabout
    axis = ra.legs[ocp.road.route.enter].angle
    fig, ax = plt.subplots(figsize=(8.0, 4.8))
    r = np.hypot(traffic["x"] - ra.center[0], traffic["y"] - ra.center[1])
    on = (r >= ra.inner_radius - 0.5) & (r <= ra.outer_radius + 0.5)
    for vid in np.unique(traffic["id"]):
        k = (traffic["id"] == vid) & on
        if k.sum() < 2:
            continue
        s = ring_position(ra, axis, traffic["x"][k], traffic["y"][k])
        s = np.where(np.abs(np.diff(s, prepend=s[0])) > 5, np.nan, s)
        ax.plot(traffic["t"][k], s, color=OTHER, lw=1.0)
    corners = body_corners(ocp, {n: trajectory[n] for n in ocp.vehicle.states})
    names = list(corners)
    first, last = corners[names[0]], corners[names[-1]]
    ends = (((first[:, 1] + first[:, 2]) / 2, "truck: front bumper", body_color(names[0])),
            ((last[:, 0] + last[:, 3]) / 2, "truck: rear of its last body", body_color(names[-1])))  # fmt: skip
    for pts, label, color in ends:
        rr = np.hypot(pts[:, 0] - ra.center[0], pts[:, 1] - ra.center[1])
        s = np.where(rr <= ra.outer_radius + 0.5, ring_position(ra, axis, pts[:, 0], pts[:, 1]), np.nan)
        ax.plot(trajectory["t"], s, color=color, lw=2.2, label=label)
    ax.plot([], [], color=OTHER, lw=1.0, label="other vehicles (centres) on the ring")
    for t in record.get("passage_times", []):
        ax.plot([t], [0.0], marker="|", color="k", ms=10)
    for key, style in (("arrival", ":"), ("entry", "--"), ("cleared", "-.")):
        if record.get(key) is not None and math.isfinite(record[key]):
            label = f"truck {key.replace('cleared', 'entry cleared')}"
            ax.axvline(record[key], color="0.35", ls=style, lw=1.0, label=label)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlabel="simulation time (s)", ylabel="position on the ring from the entry's conflict line (m)",
           title=f"Conflict zone of the truck's entry ({scenario.ocp.name}); | = a passage of the line")  # fmt: skip
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    save(fig, stem)


class Scene:
    """The roundabout drawn once; the vehicles redrawn at each time."""

    def __init__(self, ax, scenario, traffic, trajectory):
        self.ax, self.ocp = ax, scenario.ocp
        self.traffic, self.trajectory = traffic, trajectory
        draw_roundabout(ax, self.ocp, label=False)
        ra = self.ocp.road.roundabout
        reach = ra.outer_radius + 32
        ax.set(xlim=(ra.center[0] - reach, ra.center[0] + reach), ylim=(ra.center[1] - reach, ra.center[1] + reach))
        ax.set_aspect("equal")
        ax.set_xticks([]), ax.set_yticks([])
        draw_scale_bar(ax)
        self.corners = body_corners(self.ocp, {n: trajectory[n] for n in self.ocp.vehicle.states})
        self.patches, self.label = [], ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9)

    def at(self, t: float) -> None:
        for p in self.patches:
            p.remove()
        self.patches = []
        tt = self.traffic["t"]
        ks = np.flatnonzero(np.isclose(tt, tt[np.argmin(np.abs(tt - t))]))
        for k in ks:
            row = tuple(self.traffic[c][k] for c in TRAFFIC_COLUMNS)
            self.patches.append(self.ax.add_patch(PolygonPatch(other_corners(row), fc=OTHER, ec="k", lw=0.5, zorder=5)))
        i = int(np.argmin(np.abs(self.trajectory["t"] - t)))
        for name, c in self.corners.items():
            self.patches.append(self.ax.add_patch(PolygonPatch(c[i], fc=body_color(name), ec="k", lw=0.7, zorder=6)))
        self.label.set_text(f"t = {t:.1f} s")


def snapshots(scenario, traffic, trajectory, record, stem: Path) -> None:
    keys = [k for k in ("arrival", "entry", "cleared") if record.get(k) is not None and math.isfinite(record[k])]
    times = [record[k] for k in keys] + [float(trajectory["t"][-1])]
    names = [*keys, "arrived"]
    fig, axes = plt.subplots(1, len(times), figsize=(4.0 * len(times), 4.2))
    for ax, t, name in zip(np.atleast_1d(axes), times, names, strict=True):
        Scene(ax, scenario, traffic, trajectory).at(t)
        ax.set_title(f"{name.replace('cleared', 'entry cleared')}: t = {t:.1f} s", fontsize=9)
    fig.suptitle(f"{scenario.ocp.name}: the truck (colour, its bodies) among the other vehicles (grey), to scale")
    fig.tight_layout()
    save(fig, stem)


def animation(scenario, traffic, trajectory, record, path: Path, every: float = 0.5) -> None:
    fig, ax = plt.subplots(figsize=(5.0, 5.0), dpi=80)
    scene = Scene(ax, scenario, traffic, trajectory)
    t0 = max(float(trajectory["t"][0]), (record.get("arrival") or 0.0) - 4.0)
    frames = []
    for t in np.arange(t0, float(trajectory["t"][-1]) + 1e-9, every):
        scene.at(float(t))
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        frames.append(Image.open(buf).convert("P", palette=Image.ADAPTIVE))
    plt.close(fig)
    path.parent.mkdir(parents=True, exist_ok=True)
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=round(1000 * every), loop=0)


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
    scenario = parse_scenario(doc, default_name=cell["cell"])
    traffic, trajectory = read_columns(args.run / "traffic.csv"), read_columns(args.run / "trajectory.csv")
    seed = json.loads((args.run / "summary.json").read_text())["seed"]
    record = next((r for r in cell["runs"] if r.get("seed") == seed), {})
    time_space(scenario, traffic, trajectory, record, args.out / "time-space")
    snapshots(scenario, traffic, trajectory, record, args.out / "snapshots")
    animation(scenario, traffic, trajectory, record, args.out / "traffic.gif")
    args.fragment.write_text(
        f"One run drawn ({cell['cell']}, seed {record.get('seed')}): the conflict zone in time and space, snapshots"
        f" and an animation, every vehicle to scale.\n\n![Time-space diagram]({args.link}/time-space.png)\n\n"
        f"![Snapshots]({args.link}/snapshots.png)\n\n![Animation]({args.link}/traffic.gif)\n"
    )


if __name__ == "__main__":
    main()
