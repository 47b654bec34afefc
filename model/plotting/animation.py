"""A road manoeuvre as an animated GIF: the vehicle driving its trajectory over the roundabout plan.

Each frame shows the plan to scale (as in ``model.plotting.roads``), the bodies and the other
vehicles (moving obstacles, with their paths dotted) at the frame's time, the envelope each body
has swept so far, the axle tracks so far and the planned rear-axle path ahead, and a time label.
States between the nodes are interpolated linearly, as for the validation's dense check
(``model.analysis.bodies.substeps``), so the last frame's envelope is the one ``swept_polygons``
gives. Written with Pillow (no ffmpeg needed), the last frame first: a viewer that shows only the
first frame (the PDF) shows the complete manoeuvre.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import shapely
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, PathPatch
from matplotlib.patches import Polygon as PolygonPatch
from PIL import Image

from model.analysis.bodies import body_corners
from model.plotting.figures import MOVING_COLOR, apply_style
from model.plotting.roads import (
    BODY_COLORS,
    TRACK_STYLES,
    axle_tracks,
    body_label,
    draw_north,
    draw_roundabout,
    draw_scale_bar,
    frame_plan,
    geometry_patch,
)
from model.problem.ocp import OCP

SAMPLES_PER_INTERVAL = 8  # rectangles per node interval in the growing envelope (as swept_polygons)


def frame_times(final_time: float, fps: float = 12.0, duration: float = 10.0) -> np.ndarray:
    """Times of the moving frames: ``round(fps * duration)`` frames from 0 to ``final_time`` inclusive.

    Parameters
    ----------
    final_time : float
        The manoeuvre's duration, s.
    fps : float
        Frames per second of the GIF.
    duration : float
        Playing time of the moving part, s (the manoeuvre is sped up or slowed down to fit).
    """
    return np.linspace(0.0, float(final_time), max(2, round(fps * duration)))


def interpolate(columns: Mapping[str, np.ndarray], names, times: np.ndarray) -> dict[str, np.ndarray]:
    """States ``names`` linearly interpolated in time at ``times``."""
    t = np.asarray(columns["t"], float)
    return {n: np.interp(times, t, np.asarray(columns[n], float)) for n in names}


@dataclass
class _Scene:
    """The artists that change from frame to frame, and the envelope swept so far."""

    bodies: dict[str, PolygonPatch]
    tracks: dict[str, plt.Line2D]
    label: plt.Text
    outlines: dict[str, PathPatch]
    others: list[PolygonPatch] = field(default_factory=list)
    envelopes: dict = field(default_factory=dict)


class RoadAnimation:
    """Frames of a solved road manoeuvre.

    Parameters
    ----------
    ocp : OCP
        A problem with a ``road``.
    columns : mapping
        Node values: t and the states (a Solution's ``columns`` or a trajectory.csv).
    times : ndarray
        The frames' times, increasing, within [0, final time].
    size : (float, float)
        Figure size, inches.
    """

    def __init__(
        self, ocp: OCP, columns: Mapping[str, np.ndarray], times: np.ndarray, size=(5.6, 5.6), dpi: float = 100.0
    ) -> None:
        apply_style()
        self.ocp, self.times, self.dpi = ocp, np.asarray(times, float), dpi
        states = ocp.vehicle.states
        self.nodes = {k: np.asarray(columns[k], float) for k in ("t", *states)}
        t = self.nodes["t"]
        fine = np.linspace(t[0], t[-1], SAMPLES_PER_INTERVAL * (len(t) - 1) + 1)
        self.samples_t = np.union1d(fine, self.times)
        self.samples = interpolate(self.nodes, states, self.samples_t)
        self.rectangles = {n: shapely.polygons(c) for n, c in body_corners(ocp, self.samples).items()}
        self.tracks = axle_tracks(ocp, self.samples)
        self.fig, ax = plt.subplots(figsize=size, dpi=dpi, layout="constrained")
        self._draw_static(ax)
        self.scene = self._draw_moving(self._freeze(ax))

    def _draw_static(self, ax: plt.Axes) -> None:
        """The plan, the planned path, the scale bar, north arrow, title and legend."""
        ocp = self.ocp
        draw_roundabout(ax, ocp, label=False)
        px, py = ocp.vehicle.position
        ax.plot(self.nodes[px], self.nodes[py], color="0.35", lw=0.7, ls=(0, (2, 3)), zorder=2)
        span = np.linspace(0.0, float(self.nodes["t"][-1]), 200)
        for ob in ocp.moving_obstacles:
            ax.plot(*ob.path(span).T, color=MOVING_COLOR, lw=0.7, ls=":", zorder=2)
        frame_plan(ax, ocp, self.nodes)
        draw_scale_bar(ax)
        draw_north(ax)
        handles = [Patch(fc=(*to_rgb(BODY_COLORS.get(n, "0.4")), 0.6), ec=BODY_COLORS.get(n, "0.4"),
                         label=body_label(ocp, n)) for n in self.rectangles]  # fmt: skip
        if ocp.moving_obstacles:
            handles.append(Patch(fc=(*to_rgb(MOVING_COLOR), 0.6), ec=MOVING_COLOR, label="other vehicle"))
        handles += [Patch(fc=(0.5, 0.5, 0.6, 0.2), ec="0.3", lw=0.8, label="swept so far"),
                    Line2D([], [], color="0.35", lw=0.7, ls=(0, (2, 3)), label="planned rear axle path")]  # fmt: skip
        ax.set_title(textwrap.fill(ocp.title or ocp.name, 70), fontsize=8)
        ax.legend(handles=handles, loc="lower left", fontsize=7, framealpha=0.9)

    def _freeze(self, ax: plt.Axes) -> plt.Axes:
        """Render the static figure once into a background image; return a clear axes over the plan.

        The frames then draw one image and the moving artists instead of every curb, text and tick.
        """
        self.fig.canvas.draw()
        self.fig.set_layout_engine("none")
        background = np.asarray(self.fig.canvas.buffer_rgba()).copy()
        ax.set_visible(False)
        self.fig.figimage(background, zorder=-1)
        overlay = self.fig.add_axes(ax.get_position(), xlim=ax.get_xlim(), ylim=ax.get_ylim(), aspect="equal")
        overlay.set_axis_off()
        return overlay

    def _draw_moving(self, ax: plt.Axes) -> _Scene:
        """The artists that each frame updates: bodies, envelopes so far, axle tracks so far, the time."""
        bodies, outlines = {}, {}
        for name in self.rectangles:
            color = BODY_COLORS.get(name, "0.4")
            patch = PolygonPatch(np.zeros((4, 2)), closed=True, fc=(*to_rgb(color), 0.6), ec=color, lw=1.0, zorder=8)
            bodies[name] = ax.add_patch(patch)
            style = {"facecolor": (*to_rgb(color), 0.15), "edgecolor": color, "lw": 0.8, "zorder": 4}
            outlines[name] = ax.add_artist(geometry_patch(shapely.Polygon(), **style))
        tracks = {}
        for name in self.tracks:
            color = BODY_COLORS["trailer"] if name == "trailer axle" else "black"
            (tracks[name],) = ax.plot([], [], color=color, lw=0.8, ls=TRACK_STYLES[name], zorder=7)
        label = ax.text(0.03, 0.97, "", transform=ax.transAxes, va="top", fontsize=9,
                        bbox={"fc": "white", "ec": "0.7", "alpha": 0.9})  # fmt: skip
        style = {"closed": True, "fc": (*to_rgb(MOVING_COLOR), 0.6), "ec": MOVING_COLOR, "lw": 1.0, "zorder": 8}
        others = [ax.add_patch(PolygonPatch(np.zeros((4, 2)), **style)) for _ in self.ocp.moving_obstacles]
        return _Scene(bodies, tracks, label, outlines, others)

    def draw(self, k: int) -> None:
        """Bring the artists to frame ``k`` (frames must be drawn in order for the envelope to grow)."""
        s, t = self.scene, self.times[k]
        upto = int(np.searchsorted(self.samples_t, t, side="right"))
        lo = int(np.searchsorted(self.samples_t, self.times[k - 1], side="left")) if k else 0
        for name, rects in self.rectangles.items():
            new = shapely.union_all(rects[lo:upto])
            s.envelopes[name] = shapely.union(s.envelopes[name], new) if name in s.envelopes else new
            s.outlines[name].set_path(geometry_patch(s.envelopes[name]).get_path())
            s.bodies[name].set_xy(shapely.get_coordinates(rects[upto - 1].exterior))
        for name, xy in self.tracks.items():
            s.tracks[name].set_data(*xy[:upto].T)
        for patch, ob in zip(s.others, self.ocp.moving_obstacles, strict=True):
            patch.set_xy(ob.outline(t))  # the other vehicle where it is at this frame's time
        s.label.set_text(f"t = {t:5.1f} s")

    def _grab(self) -> Image.Image:
        """The figure as it is drawn now, an RGBA image."""
        self.fig.canvas.draw()
        return Image.fromarray(np.asarray(self.fig.canvas.buffer_rgba()).copy())

    def save(self, path: str | Path, fps: float = 12.0, hold: float = 1.5) -> Path:
        """Write the GIF: the whole manoeuvre (the last frame) held ``hold`` seconds, then the moving frames.

        The frames are drawn in order (the envelope grows) and written starting with the last one, so the
        first frame, all that a PDF or a still viewer shows, is the complete manoeuvre, and the loop plays
        as before: the motion from t = 0, then the complete manoeuvre held. The GIF has ``len(times)``
        frames, the first one lasting ``1 / fps + hold`` (rounded to whole frames).
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        frames = []
        for k in range(len(self.times)):
            self.draw(k)
            frames.append(self._grab())
        plt.close(self.fig)
        step = 1000.0 / fps
        durations = [round(step * (1 + round(hold * fps)))] + [round(step)] * (len(frames) - 1)
        frames = [frames[-1], *frames[:-1]]
        frames[0].save(path, save_all=True, append_images=frames[1:], duration=durations, loop=0)
        return path


def road_animation(
    ocp: OCP,
    columns: Mapping[str, np.ndarray],
    path: str | Path,
    fps: float = 12.0,
    duration: float = 10.0,
    hold: float = 1.5,
    dpi: float = 100.0,
) -> Path:
    """Write the manoeuvre as an animated GIF.

    Parameters
    ----------
    ocp : OCP
        A problem with a ``road``.
    columns : mapping
        Node values: t and the states.
    path : str or Path
        The GIF to write.
    fps : float
        Frames per second.
    duration : float
        Playing time of the moving part, s; ``round(fps * duration)`` frames.
    hold : float
        How long the complete manoeuvre (the last frame, written first) stays, s.
    dpi : float
        Pixels per inch of the 5.6 x 5.6 inch frames.

    Returns
    -------
    Path
        ``path``.
    """
    times = frame_times(float(np.asarray(columns["t"])[-1]), fps, duration)
    return RoadAnimation(ocp, columns, times, dpi=dpi).save(path, fps=fps, hold=hold)
