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
