"""Figures of the studies whose scripts draw inline today (studies_wheelbase.py, studies_time.py), drawn by the
paper's rules (model.plotting.rules): quantities with units, legends off the data, text >= 7 pt at print.

``wheelbase_figure`` plots the minimum time and the energy at fixed Tf against the wheelbase, both panels
relative to the same reference per sweep (its middle d and the value there), not each panel's own median.
``time_controls_figure`` draws each time-optimal solve's controls divided by their bounds, a panel per solve
titled by it, the y axis the quantity, one legend for all, chattering windows shaded.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Patch
from matplotlib.ticker import FormatStrFormatter, NullFormatter

from model.plotting.figures import FIGURE_WIDTH, PALETTE, apply_style, tex

if TYPE_CHECKING:
    import pandas as pd


def wheelbase_figure(frame: pd.DataFrame) -> plt.Figure:
    """Minimum time (left) and energy at fixed Tf (right) against the wheelbase d, one line per sweep, both
    relative to the same reference: the sweep's middle wheelbase d_ref (its median d over all its rows) and the
    value there; a sweep without a solved value at d_ref is left out of that panel.

    ``frame``: wheelbase.csv (sweep, d, kind "time"/"energy", ok, final_time, objective).
    """
    apply_style()
    fig, axes = plt.subplots(1, 2, figsize=(FIGURE_WIDTH, 3.0), sharex=True, layout="constrained")
    panels = ((axes[0], "time", "final_time", r"$T_{min}(d)\,/\,T_{min}(d_{ref})$ (-)"),
              (axes[1], "energy", "objective", r"$J(d)\,/\,J(d_{ref})$ at fixed $T_f$ (-)"))  # fmt: skip
    for k, (label, grp) in enumerate(frame.groupby("sweep", sort=False)):
        d_ref = float(np.median(np.unique(grp["d"])))
        for ax, kind, col, _ in panels:
            g = grp[(grp["kind"] == kind) & grp["ok"].astype(bool)].sort_values("d")
            ref = g.loc[np.isclose(g["d"], d_ref), col]
            if len(ref):
                ax.plot(g["d"] / d_ref, g[col] / float(ref.iloc[0]), "o-", ms=4, color=PALETTE[k],
                        label=f"{label} ($d_{{ref}}$ = {d_ref:g} m)")  # fmt: skip
    for ax, _, _, ylabel in panels:
        ax.axhline(1.0, color="0.6", lw=0.6)
        ax.set(xscale="log", xlabel=r"$d\,/\,d_{ref}$ (-)", ylabel=ylabel)
        ax.set_xticks([0.5, 0.8, 1.0, 1.25, 2.0])
        ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    handles = {h.get_label(): h for ax in axes for h in ax.get_legend_handles_labels()[0]}
    fig.legend(handles=list(handles.values()), loc="outside lower center", ncols=3, frameon=False)
    return fig


def time_controls_figure(
    runs: Sequence[tuple[str, pd.DataFrame, Mapping[str, tuple[float, float]], Mapping[str, list[dict]]]],
) -> plt.Figure:
    """Each time-optimal solve's controls divided by their upper bounds, a panel per solve, two columns.

    ``runs``: (name, trajectory with t and the controls; bounds control -> (lo, hi), the speed first, then the
    steering rate; chattering windows control -> list of {"t0", "t1"}) per solve. A control is not drawn
    inside its chattering windows, which are shaded.
    """
    apply_style()
    rows = math.ceil(len(runs) / 2)
    fig, axes = plt.subplots(rows, 2, figsize=(FIGURE_WIDTH, 1.35 * rows + 0.7), squeeze=False, layout="constrained")
    for ax, (name, tr, bounds, windows) in zip(axes.ravel(), runs, strict=False):
        _controls_panel(ax, tr, bounds, windows)
        (speed, (_, u1)), (turning, (_, u2)) = list(bounds.items())[:2]
        ax.set_title(f"{name} ({tex(speed)} bound {u1:g} m/s, {tex(turning)} {u2:g} rad/s)", fontsize=8, loc="left")
    for ax in axes.ravel()[len(runs) :]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("$u$ / bound (-)")
    for ax in axes.ravel():
        if ax.get_visible():
            ax.set_xlabel("t (s)")
    speed, turning = list(runs[0][2])[:2] if runs else ("", "")
    handles = [plt.Line2D([], [], color=PALETTE[0], label=f"speed {tex(speed)} / its bound"),
               plt.Line2D([], [], color=PALETTE[1], label=f"steering rate {tex(turning)} / its bound"),
               Patch(color="0.85", label="chattering window (not drawn)")]  # fmt: skip
    fig.legend(handles=handles, loc="outside lower center", ncols=3, frameon=False)
    return fig


def _controls_panel(ax: plt.Axes, tr: pd.DataFrame, bounds: Mapping, windows: Mapping) -> None:
    """The first two controls of ``bounds`` over their upper bounds, blank inside their chattering windows."""
    t = tr["t"].to_numpy()
    for c, color in zip(list(bounds)[:2], PALETTE, strict=False):
        mask = np.zeros(len(t), bool)
        for w in windows.get(c, ()):
            mask |= (t >= w["t0"]) & (t <= w["t1"])
            ax.axvspan(w["t0"], w["t1"], color="0.85", lw=0)
        ax.plot(t, np.where(mask, np.nan, tr[c].to_numpy() / bounds[c][1]), color=color)
    ax.set(ylim=(-1.15, 1.15), yticks=(-1, 0, 1))


def plant_gap_figure(groups: Sequence[tuple[str, str, Sequence[Mapping]]]) -> plt.Figure:
    """The plant study: the largest lateral deviation from the plan (left; the dynamic plant solid, the kinematic
    plant dotted) and the clearance lost (right) against the plan's largest lateral acceleration, one line per
    manoeuvre; one legend below.

    ``groups``: (label, marker, records in rising level) per manoeuvre; the records are
    model.studies.plant_gap's (RECORD_KEYS), only the validated ones with a clearance lost are drawn.
    """
    apply_style()
    fig, axes = plt.subplots(1, 2, figsize=(FIGURE_WIDTH, 3.2), layout="constrained")
    for k, (label, marker, records) in enumerate(groups):
        done = [r for r in records if r["plan_valid"] and r["clearance_lost_m"] is not None]
        x = [r["plan_max_lateral_acceleration_mps2"] for r in done]
        style = {"marker": marker, "color": PALETTE[k % len(PALETTE)]}
        axes[0].plot(x, [r["plant_max_lateral_deviation_m"] for r in done], label=label, **style)
        axes[0].plot(x, [r["kinematic_max_lateral_deviation_m"] for r in done], ls=":", mfc="none", **style)
        axes[1].plot(x, [r["clearance_lost_m"] for r in done], **style)
    axes[0].set_ylabel("lateral deviation from the plan (m)")
    axes[1].set_ylabel("clearance lost (m)")
    for ax in axes:
        ax.set(xlabel="plan's largest lateral accel. (m/s²)", ylim=(0.0, None))
    handles, names = axes[0].get_legend_handles_labels()
    handles.append(plt.Line2D([], [], color="0.4", ls=":", marker="o", mfc="none"))
    names.append("the same plan on the kinematic plant")
    fig.legend(handles, names, loc="outside lower center", ncols=2, frameon=False)
    return fig


# --------------------------------------------------------------------------- the road energy-time trade-off


def path_spread(trajectories: Mapping[str, Mapping], position: tuple[str, str]) -> float | None:
    """How far the rear-axle paths lie from the time-optimal one (key ``time``): the largest Hausdorff distance, m.

    ``position``: the vehicle's position columns (``vehicle.position``).
    """
    import shapely

    px, py = position
    lines = {k: shapely.LineString(np.column_stack([c[px], c[py]])) for k, c in trajectories.items()}
    ref = lines.pop("time", None)
    return max((ref.hausdorff_distance(line) for line in lines.values()), default=None) if ref else None


def _tradeoff_colors(keys: Sequence[str]) -> dict:
    cmap = plt.get_cmap("viridis")
    return {key: "C3" if key == "time" else cmap(k / max(1, len(keys) - 1)) for k, key in enumerate(keys)}


def _energy_time_panel(ax: plt.Axes, rows: Sequence[Mapping]) -> None:
    """J against the final time: the energy-optimal points, and the time-optimal controls' J."""
    from model.plotting.figures import ENERGY_UNIT

    tmin = next(r for r in rows if r["objective"] == "time")
    en = [r for r in rows if r["valid"] and r["objective"] == "energy"]
    ax.plot([r["final_time"] for r in en], [r["energy"] for r in en], "o-", label="energy-optimal J(Tf)")
    if tmin["valid"]:
        ax.plot(tmin["final_time"], tmin["energy"], "s", color="C3", label="time-optimal (J of its controls)")
        ax.axvline(tmin["final_time"], color="C3", ls=":", lw=1)
    ax.set(xlabel="final time Tf (s)", ylabel=f"J = ½∫(u1² + u2²) dt\n({ENERGY_UNIT})",
           title="(a) energy against time\n(kinematic model, no limits)")  # fmt: skip


def _tradeoff_paths_panel(ax: plt.Axes, ocp, trajectories: Mapping[str, Mapping]) -> None:
    """The rear-axle paths on the roundabout to scale, the fastest and slowest swept areas shaded."""
    from model.analysis.bodies import swept_polygons
    from model.plotting.roads import draw_roundabout, draw_scale_bar, geometry_patch

    draw_roundabout(ax, ocp, label=False)
    px, py = ocp.vehicle.position
    keys, color = list(trajectories), _tradeoff_colors(list(trajectories))
    for key in keys:
        cols = trajectories[key]
        if key in (keys[0], keys[-1]):
            for poly in swept_polygons(ocp, cols).values():
                ax.add_patch(geometry_patch(poly, facecolor=color[key], alpha=0.2, lw=0, zorder=2))
        ax.plot(cols[px], cols[py], color=color[key], lw=1.2, label=key, zorder=4)
    rb = ocp.road.roundabout
    lim = rb.outer_radius + 2 * max(g.lane_width for g in rb.legs)
    allx = np.concatenate([c[px] for c in trajectories.values()])
    ally = np.concatenate([c[py] for c in trajectories.values()])
    ax.set_xlim(min(allx.min(), -lim) - 1, max(allx.max(), lim) + 1)
    ax.set_ylim(min(ally.min(), -lim) - 1, max(ally.max(), lim) + 1)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    draw_scale_bar(ax)
    spread = path_spread(trajectories, (px, py))
    same = f"\n(within {spread:.2g} m of the time-optimal)" if spread is not None else ""
    ax.set_title(f"(b) rear-axle paths to scale{same}")


def _tradeoff_controls(axes: Sequence[plt.Axes], trajectories: Mapping[str, Mapping], roles) -> None:
    """Speed and steering rate against the normalised time t / Tf: where the solves differ."""
    color = _tradeoff_colors(list(trajectories))
    for key, cols in trajectories.items():
        tau = np.asarray(cols["t"]) / cols["t"][-1]
        axes[0].plot(tau, cols[roles.speed], color=color[key], lw=1.2, label=key)
        axes[1].plot(tau, cols[roles.steering_rate], color=color[key], lw=1.2, label=key)
    axes[0].set(xlabel="t / Tf (-)", ylabel="speed u1 (m/s)", title="(c) speed: what differs")
    axes[1].set(xlabel="t / Tf (-)", ylabel="steering rate u2 (rad/s)", title="(d) steering rate")


def tradeoff_figure(ocp, rows: Sequence[Mapping], trajectories: Mapping[str, Mapping]) -> plt.Figure:
    """The road study's energy-time trade-off at the figure width: (a) J against Tf, (b) the rear-axle paths on
    the roundabout (fastest and slowest swept areas shaded), (c) speed and (d) steering rate against t / Tf; one
    legend below (the solves by colour, the same in (b)-(d)).

    ``rows``: the solves' records (objective, valid, final_time, energy); ``trajectories``: the valid solves'
    columns (t, x, y, u1, u2 and the states the bodies need) by label, ``time`` the time-optimal one.
    """
    apply_style()
    fig, axes = plt.subplots(2, 2, figsize=(FIGURE_WIDTH, 6.0), layout="constrained")
    _energy_time_panel(axes[0, 0], rows)
    if trajectories:
        _tradeoff_paths_panel(axes[0, 1], ocp, trajectories)
    _tradeoff_controls(axes[1], trajectories, ocp.vehicle.roles)
    handles = {h.get_label(): h for ax in (axes[0, 0], axes[1, 0]) for h in ax.get_legend_handles_labels()[0]}
    fig.legend(handles=list(handles.values()), loc="outside lower center", ncols=2, frameon=False)
    return fig


# --------------------------------------------------------------------------- the EU turning circle

TURNING_COLORS = {"vehicle": "#1f77b4", "trailer": "#ff7f0e"}


def _annulus(ax: plt.Axes, outer: float, inner: float) -> None:
    """The directive's annulus between ``inner`` and ``outer`` (m), each circle labelled with its radius."""
    t = np.linspace(0, 2 * math.pi, 721)
    ax.fill(outer * np.cos(t), outer * np.sin(t), color="#e8e8e8", lw=0)
    ax.fill(inner * np.cos(t), inner * np.sin(t), color="white", lw=0)
    for r in (outer, inner):
        ax.plot(r * np.cos(t), r * np.sin(t), color="k", lw=1.0)
        ax.annotate(f"{r:.2f} m", (r * math.cos(2.4), r * math.sin(2.4)), xytext=(4, 4), textcoords="offset points",
                    bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 0.5}, zorder=6)  # fmt: skip


def _swept_turns(ax: plt.Axes, all_corners: Mapping[str, np.ndarray], per_turn: int) -> None:
    """Each body's swept area per turn (the second darker) and its outline at three early nodes."""
    import shapely

    from model.plotting.roads import geometry_patch

    for k, (alpha, tag) in enumerate(((0.15, "turn 1 (from straight)"), (0.35, "turn 2"))):
        pick = slice(k * per_turn, (k + 1) * per_turn + 1)
        for body, c in all_corners.items():
            poly = shapely.union_all(shapely.polygons(c[pick])).buffer(0)
            ax.add_patch(geometry_patch(poly, facecolor=TURNING_COLORS[body], alpha=alpha, lw=0,
                                        label=f"{body} swept, {tag}"))  # fmt: skip
    for idx in (0, per_turn // 4, per_turn // 2):
        for body, c in all_corners.items():
            ax.add_patch(plt.Polygon(c[idx], closed=True, fill=False, ec=TURNING_COLORS[body], lw=0.9))


def turning_figure(name: str, result: Mapping, all_corners: Mapping[str, np.ndarray], outer: float,
                   inner: float, least: np.ndarray) -> plt.Figure:  # fmt: skip
    """The EU turning circle at the figure width: (a) two full turns' swept areas in the annulus between
    ``inner`` and ``outer`` (m), (b) the inner swept radius against the heading turned; one legend below.

    ``result``: model.studies.roads.eu_turning_circle's (phi_deg, steady inner, transient run and turns);
    ``all_corners``: body -> corners over the run (model.studies.roads.corners); ``least``: the trailer's (else the
    vehicle's) least distance from the centre at each instant (model.studies.roads.rectangle_distance).
    """
    apply_style()
    run = result["transient"]["run"]
    per_turn = (len(run["t"]) - 1) // len(result["transient"]["turns"])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(FIGURE_WIDTH, 3.6), width_ratios=(1.1, 1), layout="constrained")
    _annulus(ax, outer, inner)
    _swept_turns(ax, all_corners, per_turn)
    title = f"(a) two full turns at {result['phi_deg']:.2f}° steering"
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)", title=title)
    theta = np.degrees(run["theta"] - run["theta"][0])  # names: eu_turning_circle's run (the tractor's heading)
    ax2.plot(theta, least, color=TURNING_COLORS["trailer"], label="inner swept radius of the trailer (integrated)")
    ax2.axhline(result["steady"]["inner"], color="k", ls="--", lw=0.8,
                label=f"steady state {result['steady']['inner']:.3f} m")  # fmt: skip
    ax2.axhline(inner, color="r", lw=0.8, label=f"{inner:.2f} m (96/53/EC)")
    top = max(inner + 1.0, float(np.percentile(least, 20)))
    ax2.set(xlabel="heading turned by the tractor (deg)", ylabel="least distance from the centre (m)",
            ylim=(inner - 0.2, top), title="(b) inner swept radius")  # fmt: skip
    handles = [h for a in (ax, ax2) for h in a.get_legend_handles_labels()[0]]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, frameon=False)
    fig.suptitle(name)
    return fig


# --------------------------------------------------------------------------- traffic: waits and capacities


def _waits_panel(ax: plt.Axes, cars: Mapping, measures: Mapping, styles: Mapping, vc: np.ndarray,
                 adams_delay: Callable[[float, float], float]) -> None:  # fmt: skip
    """Measured waits at the line against Adams' delay with each group's critical gap."""
    rows, tc = cars["cells"], cars["critical_gap"]
    ax.plot([r["vc_pcph"] for r in rows], [r["line_wait"] for r in rows], "o", color="0.2", ms=5,
            label="cars: measured (per rate and leg)")  # fmt: skip
    for (vehicle, driver), g in measures.items():
        if g["critical_gap"] is not None:
            ax.plot(vc, [adams_delay(v / 3600, g["critical_gap"]) for v in vc], lw=1.0, ls="--",
                    color=styles.get(driver, {}).get("color", "0.5"),
                    label=f"{vehicle} ({driver}): Adams, $t_c$ = {g['critical_gap']:.2f} s")  # fmt: skip
    if tc is not None:
        ax.plot(
            vc, [adams_delay(v / 3600, tc) for v in vc], color="0.2", lw=1.2, label=f"cars: Adams, $t_c$ = {tc:.2f} s"
        )
    for (vehicle, driver), g in measures.items():
        style = styles.get(driver, {"color": "0.5", "marker": "x"})  # names: matplotlib's x marker
        ax.plot([r["vc_pcph"] for r in g["cells"]], [r["line_wait"] for r in g["cells"]], ls="none", ms=6,
                label=f"{vehicle} ({driver}): measured", mfc="none" if vehicle != "truck" else style["color"],
                **style)  # fmt: skip
    ax.set(xlabel="conflicting flow $v_c$ at the entry (pc/h, measured)", ylabel="wait at the line (s)",
           title="(a) waits against Adams' delay")  # fmt: skip


def _capacity_panel(ax: plt.Axes, cars: Mapping, vc: np.ndarray, formulas: Mapping) -> None:
    """The HCM's entry capacity and Siegloch's with the cars' measured gaps."""
    hcm_capacity, gap_capacity = formulas["hcm_capacity"], formulas["gap_capacity"]
    ax.plot(vc, [hcm_capacity(v) for v in vc], color="0.3", lw=1.5, label=formulas["hcm_label"])
    tc, tf = cars["critical_gap"], cars["follow_up"]
    if tc is not None and tf:
        ax.plot(vc, [3600 * gap_capacity(v / 3600, tc, tf) for v in vc], color="#1f6fb4", lw=1.2,
                label=f"Siegloch, cars' $t_c$ = {tc:.2f} s, $t_f$ = {tf:.2f} s")  # fmt: skip
    ax.set(xlabel="conflicting flow $v_c$ (pc/h)", ylabel="entry capacity (pc/h)", ylim=(0, None),
           title="(b) entry capacity")  # fmt: skip


def comparison_figure(cars: Mapping, measures: Mapping[tuple[str, str], Mapping], styles: Mapping,
                      formulas: Mapping) -> plt.Figure:  # fmt: skip
    """The traffic study at the figure width: (a) measured waits at the line against Adams' delay, (b) Siegloch's
    capacity with the cars' measured gaps against the HCM's; each panel's legend to its right, off the data.

    ``cars``: model.traffic.study.others_measures (critical_gap, follow_up, cells with vc_pcph and line_wait);
    ``measures``: (vehicle, driver) -> the group's measures (critical_gap, cells); ``styles``: driver -> colour
    and marker; ``formulas``: the traffic layer's ``adams_delay(q, t_c)``, ``gap_capacity(q, t_c, t_f)``,
    ``hcm_capacity(v_c)`` and ``hcm_label`` (model.traffic.gaps), passed in: plotting sits below traffic.
    """
    apply_style()
    fig, (left, right) = plt.subplots(2, 1, figsize=(FIGURE_WIDTH, 5.6), layout="constrained")
    vmax = max([r["vc_pcph"] for r in cars["cells"]] + [r["vc_pcph"] for g in measures.values() for r in g["cells"]]
               + [100.0])  # fmt: skip
    vc = np.linspace(0, 1.1 * vmax, 200)
    _waits_panel(left, cars, measures, styles, vc, formulas["adams_delay"])
    _capacity_panel(right, cars, vc, formulas)
    for ax in (left, right):
        ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5), frameon=False)
    return fig
