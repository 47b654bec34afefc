"""A road manoeuvre as a designer draws it: the roundabout to scale, bodies at intervals, swept areas.

``road_figure`` draws the roadway (ring, apron, island, every leg's lanes with their fillets and
centre lines), the route's corridor outline, the area each body sweeps, the bodies every few
nodes, the rear-axle path, and beside it the controls and (for a trailer) the articulation angle.
"""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Polygon as PolygonPatch

from model.analysis.bodies import body_corners, swept_polygons
from model.plotting.figures import PALETTE, apply_style
from model.problem.ocp import OCP
from model.scene.roundabout import apron_region, fillet_region, island_region, lane_region, ring_region

ROAD, APRON, ISLAND, CURB = "#d9d9d9", "#c2a878", "#9cc68f", "#404040"
BODY_COLORS = {"vehicle": PALETTE[0], "trailer": PALETTE[1]}


def _fill(ax: plt.Axes, geometry, **style) -> None:
    """Fill a shapely (Multi)Polygon, holes included."""
    import shapely

    for part in shapely.get_parts(geometry):
        if part.is_empty:
            continue
        ax.fill(*part.exterior.xy, **style)
        for hole in part.interiors:
            ax.fill(*hole.xy, color="white", lw=0)


def draw_roundabout(ax: plt.Axes, ocp: OCP) -> None:
    """The roadway of every leg, the ring, apron and island, and the route's corridor outline."""
    rb = ocp.road.roundabout
    for leg in range(len(rb.legs)):
        for lane in ("entry", "exit"):
            _fill(ax, lane_region(rb, leg, lane).polygon, color=ROAD, lw=0)
            _fill(ax, fillet_region(rb, leg, lane).polygon, color=ROAD, lw=0)
        axis = rb.legs[leg].axis
        reach = rb.outer_radius + rb.legs[leg].length
        start = np.asarray(rb.center) + rb.outer_radius * axis
        ax.plot(*np.column_stack([start, np.asarray(rb.center) + reach * axis]), color="white", lw=0.8, ls=(0, (6, 6)))
    _fill(ax, ring_region(rb).polygon, color=ROAD, lw=0)
    if rb.apron_width > 0:
        _fill(ax, apron_region(rb).polygon, color=APRON, lw=0, label="truck apron")
    _fill(ax, island_region(rb).polygon, color=ISLAND, lw=0, label="central island")
    corridor = ocp.road.corridor("vehicle").polygon
    import shapely

    for part in shapely.get_parts(corridor):
        ax.plot(*part.exterior.xy, color=CURB, lw=0.9)


def road_figure(ocp: OCP, columns: Mapping[str, np.ndarray], title: str = "", every: int | None = None) -> plt.Figure:
    """The manoeuvre to scale (left) and its controls over time (right).

    Parameters
    ----------
    ocp : OCP
        A problem with a ``road``.
    columns : mapping
        Node values: t, the states and the controls (a Solution's ``columns`` or a trajectory.csv).
    every : int, optional
        Draw the bodies at every ``every``-th node (default: about 12 poses).
    """
    apply_style()
    v = ocp.vehicle
    cols = {k: np.asarray(columns[k], float) for k in ("t", *v.states, *v.controls)}
    fig = plt.figure(figsize=(11.0, 5.6), constrained_layout=True)
    rows = len([c for c in ("u1", "phi", "u2") if c in cols]) + ("theta1" in v.states)
    grid = fig.add_gridspec(rows, 2, width_ratios=(1.35, 1))
    ax = fig.add_subplot(grid[:, 0])
    draw_roundabout(ax, ocp)
    _draw_bodies(ax, ocp, cols, every or max(1, (len(cols["t"]) - 1) // 12))
    px, py = v.position
    ax.plot(cols[px], cols[py], color="k", lw=1.0, label="rear axle")
    _frame(ax, ocp, cols)
    ax.set_title(title or ocp.title or ocp.name, fontsize=10)
    ax.legend(loc="lower left", fontsize=7, framealpha=0.9)
    _time_panels(fig, grid, ocp, cols)
    return fig


def _draw_bodies(ax: plt.Axes, ocp: OCP, cols: dict, every: int) -> None:
    for name, poly in swept_polygons(ocp, cols).items():
        _fill(ax, poly, color=BODY_COLORS.get(name, PALETTE[2]), alpha=0.18, lw=0, label=f"{name} swept area")
    picks = {k: a[::every] for k, a in cols.items()}
    for name, corners in body_corners(ocp, picks).items():
        for c in corners:
            ax.add_patch(PolygonPatch(c, closed=True, fill=False, lw=0.7, ec=BODY_COLORS.get(name, PALETTE[2])))


def _frame(ax: plt.Axes, ocp: OCP, cols: dict) -> None:
    """Equal axes around the path with a margin of one leg width and the ring."""
    rb = ocp.road.roundabout
    px, py = ocp.vehicle.position
    xs = np.concatenate([cols[px], [rb.center[0] - rb.outer_radius, rb.center[0] + rb.outer_radius]])
    ys = np.concatenate([cols[py], [rb.center[1] - rb.outer_radius, rb.center[1] + rb.outer_radius]])
    pad = 2 * max(g.lane_width for g in rb.legs)
    ax.set_xlim(xs.min() - pad, xs.max() + pad)
    ax.set_ylim(ys.min() - pad, ys.max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _time_panels(fig: plt.Figure, grid, ocp: OCP, cols: dict) -> None:
    v = ocp.vehicle
    rows = [c for c in ("u1", "phi", "u2") if c in cols] + (["articulation"] if "theta1" in v.states else [])
    for i, name in enumerate(rows):
        ax = fig.add_subplot(grid[i, 1])
        values = cols["theta"] - cols["theta1"] if name == "articulation" else cols[name]
        ax.plot(cols["t"], values, color=PALETTE[i % len(PALETTE)], lw=1.2)
        lo, hi = ocp.bounds.get(name, (None, None))
        for b in (lo, hi):
            if b is not None and np.isfinite(b):
                ax.axhline(b, color="0.5", lw=0.6, ls="--")
        labels = {"u1": "u1 (m/s)", "phi": "phi (rad)", "u2": "u2 (rad/s)", "articulation": "theta - theta1 (rad)"}
        ax.set_ylabel(labels.get(name, name))
    ax.set_xlabel("t (s)")
