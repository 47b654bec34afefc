"""A road manoeuvre as a roundabout designer draws it: the plan to scale, bodies at intervals, swept paths.

``road_figure`` draws the plan (paved area with its curbs, the hatched truck apron, the central
island, the leg centre lines and give-way lines), the envelope each body sweeps, the bodies every
few nodes (other vehicles, the moving obstacles, at the same times, with their paths), the axle
tracks, a scale bar and a north arrow; beside it the controls, the steering
angle and (for a trailer) the articulation angle over time with their bounds. ``draw_roundabout``,
``draw_scale_bar`` and ``geometry_patch`` are shared with the animation (``model.plotting.animation``).
"""

from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
import shapely
from matplotlib.colors import to_rgb
from matplotlib.patches import PathPatch
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.path import Path as MplPath
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

from model.analysis.bodies import body_corners, swept_polygons
from model.plotting.figures import ENERGY_UNIT, FIGURE_WIDTH, apply_style, direction_arrow, draw_moving_obstacles, tex
from model.problem.ocp import OCP
from model.scene.geometry import Disc
from model.scene.roundabout import (
    Roundabout,
    apron_region,
    fillet_region,
    island_region,
    lane_side,
    leg_point,
)

PAVED, APRON, ISLAND, CURB, MARKING = "#e3e3e3", "#e8d5b0", "#b9d9a8", "#262626", "white"
BODY_COLORS = {"vehicle": "#1f5fa8", "trailer": "#b2182b"}
TRACK_STYLES = {"front axle": "-", "rear axle": "--", "trailer axle": ":"}
SCALE_BAR_GID = "scale-bar"
CLOSE = 1e-4  # m: slits narrower than twice this between the carriageway's polygons are closed
NICE_LENGTHS = (1, 2, 5, 10, 20, 25, 50, 100, 200, 500)
DEG = 180.0 / math.pi
ROLE_PANELS = {  # a time panel per role of the vehicle (the name in TeX after the text), in display units
    "speed": ("speed", "m/s", 1.0),
    "acceleration": ("acceleration", "m/s$^2$", 1.0),
    "jerk": ("jerk", "m/s$^3$", 1.0),
    "steering_rate": ("steering rate", "deg/s", DEG),
    "turn_rate": ("turn rate", "deg/s", DEG),
    "steering": ("steering", "deg", DEG),
}
PANEL_LABELS = {
    "lateral_acceleration": (r"lateral $a_{lat}$", "m/s$^2$", 1.0),
    "articulation": (r"articulation $\theta-\theta_1$", "deg", DEG),
}
KMH = 3.6  # km/h per m/s
FONT = 8.0  # pt: the road figure is FIGURE_WIDTH wide, so its text prints at >= 7 pt (model.plotting.rules)
MAX_HEIGHT = 6.2  # in: within the PDF's 16 cm figure height, so that the width sets the print scale


# --------------------------------------------------------------------------- shapes as patches


def geometry_patch(geometry, **style) -> PathPatch:
    """One patch for a shapely (Multi)Polygon, holes left open.

    Parameters
    ----------
    geometry : shapely Polygon or MultiPolygon
        The area to draw; empty parts are skipped.
    **style
        Patch properties (facecolor, edgecolor, hatch, alpha, ...).

    Returns
    -------
    PathPatch
        Exteriors counter-clockwise and holes clockwise, so the non-zero fill leaves the holes empty.
    """
    vertices, codes = [], []
    for part in shapely.get_parts(shapely.orient_polygons(geometry)):
        for ring in (part.exterior, *part.interiors) if not part.is_empty else ():
            xy = np.asarray(ring.coords)
            vertices.append(xy)
            codes.append([MplPath.MOVETO] + [MplPath.LINETO] * (len(xy) - 2) + [MplPath.CLOSEPOLY])
    if not vertices:
        return PathPatch(MplPath(np.zeros((1, 2)), [MplPath.MOVETO]), **style)
    return PathPatch(MplPath(np.concatenate(vertices), np.concatenate(codes)), **style)


def _plot_lines(ax: plt.Axes, lines, **style) -> None:
    """Draw every LineString part of a shapely geometry."""
    for part in shapely.get_parts(lines):
        if isinstance(part, shapely.LineString | shapely.LinearRing) and not part.is_empty:
            ax.plot(*np.asarray(part.coords).T, **style)


# --------------------------------------------------------------------------- the roundabout


def paved_area(rb: Roundabout):
    """The carriageway: the disc of the outer curb with every leg's lanes and curb fillets (shapely).

    The union of the exact shapes' polygons leaves slivers along the outer curb circle and slits
    between touching polygons: the slits are closed by a +-``CLOSE`` buffer and only the exteriors
    are kept (the island and apron are drawn over the carriageway).
    """
    parts = [Disc(rb.center, rb.outer_radius, "outer curb").polygon()]
    for leg, g in enumerate(rb.legs):
        end, w = rb.outer_radius + g.length, g.lane_width
        parts.append(shapely.Polygon([leg_point(rb, leg, a, s) for a, s in ((0, -w), (end, -w), (end, w), (0, w))]))
        parts += [fillet_region(rb, leg, lane).polygon for lane in ("entry", "exit")]
    closed = shapely.union_all(parts).buffer(CLOSE, join_style="mitre").buffer(-CLOSE, join_style="mitre")
    return shapely.union_all([shapely.Polygon(p.exterior) for p in shapely.get_parts(closed)])


def _leg_ends(rb: Roundabout):
    """The cut lines where the drawn legs end (not curbs)."""
    ends = []
    for i, g in enumerate(rb.legs):
        reach = rb.outer_radius + g.length
        ends.append(shapely.LineString([leg_point(rb, i, reach, -g.lane_width), leg_point(rb, i, reach, g.lane_width)]))
    return shapely.union_all(ends)


def _give_way_line(rb: Roundabout, leg: int) -> np.ndarray:
    """Points of the entry lane's give-way line, along the outer curb circle across the lane."""
    w, side = rb.legs[leg].lane_width, lane_side(rb, "entry")
    across = np.linspace(0.0, side * w, 12)
    along = np.sqrt(rb.outer_radius**2 - across**2)
    return np.array([leg_point(rb, leg, a, s) for a, s in zip(along, across, strict=True)])


def draw_roundabout(ax: plt.Axes, ocp: OCP, label: bool = True) -> None:
    """The plan of the roundabout to scale.

    Parameters
    ----------
    ax : Axes
        Where to draw (equal aspect is set by the caller).
    ocp : OCP
        A problem with a ``road``.
    label : bool
        Give the apron and the island legend labels.
    """
    rb = ocp.road.roundabout
    paved = paved_area(rb)
    ax.add_patch(geometry_patch(paved, facecolor=PAVED, lw=0, zorder=0))
    curbs = shapely.difference(paved.boundary, _leg_ends(rb).buffer(1e-3))
    _plot_lines(ax, curbs, color=CURB, lw=1.3, solid_capstyle="butt", zorder=3)
    for leg, g in enumerate(rb.legs):
        line = np.array([leg_point(rb, leg, rb.outer_radius, 0.0), leg_point(rb, leg, rb.outer_radius + g.length, 0.0)])
        ax.plot(*line.T, color=MARKING, lw=1.0, dashes=(4, 3), zorder=1)
        ax.plot(*_give_way_line(rb, leg).T, color=MARKING, lw=1.2, dashes=(1.5, 1.5), zorder=1)
    if rb.apron_width > 0:
        apron = apron_region(rb).polygon
        style = {"facecolor": APRON, "hatchcolor": "#a88a55", "hatch": "////", "lw": 0, "zorder": 1}
        ax.add_patch(geometry_patch(apron, label="truck apron" if label else None, **style))
        _plot_lines(ax, apron.exterior if hasattr(apron, "exterior") else apron.boundary, color=CURB, lw=0.6, zorder=3)
    island = island_region(rb).polygon
    ax.add_patch(geometry_patch(island, facecolor=ISLAND, lw=0, zorder=1, label="central island" if label else None))
    _plot_lines(ax, island.boundary, color=CURB, lw=1.3, zorder=3)


# --------------------------------------------------------------------------- scale bar, north, frame


def nice_length(span: float, fraction: float = 0.2) -> float:
    """The largest of 1, 2, 5, 10, 20, 25, 50, ... m not longer than ``fraction`` of ``span``."""
    fitting = [n for n in NICE_LENGTHS if n <= fraction * span]
    return float(fitting[-1] if fitting else NICE_LENGTHS[0])


def draw_scale_bar(ax: plt.Axes, loc: str = "lower right") -> AnchoredSizeBar:
    """A scale bar in metres (gid ``"scale-bar"``) sized to about a fifth of the view's width."""
    x0, x1 = ax.get_xlim()
    length = nice_length(x1 - x0)
    bar = AnchoredSizeBar(
        ax.transData, length, f"{length:g} m", loc, pad=0.4, borderpad=0.5, sep=3,
        frameon=True, size_vertical=(x1 - x0) / 150, fontproperties={"size": FONT},
    )  # fmt: skip
    bar.patch.set(alpha=0.85, edgecolor="none")
    bar.set_gid(SCALE_BAR_GID)
    ax.add_artist(bar)
    return bar


def draw_north(ax: plt.Axes) -> None:
    """A north arrow (+y is north) in the upper right corner."""
    ax.annotate("N", xy=(0.95, 0.97), xytext=(0.95, 0.87), xycoords="axes fraction", ha="center", va="top",
                fontsize=8, fontweight="bold", arrowprops={"arrowstyle": "-|>", "color": CURB, "lw": 1.2})  # fmt: skip


def plan_limits(ocp: OCP, cols: Mapping[str, np.ndarray]) -> tuple[tuple[float, float], tuple[float, float]]:
    """The view (x and y limits): the path, the bodies and the outer curb circle with a margin of one leg's width."""
    rb = ocp.road.roundabout
    px, py = ocp.vehicle.position
    (cx, cy), ro = rb.center, rb.outer_radius
    pad = 2 * max(g.lane_width for g in rb.legs)
    corners = np.concatenate([c.reshape(-1, 2) for c in body_corners(ocp, cols).values()] or [np.empty((0, 2))])
    xs = np.concatenate([cols[px], corners[:, 0], [cx - ro, cx + ro]])
    ys = np.concatenate([cols[py], corners[:, 1], [cy - ro, cy + ro]])
    return (xs.min() - pad, xs.max() + pad), (ys.min() - pad, ys.max() + pad)


def frame_plan(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray]) -> None:
    """Equal axes around the plan, a thin border without ticks (the scale bar gives the scale)."""
    xlim, ylim = plan_limits(ocp, cols)
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.grid(False)
    for spine in ax.spines.values():
        spine.set(visible=True, color="0.6", lw=0.6)


# --------------------------------------------------------------------------- vehicle


def body_label(ocp: OCP, name: str) -> str:
    """``"tractor"`` for the vehicle's body when it pulls a trailer, else the body's name."""
    if name == "vehicle":
        return "tractor" if "trailer" in ocp.bodies else ocp.vehicle.model or "vehicle"
    return name


def axle_tracks(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Paths (n, 2) of the axle centres: the front axle (models with a wheelbase d), rear axle, trailer axle."""
    v = ocp.vehicle
    px, py = v.position
    x, y = np.asarray(states[px], float), np.asarray(states[py], float)
    tracks = {}
    d = v.parameter_values().get("wheelbase")
    if d is not None and v.roles.heading in states:
        theta = np.asarray(states[v.roles.heading], float)
        tracks["front axle"] = np.column_stack([x + d * np.cos(theta), y + d * np.sin(theta)])
    tracks["rear axle"] = np.column_stack([x, y])
    poses = v.body_poses()
    if "trailer" in poses:
        tx, ty, _ = v.state_function(list(poses["trailer"]))(states)
        tracks["trailer axle"] = np.column_stack([tx, ty])
    return tracks


def _draw_envelopes(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray]) -> None:
    for name, poly in swept_polygons(ocp, cols).items():
        color = BODY_COLORS.get(name, "0.4")
        ax.add_patch(geometry_patch(poly, facecolor=color, alpha=0.12, lw=0, zorder=4))
        ax.add_patch(geometry_patch(poly, facecolor="none", edgecolor=color, lw=0.9, zorder=6,
                                    label=f"{body_label(ocp, name)} swept path"))  # fmt: skip


def pose_nodes(ocp: OCP, cols: Mapping[str, np.ndarray], count: int = 8) -> np.ndarray:
    """Node indices about equally spaced along the rear-axle path (first and last included).

    The spacing is the path length over ``count``, but at least the longest body, so that the
    drawn bodies seldom overlap.
    """
    px, py = ocp.vehicle.position
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(cols[px]), np.diff(cols[py])))])
    longest = max((b.length for b in ocp.bodies.values()), default=0.0)
    step = max(s[-1] / count, longest, 1e-9)
    marks = np.append(np.arange(0.0, s[-1] - 0.5 * step, step), s[-1])
    return np.unique(np.searchsorted(s, marks).clip(0, len(s) - 1))


def _draw_bodies(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray], nodes: np.ndarray) -> None:
    picks = {k: np.asarray(a)[nodes] for k, a in cols.items()}
    for name, corners in body_corners(ocp, picks).items():
        color = BODY_COLORS.get(name, "0.4")
        for i, c in enumerate(corners):
            label = body_label(ocp, name) if i == 0 else None
            ax.add_patch(PolygonPatch(c, closed=True, fc=(*to_rgb(color), 0.25), ec=color, lw=0.8, zorder=5,
                                      label=label))  # fmt: skip


def draw_poses(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray], nodes: np.ndarray) -> None:
    """The bodies to scale at the rows ``nodes`` of ``cols`` (t and the states) and, with moving
    obstacles, each other vehicle where it was at those times, both marked with the time."""
    _draw_bodies(ax, ocp, cols, nodes)
    if not ocp.moving_obstacles:
        return
    t = np.asarray(cols["t"], float)
    draw_moving_obstacles(ax, ocp, t[nodes], float(t[-1]))
    px, py = ocp.vehicle.position
    for k in nodes:
        ax.annotate(f"{t[k]:.1f} s", (cols[px][k], cols[py][k]), fontsize=FONT, color="black",
                    ha="center", va="center", zorder=9)  # fmt: skip


def _draw_tracks(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray]) -> None:
    for name, xy in axle_tracks(ocp, cols).items():
        color = BODY_COLORS["trailer"] if name == "trailer axle" else "black"
        ax.plot(*xy.T, color=color, lw=0.7, ls=TRACK_STYLES[name], zorder=7, label=f"{name} track")


# --------------------------------------------------------------------------- the figure


def road_figure(
    ocp: OCP, columns: Mapping[str, np.ndarray], title: str = "", every: int | None = None, note: str = ""
) -> plt.Figure:
    """The manoeuvre on the plan to scale (left) and its controls and angles over time (right).

    Parameters
    ----------
    ocp : OCP
        A problem with a ``road``.
    columns : mapping
        Node values: t, the states and the controls (a Solution's ``columns`` or a trajectory.csv).
    title : str, optional
        Figure title (default: the scenario's title or name).
    every : int, optional
        Draw the bodies at every ``every``-th node (default: about eight poses equally spaced along the path).
    note : str, optional
        A line added under the title (e.g. the final time and least clearance).

    Returns
    -------
    Figure
        The plan axes first, then one axes per time panel (the speed, the steering rate, the steering
        angle: the vehicle's ``roles``, and the articulation for a trailer).
    """
    apply_style()
    v = ocp.vehicle
    cols = {k: np.asarray(columns[k], float) for k in ("t", *v.states, *v.controls)}
    (x0, x1), (y0, y1) = plan_limits(ocp, cols)
    plan_width = 3.7
    rows = _panel_names(ocp, cols)
    least = max(4.0, 0.8 * len(rows) + 1.2)  # per time panel room for its title, and the heading
    height = min(max(least, 0.9 * plan_width * (y1 - y0) / (x1 - x0) + 1.6), MAX_HEIGHT)
    fig = plt.figure(figsize=(FIGURE_WIDTH, height), layout="constrained")
    grid = fig.add_gridspec(len(rows), 2, width_ratios=(plan_width, FIGURE_WIDTH - plan_width))
    ax = fig.add_subplot(grid[:, 0])
    draw_roundabout(ax, ocp)
    _draw_envelopes(ax, ocp, cols)
    nodes = np.arange(0, len(cols["t"]), every) if every else pose_nodes(ocp, cols)
    draw_poses(ax, ocp, cols, nodes)
    _draw_tracks(ax, ocp, cols)
    draw_start_goal(ax, ocp, cols)
    frame_plan(ax, ocp, cols)
    draw_scale_bar(ax)
    draw_north(ax)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.01), ncol=2, fontsize=FONT, frameon=False,
              handlelength=2.0, columnspacing=1.0)  # fmt: skip
    fig.suptitle(heading_text(title or ocp.title or ocp.name, note), fontsize=FONT)
    _time_panels(fig, grid, ocp, cols, rows)
    return fig


def heading_text(title: str, note: str = "", width: int = 100) -> str:
    """The figure's title and note, each line wrapped to ``width`` characters (the figure's width at 8 pt),
    never inside a TeX formula (its spaces held by a placeholder while wrapping)."""
    lines = [title, *note.splitlines()] if note else [title]
    held = [re.sub(r"\$[^$]*\$", lambda m: m.group(0).replace(" ", "\x00"), line) for line in lines]
    wrapped = [w for line in held for w in (textwrap.wrap(line, width) or [""])]
    return "\n".join(wrapped).replace("\x00", " ")


def draw_start_goal(ax: plt.Axes, ocp: OCP, cols: Mapping[str, np.ndarray]) -> None:
    """The start (green) and goal (red) of the rear axle and arrowheads along it: the direction of travel."""
    px, py = ocp.vehicle.position
    x, y = np.asarray(cols[px], float), np.asarray(cols[py], float)
    for where in (0.25, 0.5, 0.75):
        direction_arrow(ax, x, y, "black", where=where)
    ax.plot(x[:1], y[:1], "o", color="tab:green", ms=6, mec="white", mew=0.8, zorder=9, label="start (rear axle)")
    ax.plot(x[-1:], y[-1:], "s", color="tab:red", ms=6, mec="white", mew=0.8, zorder=9, label="goal (rear axle)")


def _panel_names(ocp: OCP, cols: Mapping[str, np.ndarray]) -> list[str]:
    names = [c for c in _panel_roles(ocp) if c in cols]
    names += [k for k in ocp.vehicle.path_outputs() if k == "lateral_acceleration"]
    return names + [k for k in ocp.vehicle.outputs() if k == "articulation"]


def _panel_roles(ocp: OCP) -> dict[str, str]:
    """The vehicle's names with a time panel of their own, in panel order, name -> role."""
    r = ocp.vehicle.roles
    named = {role: getattr(r, role) for role in ROLE_PANELS}
    return {name: role for role, name in named.items() if name is not None}


def panel_label(ocp: OCP, name: str) -> tuple[str, str, float]:
    """(text, unit, scale) of a time panel: its role and the vehicle's name for it (e.g. "speed $u_{1}$")."""
    role = _panel_roles(ocp).get(name)
    if role is None:
        return PANEL_LABELS.get(name, (name, "", 1.0))
    text, unit, scale = ROLE_PANELS[role]
    return f"{text} {tex(name)}", unit, scale


def _panel_values(ocp: OCP, cols: Mapping[str, np.ndarray], name: str) -> np.ndarray:
    if name in cols:
        return cols[name]
    v = ocp.vehicle
    if name in v.path_outputs():
        return v.path_function([v.path_outputs()[name]])(cols)[0]
    return v.state_function([v.outputs()[name]])(cols)[0]


# --------------------------------------------------------------------------- how the vehicle drives


def sign_changes(values: np.ndarray, tol: float) -> int:
    """How often a control changes sign along the nodes, values with |u| <= ``tol`` skipped.

    Parameters
    ----------
    values : ndarray
        Node values of one control (e.g. the steering rate u2).
    tol : float
        Values this close to 0 count as neither sign (for u2, 1e-3 of its largest bound).

    Returns
    -------
    int
        The number of sign changes: dozens for the bang-bang u2 of a time-optimal road solve.
    """
    signs = np.sign(np.asarray(values, float))
    signs = signs[np.abs(values) > tol]
    return int(np.sum(signs[1:] != signs[:-1]))


def steering_changes(ocp: OCP, columns: Mapping[str, np.ndarray]) -> int:
    """Sign changes of u2 (``roles.turning``) along the nodes, ignoring |u2| <= 1e-3 of its largest bound."""
    u2 = ocp.vehicle.roles.turning
    lo, hi = ocp.bounds[u2]
    return sign_changes(np.asarray(columns[u2], float), 1e-3 * max(abs(lo), abs(hi)))


def driving_label(ocp: OCP, math: bool = True) -> str:
    """How the problem drives: time-optimal (bang-bang), or at its design speed with its comfort limits.

    Every number is read from the problem: the largest forward speed of u1 (``roles.speed``, km/h), the
    lateral-acceleration bound and the steering weight of the cost. With ``math``, TeX math in
    ``$...$`` (matplotlib's mathtext and the paper's Markdown read it alike), else plain text.
    """
    lateral = ocp.bounds.get("lateral_acceleration")
    weight = float(getattr(ocp.cost, "steering_weight", 0.0) or 0.0)
    if lateral is None and not weight:
        return "time-optimal (bang-bang steering, no lateral-acceleration limit)"
    r = ocp.vehicle.roles
    parts = [f"design speed {ocp.bounds[r.speed][1] * KMH:.0f} km/h"]
    if lateral is not None:
        lo, hi = lateral
        if math:
            bound = rf"${lo:g} \leq a_{{lat}} \leq {hi:g}$"  # no "|": the label goes into Markdown tables
            parts.append(bound + " m/s$^2$")
        else:
            parts.append(f"|a_lat| <= {hi:g} m/s^2" if lo == -hi else f"a_lat in [{lo:g}, {hi:g}] m/s^2")
    if weight:
        u2 = r.turning
        cost = (rf"$J = T_f + {weight:g} \int {tex(u2)[1:-1]}^2 \, dt$" if math
                else f"J = Tf + {weight:g} * integral of {u2}^2 dt")  # fmt: skip
        parts.append(f"steering weight: {cost}")
    return ", ".join(parts)


def _time_panels(fig: plt.Figure, grid, ocp: OCP, cols: Mapping[str, np.ndarray], rows: list[str]) -> None:
    """One panel per quantity, in display units, its bounds dashed; the time axis shared."""
    first = None
    for i, name in enumerate(rows):
        ax = fig.add_subplot(grid[i, 1], sharex=first)
        first = first or ax
        text, unit, scale = panel_label(ocp, name)
        ax.plot(cols["t"], scale * _panel_values(ocp, cols, name), color="C0" if i < 2 else "C3", lw=1.1)
        for b in ocp.bounds.get(name, ()):
            if np.isfinite(b):
                ax.axhline(scale * b, color="0.45", lw=0.7, ls="--")
        head, _, last = text.rpartition(" ")  # the name as the panel's title, "$u_2$ (deg/s)" on the axis
        ax.set_title(head or text, loc="left", fontsize=FONT, pad=2)
        ax.set_ylabel(last + (f" ({unit})" if unit else "") if head else f"({unit})", fontsize=FONT)
        ax.tick_params(labelsize=FONT)
        if i < len(rows) - 1:
            ax.tick_params(labelbottom=False)
    ax.set_xlabel("t (s)", fontsize=FONT)
def road_note(summary: Mapping, ocp: OCP | None = None, columns: Mapping | None = None) -> str:
    """The lines under the figure's title: final time, energy and the least clearance at the nodes;
    with the problem and its node columns, how it drives (time-optimal or its design speed and limits),
    the largest |a_lat| at the nodes and between them, and how often u2 changes sign."""
    parts = [
        f"$T_f$ = {summary['final_time']:.2f} s" if summary.get("final_time") is not None else "",
        f"energy {summary['energy']:.1f} {ENERGY_UNIT}" if summary.get("energy") is not None else "",
    ]
    if summary.get("min_clearance") is not None:
        body = summary.get("min_clearance_body")
        parts.append(f"least clearance to a curb {summary['min_clearance']:.2f} m" + (f" ({body})" if body else ""))
    if summary.get("min_clearance_moving") is not None:
        parts.append(f"to the other vehicle {summary['min_clearance_moving']:.2f} m beyond its safety distance")
    text = ", ".join(p for p in parts if p)
    if ocp is None or columns is None:
        return text
    driving = [driving_label(ocp)]
    lateral = summary.get("lateral_acceleration") or {}
    if lateral.get("max_abs_nodes") is not None:
        dense = lateral.get("max_abs_dense")
        between = f" ({dense:.3f} between nodes)" if dense is not None else ""
        driving.append(f"max $|a_{{lat}}|$ {lateral['max_abs_nodes']:.3f} m/s$^2${between}")
    driving.append(f"{tex(ocp.vehicle.roles.turning)} changes sign {steering_changes(ocp, columns)} times")
    return text + "\n" + ", ".join(driving)


