"""The truck in traffic drawn: a time-space diagram of its entry's conflict zone, snapshots, an animation.

Every vehicle to scale: the truck's bodies as the exact rectangles of its states, every other
vehicle as the rectangle of its traffic.csv row (centre, heading, length, width; docs/traffic-format.md).
The time-space diagram shows, against time, the position along the ring's centre line measured from
the conflict line of the truck's entry (in the circulation direction) of every vehicle on the ring,
the truck's front bumper and the rear of its last body, the stream's passages of the line, and the
truck's arrival at the line, entry and entry cleared (``record``: keys ``arrival``, ``entry``,
``cleared``, ``passage_times``, as ``model.traffic.study.run_record`` gives them).
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Polygon as PolygonPatch
from PIL import Image

from model.analysis.bodies import body_corners
from model.plotting.figures import FIGURE_WIDTH, direction_arrow
from model.plotting.roads import BODY_COLORS, FONT, draw_roundabout, draw_scale_bar
from model.problem.ocp import OCP
from model.vehicles.body import centred_rectangle

Columns = Mapping[str, np.ndarray]
OTHER_COLUMNS = ("x", "y", "heading", "length", "width")  # names: traffic.csv's columns of a rectangle


OTHER = "#7a7a7a"


def body_color(name: str) -> str:
    """The roads figures' colour of a body (the tractor's for any body without one)."""
    return BODY_COLORS.get(name, BODY_COLORS["vehicle"])


def ring_position(ra, axis: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Arc length (m) on the ring's centre line from the conflict line, in the circulation direction."""
    a = ra.circulation * (np.arctan2(y - ra.center[1], x - ra.center[0]) - axis)
    a = (a + math.pi) % (2 * math.pi) - math.pi
    return a * (ra.outer_radius + ra.inner_radius) / 2


def time_space(ocp: OCP, traffic: Columns, trajectory: Columns, record: Mapping) -> plt.Figure:
    """Positions on the ring from the conflict line against time: the others, the truck's ends, its marks."""
    ra = ocp.road.roundabout
    axis = ra.legs[ocp.road.route.enter].angle
    fig, ax = plt.subplots(figsize=(FIGURE_WIDTH, 4.6), layout="constrained")
    cx, cy = (np.asarray(traffic[c], float) for c in OTHER_COLUMNS[:2])
    r = np.hypot(cx - ra.center[0], cy - ra.center[1])
    on = (r >= ra.inner_radius - 0.5) & (r <= ra.outer_radius + 0.5)
    for vid in np.unique(traffic["id"]):
        k = (traffic["id"] == vid) & on
        if k.sum() < 2:
            continue
        s = ring_position(ra, axis, cx[k], cy[k])
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
    ax.set(xlabel="simulation time (s)", ylabel="position on the ring from\nthe entry's conflict line (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=FONT, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=2, frameon=False,
              title=f"Conflict zone of the truck's entry ({ocp.name}); | = a passage of the line",
              title_fontsize=FONT + 1, alignment="left")  # fmt: skip
    return fig


class Scene:
    """The roundabout drawn once; the vehicles redrawn at each time."""

    def __init__(self, ax: plt.Axes, ocp: OCP, traffic: Columns, trajectory: Columns, reach: float = 32.0):
        """``reach``: the view, a square this far (m) beyond the ring's outer curb each side."""
        self.ax, self.ocp = ax, ocp
        self.traffic, self.trajectory = traffic, trajectory
        draw_roundabout(ax, self.ocp, label=False)
        ra = self.ocp.road.roundabout
        reach += ra.outer_radius
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
            corners = centred_rectangle(*(float(self.traffic[c][k]) for c in OTHER_COLUMNS))
            self.patches.append(self.ax.add_patch(PolygonPatch(corners, fc=OTHER, ec="k", lw=0.5, zorder=5)))
        i = int(np.argmin(np.abs(self.trajectory["t"] - t)))
        for name, c in self.corners.items():
            self.patches.append(self.ax.add_patch(PolygonPatch(c[i], fc=body_color(name), ec="k", lw=0.7, zorder=6)))
        self.label.set_text(f"t = {t:.1f} s")


def snapshots(ocp: OCP, traffic: Columns, trajectory: Columns, record: Mapping) -> plt.Figure:
    """The scene at the truck's arrival at the line, its entry, its entry cleared and its arrival."""
    keys = [k for k in ("arrival", "entry", "cleared") if record.get(k) is not None and math.isfinite(record[k])]
    times = [record[k] for k in keys] + [float(trajectory["t"][-1])]
    names = [*keys, "arrived"]
    cols = 2 if len(times) > 1 else 1
    rows = math.ceil(len(times) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(FIGURE_WIDTH, 0.5 * FIGURE_WIDTH * rows + 0.5), layout="constrained")
    axes = np.atleast_1d(axes).ravel()
    reach = snapshot_reach(ocp, trajectory, times)
    for ax, t, name in zip(axes, times, names, strict=False):
        scene = Scene(ax, ocp, traffic, trajectory, reach=reach)
        scene.at(t)
        scene.label.set_visible(False)  # the panel's title says the time
        draw_route(ax, ocp, trajectory)
        ax.set_title(f"{name.replace('cleared', 'entry cleared')}: t = {t:.1f} s", fontsize=FONT + 1)
    for ax in axes[len(times):]:
        ax.set_visible(False)
    fig.suptitle(f"{ocp.name}: the truck (colour, its bodies) among the other vehicles (grey), to scale;\n"
                 "its route dotted with arrowheads, from the green dot to the red square",
                 fontsize=FONT + 1)  # fmt: skip
    return fig


def draw_route(ax: plt.Axes, ocp: OCP, trajectory: Columns) -> None:
    """The truck's route (its rear axle's path) dotted, arrowheads along it, its start and goal marked."""
    px, py = ocp.vehicle.position
    x, y = np.asarray(trajectory[px], float), np.asarray(trajectory[py], float)
    color = body_color(next(iter(ocp.bodies), "vehicle"))
    ax.plot(x, y, ls=":", color=color, lw=1.0, zorder=4)
    for where in (0.3, 0.6):
        direction_arrow(ax, x, y, color, where=where)
    ax.plot(x[:1], y[:1], "o", color="tab:green", ms=5, zorder=7)
    ax.plot(x[-1:], y[-1:], "s", color="tab:red", ms=5, zorder=7)


def snapshot_reach(ocp: OCP, trajectory: Columns, times, margin: float = 6.0) -> float:
    """How far beyond the ring's outer curb the snapshots must look to hold the truck at ``times`` (m), at
    least 8 m: the vehicles large, the ring and the truck in every panel."""
    ra = ocp.road.roundabout
    corners = body_corners(ocp, {n: trajectory[n] for n in ocp.vehicle.states})
    t = np.asarray(trajectory["t"], float)
    rows = [int(np.argmin(np.abs(t - s))) for s in times]
    pts = np.concatenate([c[rows].reshape(-1, 2) for c in corners.values()])
    far = np.max(np.abs(pts - np.asarray(ra.center, float)))
    return max(8.0, far - ra.outer_radius + margin)


def animation(ocp: OCP, traffic: Columns, trajectory: Columns, record: Mapping, path: Path, every: float = 0.5) -> Path:
    """The scene every ``every`` s from 4 s before the truck's arrival at the line to its arrival, as a GIF."""
    fig, ax = plt.subplots(figsize=(5.0, 5.0), dpi=80)
    scene = Scene(ax, ocp, traffic, trajectory)
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
    return path


__all__ = ["Scene", "animation", "snapshots", "time_space"]
