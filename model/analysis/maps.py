"""Bodies on a lanelet map, checked as exact rectangles in the route's corridor (shapely).

As on roads (``model.analysis.bodies``): ``min_clearance`` at the nodes and ``min_clearance_dense``
on ``SUBSTEPS`` linear sub-steps between them (>= 0 inside the corridor), plus the lanelets any body
touches and, where a body leaves the corridor, where and by how much (``corridor_diagnosis``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import shapely

from model.analysis.bodies import body_corners, clearance_measures, substeps
from model.problem.ocp import OCP
from model.scene.geometry import polygon_clearances

AREA = 1e-3  # m^2: a lanelet counts as used when a body covers more of it than this


def map_clearances(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Signed clearance (m) of each body's exact rectangle in its corridor at each state sample."""
    return {name: polygon_clearances(ocp.map_route.corridor(name), corners)
            for name, corners in body_corners(ocp, states).items()}  # fmt: skip


def map_measures(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict:
    """``min_clearance`` (nodes), ``min_clearance_dense`` (sub-steps), the worst body and node,
    ``body_clearance`` per body, ``route_lanelets`` and ``lanelets_used``."""
    route = ocp.map_route
    measures = {"route_lanelets": sorted(route.corridor_lanelets)}
    if not ocp.bodies:
        return measures | {"min_clearance": None, "min_clearance_dense": None, "lanelets_used": []}
    v = ocp.vehicle
    nodes = map_clearances(ocp, states)
    dense = map_clearances(ocp, substeps(states, v.states))
    rectangles = [shapely.polygons(c) for c in body_corners(ocp, states).values()]
    return measures | clearance_measures(nodes, dense) | {
        "lanelets_used": lanelets_covered(ocp, shapely.union_all(np.concatenate(rectangles))),
    }


def lanelets_covered(ocp: OCP, area, least: float = AREA) -> list[int]:
    """Ids of the map's lanelets that share more than ``least`` m^2 with ``area`` (a shapely geometry), sorted;
    a lanelet that only touches it along an edge is not counted."""
    lanelets = ocp.map_route.map
    return [i for i in ocp.map_route.lanelets_touching(area) if lanelets.polygon(i).intersection(area).area > least]


def corridor_diagnosis(ocp: OCP, states: Mapping[str, np.ndarray]) -> list[dict]:
    """Each body that leaves its corridor: the node or sub-step where it leaves it most, and by how much.

    Returns
    -------
    list of dict
        ``body``, ``where`` ("node" or "between nodes"), ``t`` (s), ``x``, ``y`` (its reference
        point, map coordinates), ``outside`` (m, > 0) and ``lanelets`` (the map's lanelets it
        touches there); empty when every body stays inside at the nodes and between them.
    """
    v, out = ocp.vehicle, []
    samples = {"node": dict(states), "between nodes": substeps(states, [*v.states, "t"])}
    poses = v.body_poses()
    for name in ocp.bodies:
        worst = None
        for where, s in samples.items():
            gaps = map_clearances(ocp, s)[name]
            k = int(np.argmin(gaps))
            if gaps[k] < 0 and (worst is None or gaps[k] < worst[2]):
                worst = (where, s, float(gaps[k]), k)
        if worst is None:
            continue
        where, s, gap, k = worst
        x, y, h = v.state_function(list(poses[name]))({n: np.atleast_1d(a[k]) for n, a in s.items()})
        corners = ocp.bodies[name].corners(x[0], y[0], h[0])
        point = {"x": float(x[0]), "y": float(y[0])}  # names: the diagnosis's keys for the body's point
        out.append({"body": name, "where": where, "t": float(s["t"][k]), **point,
                    "outside": -gap, "lanelets": lanelets_covered(ocp, shapely.Polygon(corners))})  # fmt: skip
    return out
