"""The figure of one closed-loop run: the driven path against the optimum, and the controls sent."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np

from model.plotting.figures import PALETTE, apply_style, draw_obstacles, tex, unit
from model.plotting.roads import draw_poses, draw_roundabout, draw_scale_bar, frame_plan, pose_nodes
from model.problem.ocp import OCP


def closed_loop_figure(
    ocp: OCP, optimum: Mapping[str, np.ndarray], driven: Mapping[str, np.ndarray], summary: Mapping
) -> plt.Figure:
    """The plant's path (closed_loop.csv) beside the open-loop optimum (optimum/trajectory.csv).

    Parameters
    ----------
    ocp : OCP
        The scenario's problem (its obstacles or road are drawn).
    optimum : mapping
        Node values of the optimum: t, x, y and the controls.
    driven : mapping
        The closed loop's rows: t, the plant's states and ``sent_<control>``.
    summary : mapping
        The run's summary.json (controller, errors, whether the goal was reached).

    Returns
    -------
    Figure
        The plan (left) and one panel per control over time (right): the speed, the steering (or turn)
        rate, then any other control.
    """
    apply_style()
    optimum = {k: np.asarray(optimum[k], float) for k in optimum}
    driven = {k: np.asarray(driven[k], float) for k in driven}
    px, py = ocp.vehicle.position
    v = ocp.vehicle
    order = dict.fromkeys(c for c in (v.roles.speed, v.roles.turning, *v.controls) if c in v.controls)
    controls = [c for c in order if f"sent_{c}" in driven]  # the speed first, then the steering rate
    fig = plt.figure(figsize=(9.5, 4.6), layout="constrained")
    grid = fig.add_gridspec(max(1, len(controls)), 2, width_ratios=(1.25, 1))
    ax = fig.add_subplot(grid[:, 0])
    if ocp.road is not None:  # the driven bodies to scale, and the other vehicles at the same times
        draw_roundabout(ax, ocp, label=False)
        draw_scale_bar(ax)
        draw_poses(ax, ocp, driven, pose_nodes(ocp, driven))
    else:
        draw_obstacles(ax, ocp.obstacles)
    ax.plot(optimum[px], optimum[py], color="0.35", ls="--", lw=1.2, label="open-loop optimum")
    ax.plot(driven[px], driven[py], color=PALETTE[0], label=f"closed loop: {summary.get('controller', '')}")
    ax.plot(driven[px][-1], driven[py][-1], "o", color=PALETTE[3], ms=4, label="final position")
    if ocp.road is not None:
        frame_plan(ax, ocp, driven)  # the roundabout and the driven bodies, the scale bar for the scale
    else:
        ax.set_aspect("equal", adjustable="datalim")
        ax.set(xlabel=f"{px} (m)", ylabel=f"{py} (m)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=7, frameon=False)
    for row, name in enumerate(controls):
        panel = fig.add_subplot(grid[row, 1])
        panel.plot(optimum["t"], optimum[name], color="0.35", ls="--", lw=1.0, label="optimum")
        panel.step(driven["t"], driven[f"sent_{name}"], where="post", color=PALETTE[row], lw=1.0, label="sent")
        units = unit(ocp.vehicle.roles, name)
        panel.set(ylabel=tex(name) + (f" ({units})" if units else ""))
        if row == len(controls) - 1:
            panel.set(xlabel="t (s)")
        panel.legend(loc="best", fontsize=7)
    fig.suptitle(_title(ocp, summary), fontsize=9)
    return fig


def _title(ocp: OCP, summary: Mapping) -> str:
    reached = "goal reached" if summary.get("reached_goal") else "goal NOT reached within the tolerance"
    err = summary.get("final_position_error")
    head = summary.get("final_heading_error")
    moving = summary.get("min_distance_moving")
    numbers = ", ".join(
        part
        for part in (
            f"final position error {err:.3g} m" if err is not None else "",
            f"heading error {head:.3g} rad" if head is not None else "",
            f"least distance to another vehicle {moving:.2f} m" if moving is not None else "",
        )
        if part
    )
    return f"{ocp.title or ocp.name}\n{reached}" + (f" ({numbers})" if numbers else "")


__all__ = ["closed_loop_figure", "errors_figure", "paths_figure"]


# --------------------------------------------------------------------------- final errors against the level

CONTROLLER_ORDER = ("open-loop", "tracking", "mpc")
ERROR_ROWS = (("position_error", "position", "final position error (m)"),
              ("heading_error", "angle", "final heading error (rad)"))  # fmt: skip


def _error_panel(ax: plt.Axes, rows: list[dict], key: str, tol_key: str, colors: Mapping[str, tuple]) -> None:
    """Markers at each level (offset per controller), the mean and a bar up to the worst run; no lines: the
    levels are separate experiments, not a continuum."""
    levels = sorted({r["level"] for r in rows if r["numbers"]})
    width = 0.6 / len(CONTROLLER_ORDER)
    for k, c in enumerate(CONTROLLER_ORDER):
        pts = sorted((r for r in rows if r["controller"] == c and r["numbers"]), key=lambda r: r["level"])
        if not pts:
            continue
        x = np.array([levels.index(r["level"]) for r in pts]) + (k - 1) * width
        mean = np.array([max(r["numbers"][f"{key}_mean"] or 0.0, 1e-9) for r in pts])
        worst = np.array([max(r["numbers"][f"{key}_worst"] or 0.0, 1e-9) for r in pts])
        ax.errorbar(x, mean, yerr=[0 * mean, worst - mean], fmt="o", ls="none", capsize=3, color=colors[c], label=c)
    tol = next((r["goal_tolerance"].get(tol_key) for r in rows if r["numbers"]), None)
    if tol:
        ax.axhline(tol, color="0.4", ls="--", lw=1, label="goal tolerance")
        ax.annotate(f"{tol:.2g}", (-0.58, tol), va="bottom", ha="left", fontsize=8, color="0.3")  # left of the data
    ax.set(yscale="log", xticks=range(len(levels)), xticklabels=[f"{lv:g}" for lv in levels],
           xlim=(-0.6, len(levels) - 0.4), xlabel="disturbance level (-)")  # fmt: skip


def errors_figure(rows: list[dict], colors: Mapping[str, tuple]) -> plt.Figure:
    """Final position error (top) and heading error (bottom) per disturbance level, one column per geometry,
    one marker per controller (mean, bar to the worst run), each tolerance dashed; one legend below.

    ``rows``: closed_loop_section's rows (keys geometry, level, controller, numbers, goal_tolerance).
    """
    from model.plotting.figures import FIGURE_WIDTH

    apply_style()
    names = list(dict.fromkeys(r["geometry"] for r in rows))
    shown = [g for g in names if len({r["level"] for r in rows if r["geometry"] == g}) > 1] or names
    fig, axes = plt.subplots(2, len(shown), figsize=(FIGURE_WIDTH, 5.0), squeeze=False, sharex="col",
                             layout="constrained")  # fmt: skip
    for j, g in enumerate(shown):
        mine = [r for r in rows if r["geometry"] == g]
        for i, (key, tol_key, ylabel) in enumerate(ERROR_ROWS):
            _error_panel(axes[i, j], mine, key, tol_key, colors)
            axes[i, j].set(ylabel=ylabel if j == 0 else None, title=g if i == 0 else None)
    handles = {h.get_label(): h for ax in axes.ravel() for h in ax.get_legend_handles_labels()[0]}
    fig.legend(handles=list(handles.values()), loc="outside lower center", ncols=4, frameon=False)
    return fig


# --------------------------------------------------------------------------- closed-loop paths on the scene


def _scene(ax: plt.Axes, ocp: OCP | None) -> None:
    """The geometry's obstacles or roundabout and its goal (a star); nothing without a scenario."""
    if ocp is None:
        return
    if ocp.road is not None:
        draw_roundabout(ax, ocp, label=False)
    draw_obstacles(ax, ocp.obstacles, label=False)
    px, py = ocp.vehicle.position
    ax.plot([ocp.final.get(px, np.nan)], [ocp.final.get(py, np.nan)], "k*", ms=9, label="goal")


def _paths_panel(ax: plt.Axes, panel: Mapping, colors: Mapping[str, tuple]) -> None:
    ocp = panel.get("ocp")
    _scene(ax, ocp)
    px, py = ocp.vehicle.position if ocp is not None else ("x", "y")  # names: the study's trucks without a scene
    optimum = panel.get("optimum")
    if optimum is not None:
        ax.plot(optimum[px], optimum[py], color="k", lw=2.4, alpha=0.35, label="optimum (reference)")
    for controller, run in panel["runs"].items():
        ax.plot(run[px], run[py], color=colors[controller], lw=1.3, label=controller)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x (m)", ylabel="y (m)", title=panel["title"])


def paths_figure(panels: list[Mapping], colors: Mapping[str, tuple]) -> plt.Figure:
    """The closed-loop paths on the scene, one panel per geometry, at the figure width; one legend below.

    ``panels``: per geometry a mapping with ``title``, ``ocp`` (the scenario's problem or None),
    ``optimum`` (columns x, y, or None) and ``runs`` (controller -> columns x, y).
    """
    from model.plotting.figures import FIGURE_WIDTH

    apply_style()
    fig, axes = plt.subplots(1, max(1, len(panels)), figsize=(FIGURE_WIDTH, 3.6), squeeze=False,
                             layout="constrained")  # fmt: skip
    for ax, panel in zip(axes[0], panels, strict=False):
        _paths_panel(ax, panel, colors)
    handles = {h.get_label(): h for ax in axes[0] for h in ax.get_legend_handles_labels()[0]}
    if handles:
        fig.legend(handles=list(handles.values()), loc="outside lower center", ncols=5, frameon=False)
    return fig
