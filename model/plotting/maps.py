"""A lanelet map drawn as a designer's base plan: each lanelet filled by its type, swept paths on top.

``draw_lanelets`` fills every lanelet polygon of a ``LaneletMap`` with the colour of its type
(``LANELET_STYLES``: roadway, intersection, the border lanelets such as Kackertstrasse's apron ring,
sidewalks, restricted lanes, crosswalks, bicycle lanes) with thin outlines, optionally outlining a
route's corridor; ``draw_swept`` draws swept-path polygons (shapely or GeoJSON geometries) over it.
``map_limits`` frames an area. Knows no solver: what is drawn is given.
"""

from __future__ import annotations

from collections.abc import Iterable

import matplotlib.pyplot as plt
import numpy as np
import shapely
from matplotlib.patches import Patch

from model.plotting.roads import geometry_patch
from model.scene.lanelet_map import LaneletMap

# type -> (label, fill colour); the first type of a lanelet found here, in this order, sets its style
LANELET_STYLES = {
    "crosswalk": ("crosswalk", "#f7f7f7"),
    "border": ("border / apron", "#e8d5b0"),
    "sidewalk": ("sidewalk", "#ece7dc"),
    "bicycleLane": ("bicycle lane", "#f3c9c0"),
    "restricted": ("restricted", "#c9c9e3"),
    "intersection": ("intersection", "#cfcfcf"),
    "urban": ("roadway", "#dedede"),
}
OTHER = ("other", "#eeeeee")
OUTLINE = "#8c8c8c"


def lanelet_style(lanelet_map: LaneletMap, lanelet_id: int) -> tuple[str, str]:
    """(label, colour) of a lanelet by its types (``LANELET_STYLES``, else ``OTHER``)."""
    types = {t.value for t in lanelet_map.lanelet(lanelet_id).lanelet_type}
    return next((style for name, style in LANELET_STYLES.items() if name in types), OTHER)


def draw_lanelets(ax: plt.Axes, lanelet_map: LaneletMap, corridor: Iterable[int] = (), labels: bool = False) -> list:
    """Fill each lanelet by its type; outline the ``corridor`` lanelets' union; returns legend handles.

    Parameters
    ----------
    ax : Axes
    lanelet_map : LaneletMap
    corridor : iterable of int
        Lanelet ids whose union is outlined (a route's corridor); none by default.
    labels : bool
        Write each lanelet's id at its centre line's middle.
    """
    used: dict[str, str] = {}
    styles = [*LANELET_STYLES.values(), OTHER]
    for i in sorted(lanelet_map.ids, key=lambda i: -styles.index(lanelet_style(lanelet_map, i))):  # roadway first
        label, colour = lanelet_style(lanelet_map, i)
        used[label] = colour
        ax.add_patch(geometry_patch(lanelet_map.polygon(i), facecolor=colour, edgecolor=OUTLINE, lw=0.3, zorder=1))
        if labels:
            mid = np.asarray(lanelet_map.lanelet(i).center_vertices, float)
            x, y = mid[len(mid) // 2]
            ax.text(x, y, str(i), fontsize=5, ha="center", va="center", color="#555555", zorder=2)
    ids = list(corridor)
    if ids:
        outline = shapely.union_all([lanelet_map.polygon(i) for i in ids])
        ax.add_patch(geometry_patch(outline, facecolor="none", edgecolor="#262626", lw=0.9, zorder=3))
    return [Patch(facecolor=c, edgecolor=OUTLINE, label=lab) for lab, c in used.items()]


def draw_swept(ax: plt.Axes, geometries: Iterable, color: str, label: str | None = None, alpha: float = 0.35) -> None:
    """Swept-path polygons (shapely geometries or GeoJSON geometry dicts) in one colour, one legend entry."""
    for k, geometry in enumerate(geometries):
        shape = geometry if isinstance(geometry, shapely.Geometry) else shapely.geometry.shape(geometry)
        ax.add_patch(geometry_patch(shape, facecolor=color, edgecolor=color, alpha=alpha, lw=0.6, zorder=4,
                                    label=label if k == 0 else None))  # fmt: skip


def map_limits(geometries: Iterable, margin: float = 8.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """x and y limits around the union of shapely geometries, ``margin`` m wider on every side."""
    x0, y0, x1, y1 = shapely.union_all(list(geometries)).bounds
    return (x0 - margin, x1 + margin), (y0 - margin, y1 + margin)


# --------------------------------------------------------------------------- the study's figure

COMPASS = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")
MAX_HEIGHT = 6.2  # in: at most the PDF's 16 cm figure height, so that 8 pt text prints at 7 pt or more


def island(lanelet_map: LaneletMap) -> shapely.Polygon | None:
    """The central island (with the apron a border lanelet may draw round it): the largest hole of the map's
    lanelets' union; None without a hole."""
    merged = shapely.union_all([lanelet_map.polygon(i).buffer(0.05) for i in lanelet_map.ids])
    holes = [shapely.Polygon(ring) for poly in getattr(merged, "geoms", [merged]) for ring in poly.interiors]
    return max(holes, key=lambda h: h.area) if holes else None


def map_frame(lanelet_map: LaneletMap, geometries: Iterable, ring: float = 14.0, margin: float = 4.0):
    """x and y limits holding ``geometries`` and the whole ring: the island grown by ``ring`` m."""
    parts = list(geometries)
    hole = island(lanelet_map)
    if hole is not None:
        parts.append(hole.buffer(ring))
    return map_limits(parts, margin)


def bearing(point, centre) -> str:
    """The compass direction (E, NE, N, ...) of ``point`` seen from ``centre`` (+y is north)."""
    angle = np.degrees(np.arctan2(point[1] - centre[1], point[0] - centre[0])) % 360.0
    return COMPASS[int(((angle + 22.5) % 360.0) // 45.0)]


def cell_route(lanelet_map: LaneletMap, route: dict):
    """A study cell's ``route`` table as a MapRoute (its start, goal and centre line)."""
    from model.scene.lanelet_map import MapRoute

    keys = ("from_lanelet", "to_lanelet", "start_offset", "goal_offset", "apron_use", "apron_gap")
    given = {k: route[k] for k in keys if k in route}
    return MapRoute(lanelet_map, apron_lanelets=tuple(route.get("apron_lanelets", ())), **given)


def movement_name(lanelet_map: LaneletMap, route: dict) -> str:
    """A movement by its legs' directions from the island's centre: "from S to NE" (no lanelet ids)."""
    hole = island(lanelet_map)
    r = cell_route(lanelet_map, route)
    centre = np.asarray(hole.centroid.coords[0]) if hole is not None else np.mean(r.line.points, axis=0)
    return f"from {bearing(r.start()[:2], centre)} to {bearing(r.goal()[:2], centre)}"


def draw_route(ax: plt.Axes, lanelet_map: LaneletMap, route: dict, color) -> None:
    """The route's centre line dotted with arrowheads, its start (green dot) and goal (red square)."""
    from model.plotting.figures import direction_arrow

    r = cell_route(lanelet_map, route)
    s = np.linspace(r.start_offset, r.goal_s, 200)
    xy = r.line.point(s)
    ax.plot(*xy.T, ls=":", color="black", lw=0.9, zorder=5)
    for where in (0.3, 0.6, 0.85):
        direction_arrow(ax, xy[:, 0], xy[:, 1], color, where=where)
    ax.plot(*xy[0], "o", color="tab:green", ms=6, mec="white", zorder=7)
    ax.plot(*xy[-1], "s", color="tab:red", ms=6, mec="white", zorder=7)


def _swept_of(cell: dict) -> list:
    return [shapely.geometry.shape(f["geometry"]) for f in cell["swept_path"]["features"]] if cell.get("valid") else []


def same_swept(a: list[dict], b: list[dict], tol: float = 0.01) -> bool:
    """Whether two panels' cells sweep the same area (symmetric difference under ``tol`` of it)."""
    ua = shapely.union_all([g for c in a for g in _swept_of(c)] or [shapely.Polygon()])
    ub = shapely.union_all([g for c in b for g in _swept_of(c)] or [shapely.Polygon()])
    return ua.symmetric_difference(ub).area <= tol * max(ua.area, ub.area, 1e-9)


def map_figure(lanelet_map: LaneletMap, cells: list[dict], preset: str) -> plt.Figure:
    """One vehicle's movements on the map: a panel per apron setting (one when the settings sweep the same
    area), each movement's swept path, its route with start, goal and direction, named by its legs'
    directions; the framing holds the whole ring; the legend below the map; failures listed by name."""
    from model.plotting.figures import FIGURE_WIDTH, apply_style
    from model.plotting.roads import FONT, draw_north, draw_scale_bar

    apply_style()
    mine = [c for c in cells if c["preset"] == preset]
    panels = {a: [c for c in mine if bool(c["apron"]) == a] for a in sorted({bool(c["apron"]) for c in mine})[::-1]}
    merged = len(panels) == 2 and same_swept(*panels.values())
    if merged:
        panels = {True: panels[True]}
    names = {c["cell"]: movement_name(lanelet_map, c["route"]) for c in mine}
    colours = dict(zip(sorted(set(names.values())), plt.get_cmap("tab10").colors, strict=False))
    xlim, ylim = map_frame(lanelet_map, [g for c in mine for g in _swept_of(c)])
    aspect = (ylim[1] - ylim[0]) / (xlim[1] - xlim[0])
    panel = min(FIGURE_WIDTH / len(panels), (MAX_HEIGHT - 1.8) / aspect)  # the PDF's height cap: 16 cm
    # always the figure width: the legend below (three columns) needs it, a narrower figure cut it at the right
    fig, axes = plt.subplots(1, len(panels), figsize=(FIGURE_WIDTH, panel * aspect + 1.8), squeeze=False,
                             layout="constrained")  # fmt: skip
    for ax, (apron, group) in zip(axes[0], panels.items(), strict=True):
        handles = draw_lanelets(ax, lanelet_map)
        failed = []
        for c in sorted(group, key=lambda c: names[c["cell"]]):
            colour, name = colours[names[c["cell"]]], names[c["cell"]]
            if c.get("valid"):
                draw_swept(ax, _swept_of(c), colour, f"{name}: $T_f$ = {c['final_time']:.1f} s")
                draw_route(ax, lanelet_map, c["route"], colour)
            else:
                failed.append(f"{name} ({c.get('status')})")
        ax.set(xlim=xlim, ylim=ylim, aspect="equal", xticks=[], yticks=[])
        ax.spines[:].set(visible=True, color="0.6", lw=0.6)
        draw_scale_bar(ax)
        draw_north(ax)
        use = next((c.get("apron_use", "none") for c in group), "none")
        title = ("with or without the apron (the same swept paths)" if merged
                 else f"with the apron (use: {use})" if apron else "without the apron")  # fmt: skip
        ax.set_title(title, fontsize=FONT + 1)
        ax.set_xlabel("fails (not drawn): " + (", ".join(failed) or "none"), fontsize=FONT)
    marks = [plt.Line2D([], [], marker="o", ls="", color="tab:green", label="start"),
             plt.Line2D([], [], marker="s", ls="", color="tab:red", label="goal"),
             plt.Line2D([], [], ls=":", color="black", label="route (arrowheads: direction)")]  # fmt: skip
    swept = {h.get_label(): h for ax in axes[0] for h in ax.get_legend_handles_labels()[0]}  # each movement once
    fig.legend(handles=[*handles, *swept.values(), *marks], loc="outside lower center",
               ncols=3, fontsize=FONT, frameon=False)  # fmt: skip
    fig.suptitle(f"{preset}: swept paths of the movements that pass", fontsize=FONT + 1)
    return fig
