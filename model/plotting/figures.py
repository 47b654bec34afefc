"""The pipeline's one figure style and its plots (matplotlib): every figure is made here."""

from __future__ import annotations

import functools
import re
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle as Disc  # noqa: E402
from matplotlib.patches import Polygon as PolygonPatch  # noqa: E402

if TYPE_CHECKING:
    import pandas as pd

    from model.plotting.results import Result
    from model.vehicles import Roles

STYLE = {
    "figure.dpi": 110,
    "savefig.dpi": 150,
    "savefig.bbox": "tight",
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "lines.linewidth": 1.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
}
PALETTE = plt.get_cmap("tab10").colors
LINESTYLES = ("-", "--", "-.", ":")
ROLE_UNITS = {"heading": "rad", "steering": "rad", "speed": "m/s", "steering_rate": "rad/s", "turn_rate": "rad/s",
              "acceleration": "m/s²", "jerk": "m/s³"}  # fmt: skip
# The energy J = 1/2 int (u1^2 + u2^2) dt adds an m^2/s term (u1 in m/s) and a rad^2/s term (u2 in rad/s): the
# paper adds them as numbers in SI units (the radian counted as 1), so every J is written with this unit.
ENERGY_UNIT = "m²/s + rad²/s"
# The PDF prints a figure 0.88 of the 16.4 cm text width (5.68 in; model.plotting.rules): drawn at most
# this wide, the style's smallest text (8 pt) prints at 7 pt or more.
FIGURE_WIDTH = 6.0  # in


def tex(name: str) -> str:
    """A state or control name as TeX math: ``u1`` -> ``$u_1$``, ``theta`` -> ``$\\theta$`` (SymPy's LaTeX)."""
    import sympy as sp  # lazy: sympy (and model.vehicles, which imports it) cost 0.5 s at import

    from model.vehicles import sym

    return "$" + re.sub(r"_\{(\w)\}", r"_\1", sp.latex(sym(name))) + "$"


def unit(roles: Roles, name: str) -> str:
    """The unit of the state or control ``name`` by its role (``"m"``, ``"rad"``, ``"m/s"``, ...); "" without one."""
    if name in roles.position:
        return "m"
    if name in roles.trailers:
        return "rad"
    return next((u for role, u in ROLE_UNITS.items() if getattr(roles, role) == name), "")


def apply_style() -> None:
    plt.rcParams.update(STYLE)


def color_for(name: str, order: Sequence[str]) -> tuple:
    """One colour per scenario, the same in every figure (its place in ``order``)."""
    return PALETTE[list(order).index(name) % len(PALETTE)] if name in order else PALETTE[-1]


def save(fig: plt.Figure, stem: str | Path, formats: Sequence[str] = ("pdf", "png")) -> list[Path]:
    """Write ``stem.<format>`` for every format and close the figure."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path in paths:
        fig.savefig(path, metadata={"CreationDate": None} if path.suffix == ".pdf" else None)
    plt.close(fig)
    return paths


def cumulative_energy(frame: pd.DataFrame, controls: Sequence[str]) -> np.ndarray:
    """E(t) = 1/2 integral of (u1^2 + u2^2) (the sum over ``controls``), trapezoid rule on the nodes
    (the paper's eq. 32; ``model.problem.costs.Energy.cumulative``, unit weights as summary.json's energy)."""
    from model.problem.costs import Energy  # lazy, as the module's other model imports

    return Energy().cumulative(frame, controls)


def phase_rate(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Hypothesis 1: psi = atan2(u2, u1) and psi' = (u1 u2' - u2 u1') / (u1^2 + u2^2), by finite differences."""
    t, u1, u2 = (frame[c].to_numpy(dtype=float) for c in ("t", "u1", "u2"))  # names: the paper's truck (its Fig. 8)
    du1, du2 = np.gradient(u1, t), np.gradient(u2, t)
    norm = np.maximum(u1**2 + u2**2, 1e-12)
    return np.arctan2(u2, u1), (u1 * du2 - u2 * du1) / norm


def legend_above(ax: plt.Axes, title: str, ncols: int = 3, width: int = 30, **kw) -> None:
    """The panel's title (wrapped at ``width`` characters) and its legend above the axes, off the data (the
    panel has no axes title). Under constrained layout a legend wider than its axes narrows the axes."""
    handles, labels = ax.get_legend_handles_labels()
    handles, labels = kw.pop("handles", handles), kw.pop("labels", labels)
    style = {"handlelength": 1.8, "columnspacing": 1.0, "borderaxespad": 0.2, **kw}
    legend = ax.legend(handles, labels, title=textwrap.fill(title, width), loc="lower left", bbox_to_anchor=(0.0, 1.0),
                       ncols=ncols, frameon=False, alignment="left", **style)  # fmt: skip
    legend.get_title().set_fontsize(plt.rcParams["axes.titlesize"])


def _bounds(ax: plt.Axes, bounds: dict, name: str, color) -> None:
    for value in bounds.get(name, ()):
        ax.axhline(value, color=color, linestyle="--", linewidth=0.9, alpha=0.8)


def _pose_arrow(ax: plt.Axes, pose: dict, roles: Roles, color, label: str, length: float) -> None:
    """A pose: a dot at the position and, if the heading is fixed, an arrow along it."""
    x, y = pose[roles.x], pose[roles.y]
    if roles.heading in pose:
        dx, dy = length * np.cos(pose[roles.heading]), length * np.sin(pose[roles.heading])
        ax.annotate("", xy=(x + dx, y + dy), xytext=(x, y),
                    arrowprops={"arrowstyle": "-|>", "color": color, "lw": 2.2, "mutation_scale": 18})
        ax.plot([x + dx], [y + dy], alpha=0.0)  # keeps the arrow's tip inside the axes
        label = f"{label} pose"
    ax.plot([x], [y], "o", color=color, markersize=6, label=label)


def direction_arrow(ax: plt.Axes, x: np.ndarray, y: np.ndarray, color, where: float = 0.5) -> None:
    """An arrowhead on the path (x, y) at the fraction ``where`` of its length: the direction of travel."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    if len(x) < 3 or arc[-1] <= 0:
        return
    k = int(np.clip(np.searchsorted(arc, where * arc[-1]), 1, len(x) - 2))
    ax.annotate("", xy=(x[k + 1], y[k + 1]), xytext=(x[k - 1], y[k - 1]),
                arrowprops={"arrowstyle": "-|>", "color": color, "lw": 0, "mutation_scale": 14})  # fmt: skip


def mark_reversing(ax: plt.Axes, x, y, speed, label: bool = True, name: str = "speed") -> None:
    """The nodes where the speed is negative (the vehicle reverses), black crosses; nothing if it never does."""
    back = np.asarray(speed, float) < 0
    cross = "x"  # names: matplotlib's cross marker, not a state
    if back.any():
        ax.plot(np.asarray(x)[back], np.asarray(y)[back], cross, color="black", ms=3.5, mew=0.8, zorder=6,
                label=f"reversing ({name} < 0)" if label else None)  # fmt: skip


def draw_obstacles(ax: plt.Axes, obstacles: Sequence, label: bool = True) -> None:
    """Each obstacle as a grey disc and its safety circle (radius + safety) dashed."""
    for i, ob in enumerate(obstacles):
        first = label and i == 0
        ax.add_patch(Disc(ob.center, ob.radius, facecolor="0.75", edgecolor="0.4",
                          label="obstacle" if first else None))
        ax.add_patch(Disc(ob.center, ob.keep_out, fill=False, edgecolor="0.3", linestyle="--",
                          label="safety distance" if first else None))


MOVING_COLOR = "#6a3d9a"  # the other vehicles (moving obstacles)


def draw_moving_obstacles(ax: plt.Axes, ocp, times: Sequence[float], final_time: float, label: bool = True) -> None:
    """Each moving obstacle to scale: its rectangle at ``times`` (fainter the earlier, each with its time)
    and the path of its centre over [0, ``final_time``] dotted."""
    times = np.asarray(times, float)
    span = np.linspace(0.0, final_time, 200)
    for i, ob in enumerate(ocp.moving_obstacles):
        first = label and i == 0
        ax.plot(*ob.path(span).T, color=MOVING_COLOR, lw=0.8, ls=":", zorder=3,
                label="other vehicle's path" if first else None)  # fmt: skip
        for k, t in enumerate(times):
            alpha = 0.15 + 0.45 * (k + 1) / len(times)
            ax.add_patch(PolygonPatch(ob.outline(t), closed=True, fc=(*matplotlib.colors.to_rgb(MOVING_COLOR), alpha),
                                      ec=MOVING_COLOR, lw=0.7, zorder=5,
                                      label="other vehicle" if first and k == 0 else None))  # fmt: skip
            x, y = ob.path(t)
            ax.annotate(f"{t:.1f} s", (x, y), fontsize=7.5, color=MOVING_COLOR, ha="center", va="center", zorder=9)


def controls_panel(ax: plt.Axes, frame: pd.DataFrame, bounds: dict, roles: Roles) -> None:
    """The speed (with longitudinal dynamics also the acceleration) and the steering (or turn) rate over time,
    bounds dashed."""
    names = ((roles.speed, PALETTE[0]), (roles.acceleration, PALETTE[1]), (roles.turning, PALETTE[3]))
    for name, color in ((n, c) for n, c in names if n is not None):
        ax.plot(frame["t"], frame[name], color=color, label=f"{tex(name)} ({unit(roles, name)})")
        _bounds(ax, bounds, name, color)
    title = "(a) speed, acceleration, steering rate" if roles.acceleration else "(a) controls"
    ylabel = "value (SI units)" if roles.acceleration else "control (SI units)"
    ax.set(xlabel="t (s)", ylabel=ylabel)
    legend_above(ax, title + " (bounds dashed)")


def states_panel(ax: plt.Axes, frame: pd.DataFrame, roles: Roles) -> None:
    """The position over time."""
    for name, color in ((roles.x, PALETTE[0]), (roles.y, PALETTE[2])):
        ax.plot(frame["t"], frame[name], color=color, label=tex(name))
    ax.set(xlabel="t (s)", ylabel="position (m)")
    legend_above(ax, "(b) states")


def path_panel(ax: plt.Axes, frame: pd.DataFrame, ocp, color=PALETTE[0], label: str = "path") -> None:
    """The path in the plane with the obstacle, its safety circle, and start and goal poses.

    Moving obstacles are drawn at five node times, where the path has a dot, with their paths."""
    draw_obstacles(ax, ocp.obstacles)
    r = ocp.vehicle.roles
    if ocp.moving_obstacles:
        t = np.asarray(frame["t"], float)
        marks = np.linspace(0, len(t) - 1, 5).round().astype(int)
        draw_moving_obstacles(ax, ocp, t[marks], float(t[-1]))
        ax.plot(np.asarray(frame[r.x])[marks], np.asarray(frame[r.y])[marks], "o", color=color, ms=3)
    ax.plot(frame[r.x], frame[r.y], color=color, label=label)
    direction_arrow(ax, frame[r.x], frame[r.y], color)
    mark_reversing(ax, frame[r.x], frame[r.y], frame[r.speed], name=tex(r.speed))
    span = max(np.ptp(frame[r.x]), np.ptp(frame[r.y]), 0.1)
    _pose_arrow(ax, ocp.initial, r, "tab:green", "start", 0.18 * span)
    if set(r.position) <= set(ocp.final):
        _pose_arrow(ax, ocp.final, r, "tab:red", "goal", 0.18 * span)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x (m)", ylabel="y (m)")
    legend_above(ax, "(c) path (arrowhead: direction of travel)", ncols=2)


def energy_panel(ax: plt.Axes, frame: pd.DataFrame, controls: Sequence[str]) -> None:
    """The cumulative energy of ``controls`` over time."""
    ax.plot(frame["t"], cumulative_energy(frame, controls), color=PALETTE[4])
    ax.set(xlabel="t (s)", ylabel=f"energy $E(t)$ ({ENERGY_UNIT})")
    ax.plot([], [], " ", label=r"$E(t)=\frac{1}{2}\int_0^t (u_1^2+u_2^2)\,ds$")
    legend_above(ax, "(d) cumulative energy", ncols=1, handlelength=0)


def failed_figure(result: Result, title: str) -> plt.Figure:
    """A placeholder that says the solve failed: a failed solve is never drawn as a solution."""
    fig, ax = plt.subplots(figsize=(7.5, 2.2))
    ax.axis("off")
    reason = result.summary.get("failure") or result.summary.get("solver_message") or ""
    ax.text(0.5, 0.6, f"{title}\nSOLVE FAILED ({result.status_text})", ha="center", va="center",
            fontsize=12, color="tab:red", weight="bold")
    ax.text(0.5, 0.15, reason[:120], ha="center", va="center", fontsize=8, wrap=True)
    return fig


def _solved_grid(draw):
    """``draw(axes, frame, result, ocp) -> title`` on a 2 x 2 figure of a solved result; a
    failed solve gets the placeholder instead: it is never drawn as a solution."""

    @functools.wraps(draw)
    def figure(result: Result, ocp) -> plt.Figure:
        if not result.solved:
            return failed_figure(result, ocp.title or result.name)
        fig, axes = plt.subplots(2, 2, figsize=(FIGURE_WIDTH, 5.6), layout="constrained")
        fig.suptitle(textwrap.fill(draw(axes, result.trajectory, result, ocp), 80))
        return fig

    return figure


@_solved_grid
def solution_figure(axes, frame: pd.DataFrame, result: Result, ocp) -> str:
    """The paper's Figures 4-7: (a) controls, (b) states, (c) path, (d) cumulative energy."""
    roles = ocp.vehicle.roles
    controls_panel(axes[0, 0], frame, ocp.bounds, roles)
    states_panel(axes[0, 1], frame, roles)
    path_panel(axes[1, 0], frame, ocp)
    energy_panel(axes[1, 1], frame, ocp.vehicle.controls)
    return (f"{ocp.title or result.name}  (Tf = {result.summary['final_time']:.4g} s, "
            f"E = {result.summary['energy']:.4g} ({ENERGY_UNIT}))")


@_solved_grid
def costate_figure(axes, frame: pd.DataFrame, result: Result, ocp) -> str:
    """Costate estimates, switching functions beside the controls (with bounds), and H and mu."""
    ax = axes[0, 0]
    for i, name in enumerate(c for c in frame.columns if c.startswith("p_")):
        ax.plot(frame["t"], frame[name], color=PALETTE[i], label=f"$p_{{{tex(name[2:])[1:-1]}}}$")
    ax.set(xlabel="t (s)", ylabel="costate estimate (SI units)")
    legend_above(ax, "(a) costates (from the NLP multipliers)", ncols=4)
    v = ocp.vehicle
    for ax, name, tag in ((axes[0, 1], v.roles.speed, "b"), (axes[1, 0], v.roles.turning, "c")):
        psi, k, color = f"psi_{name}", v.controls.index(name) + 1, PALETTE[0 if name == v.roles.speed else 3]
        ax.plot(frame["t"], frame[psi], color="0.6", linewidth=4.0, alpha=0.7,
                label=rf"$\psi_{{{k}}}$ (switching function)")
        ax.plot(frame["t"], frame[name], color=color, linewidth=1.4, label=f"{tex(name)} ({unit(v.roles, name)})")
        _bounds(ax, ocp.bounds, name, color)
        ax.set(xlabel="t (s)", ylabel=f"{tex(name)} ({unit(v.roles, name)}), " + rf"$\psi_{{{k}}}$")
        legend_above(ax, f"({tag}) {tex(name)} and its switching function (bounds dashed)", ncols=1)
    hamiltonian_panel(axes[1, 1], frame)
    return f"{ocp.title or result.name}: Pontryagin quantities"


def hamiltonian_panel(ax: plt.Axes, frame: pd.DataFrame) -> None:
    ax.plot(frame["t"], frame["H"], color=PALETTE[4], label="$H$")
    ax.set(xlabel="t (s)", ylabel="Hamiltonian $H$")
    title = "(d) Hamiltonian and obstacle multiplier"
    if "mu" in frame:
        twin = ax.twinx()
        twin.plot(frame["t"], frame["mu"], color=PALETTE[1], linestyle=":", label=r"$\mu$")
        twin.set_ylabel(r"obstacle multiplier $\mu$")
        twin.grid(False)
        lines = ax.get_lines() + twin.get_lines()
        legend_above(ax, title, ncols=2, handles=lines, labels=[ln.get_label() for ln in lines])
    else:
        legend_above(ax, title, ncols=2)


def phase_rate_figure(results: Sequence[Result], order: Sequence[str]) -> plt.Figure:
    """The paper's Figure 8: psi = atan2(u2, u1) and its rate for each solved scenario."""
    fig, axes = plt.subplots(2, 1, figsize=(FIGURE_WIDTH, 5.2), sharex=True, layout="constrained")
    for r in results:
        if not r.solved:
            axes[0].plot([], [], " ", label=f"{r.name}: {r.status_text}, not plotted")
            continue
        psi, rate = phase_rate(r.trajectory)
        color = color_for(r.name, order)
        axes[0].plot(r.trajectory["t"], psi, color=color, label=r.name)
        axes[1].plot(r.trajectory["t"], rate, color=color, label=r.name)
    axes[0].set(ylabel=r"$\psi=\mathrm{atan2}(u_2,u_1)$ (rad)")
    axes[1].set(xlabel="t (s)", ylabel=r"$\dot\psi$ (rad/s, symlog)",
                title=r"(b) phase rate $\dot\psi=(u_1\dot u_2-u_2\dot u_1)/(u_1^2+u_2^2)$ (finite differences)")
    axes[1].set_yscale("symlog", linthresh=1.0)
    legend_above(axes[0], "(a) phase of the control vector", ncols=5, width=80)
    fig.suptitle(r"Hypothesis 1: singular arcs have $\dot\psi = 0$")
    return fig


def _shared_obstacles(ax: plt.Axes, ocps: Sequence) -> None:
    drawn: set = set()
    for ocp in ocps:
        for ob in ocp.obstacles:
            key = (tuple(ob.center), ob.radius, ob.safety)
            if key not in drawn:
                draw_obstacles(ax, [ob], label=not drawn)
                drawn.add(key)


def _start_goal(ax: plt.Axes, ocps: Sequence) -> None:
    """Each distinct start and goal pose once: green and red, an arrow along a fixed heading."""
    span = max(max(abs(o.initial[o.vehicle.roles.x] - o.final.get(o.vehicle.roles.x, 0.0)) for o in ocps), 0.1)
    seen: set = set()
    for ocp in ocps:
        r = ocp.vehicle.roles
        for pose, color, name in ((ocp.initial, "tab:green", "start"), (ocp.final, "tab:red", "goal")):
            key = (name, *(round(float(pose.get(k, np.nan)), 6) for k in (r.x, r.y, r.heading)))
            if set(r.position) <= set(pose) and key not in seen:
                _pose_arrow(ax, pose, r, color, name if not any(k[0] == name for k in seen) else "_", 0.12 * span)
                seen.add(key)


def paths_figure(results: Sequence[Result], ocps: Sequence, order: Sequence[str]) -> plt.Figure:
    """The paper's Figure 9: several scenarios' paths in one plane, each with its direction of travel,
    the start and goal poses, and its reversing nodes."""
    fig, ax = plt.subplots(figsize=(FIGURE_WIDTH, 5.0), layout="constrained")
    _shared_obstacles(ax, ocps)
    for k, (r, ocp) in enumerate(zip(results, ocps, strict=True)):
        if not r.solved:
            ax.plot([], [], " ", label=f"{r.name}: {r.status_text}, not plotted")
            continue
        style, color = LINESTYLES[k % len(LINESTYLES)], color_for(r.name, order)
        px, py = ocp.vehicle.position
        x, y = r.trajectory[px].to_numpy(), r.trajectory[py].to_numpy()
        ax.plot(x, y, color=color, linestyle=style, linewidth=2.4 - 0.3 * k,
                label=f"{r.name} ($T_f$ = {r.summary['final_time']:.3g} s)")  # fmt: skip
        direction_arrow(ax, x, y, color, where=0.3 + 0.1 * k)
        speed = ocp.vehicle.roles.speed
        mark_reversing(ax, x, y, r.trajectory[speed], name=tex(speed), label=not any(
            ln.get_label().startswith("reversing") for ln in ax.get_lines()))  # fmt: skip
    _start_goal(ax, ocps)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x (m)", ylabel="y (m)")
    legend_above(ax, "Paths of the compared scenarios (arrowheads: direction of travel)", ncols=3, width=80)
    return fig


def path_gap(paths: Sequence[np.ndarray], samples: int = 200) -> float:
    """The largest distance between paths (n x 2 node arrays) at the same fraction of their length."""

    def resample(xy: np.ndarray) -> np.ndarray:
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        s = np.linspace(0.0, arc[-1], samples)
        return np.column_stack([np.interp(s, arc, xy[:, 0]), np.interp(s, arc, xy[:, 1])])

    if len(paths) < 2:
        return 0.0
    first = resample(np.asarray(paths[0], float))
    return max(float(np.max(np.hypot(*(resample(np.asarray(p, float)) - first).T))) for p in paths[1:])


def cases_figure(results: Sequence[Result], ocps: Sequence, order: Sequence[str]) -> plt.Figure:
    """Cases of one scenario that differ only in their final time or weights, overlaid: (a) speed and (b)
    steering rate over time with their bounds, (c) the paths (coinciding ones drawn once, by the legend),
    (d) the cumulative energy. One figure instead of a near-identical four-panel figure per case."""
    fig, axes = plt.subplots(2, 2, figsize=(FIGURE_WIDTH, 5.4), layout="constrained")
    (a, b), (c, d) = axes
    solved = [(r, o) for r, o in zip(results, ocps, strict=True) if r.solved]
    for k, (r, ocp) in enumerate(solved):
        roles, color, style = ocp.vehicle.roles, color_for(r.name, order), LINESTYLES[k % len(LINESTYLES)]
        label = f"{r.name} ($T_f$ = {r.summary['final_time']:.3g} s)"
        frame = r.trajectory
        for ax, name in ((a, roles.speed), (b, roles.turning)):
            ax.plot(frame["t"], frame[name], color=color, ls=style, label=label)
        c.plot(frame[roles.x], frame[roles.y], color=color, ls=style, lw=2.4 - 0.4 * k, label=label)
        d.plot(frame["t"], cumulative_energy(frame, ocp.vehicle.controls), color=color, ls=style, label=label)
    if solved:
        ocp, roles = solved[0][1], solved[0][1].vehicle.roles
        for ax, name in ((a, roles.speed), (b, roles.turning)):
            _bounds(ax, ocp.bounds, name, "0.45")
            ax.set(xlabel="t (s)", ylabel=f"{tex(name)} ({unit(roles, name)})")
        draw_obstacles(c, ocp.obstacles, label=False)
        frame = solved[0][0].trajectory
        direction_arrow(c, frame[roles.x], frame[roles.y], "black")
        span = max(np.ptp(frame[roles.x]), np.ptp(frame[roles.y]), 0.1)
        _pose_arrow(c, ocp.initial, roles, "tab:green", "start", 0.15 * span)
        _pose_arrow(c, ocp.final, roles, "tab:red", "goal", 0.15 * span)
        c.set_aspect("equal", adjustable="datalim")
    c.set(xlabel="x (m)", ylabel="y (m)")
    d.set(xlabel="t (s)", ylabel=f"energy $E(t)$ ({ENERGY_UNIT})")
    legend_above(a, "(a) speed (bounds dashed)", ncols=1)
    legend_above(b, "(b) steering rate (bounds dashed)", handles=[], labels=[])
    gap = path_gap([r.trajectory[[o.vehicle.roles.x, o.vehicle.roles.y]].to_numpy() for r, o in solved])
    legend_above(c, f"(c) paths (at most {gap:.2g} m apart; arrowhead: direction)", ncols=2,
                 handles=[h for h in c.get_lines() if "pose" in h.get_label()],
                 labels=[h.get_label() for h in c.get_lines() if "pose" in h.get_label()])  # fmt: skip
    legend_above(d, "(d) cumulative energy", handles=[], labels=[])
    names = ", ".join(r.name for r, _ in solved)
    span = max((np.ptp(r.trajectory[o.vehicle.roles.x]) for r, o in solved), default=1.0)
    fig.suptitle(names + (": one path at different final times" if gap < 0.01 * span else ": compared"))
    return fig
