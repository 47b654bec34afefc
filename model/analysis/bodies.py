"""Bodies on a road, checked as exact rectangles against the exact corridor (not the NLP's discs).

At the nodes a body must lie in its corridor (the route's, with the apron where the roundabout
lets that body use it): ``node_clearance`` is the smallest signed clearance over bodies and
nodes (>= 0 inside). Between the nodes the states are interpolated linearly on ``SUBSTEPS``
sub-steps and the worst clearance is reported (``dense_clearance``), not judged, as for
obstacles; the validation judges the clearance along the controls integrated from each node
(``model.analysis.validation``, ``dense_clearance`` and ``integration_error``). ``swept_polygons`` is the area each body sweeps (for swept_path.geojson).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from model.problem.ocp import OCP
from model.scene.geometry import Region, clearance
from model.scene.geometry import clearances as clearances_in
from model.scene.roundabout import exit_taken

SUBSTEPS = 4


def body_corners(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Corners (n, 4, 2) of each body at the given state samples."""
    poses = ocp.vehicle.body_poses()
    return {name: body.corners(*ocp.vehicle.state_function(list(poses[name]))(states))
            for name, body in ocp.bodies.items()}  # fmt: skip


def substeps(states: Mapping[str, np.ndarray], names, count: int = SUBSTEPS) -> dict[str, np.ndarray]:
    """States linearly interpolated at ``count`` points inside each interval (nodes excluded)."""
    s = np.arange(1, count + 1) / (count + 1)
    return {n: (states[n][:-1, None] * (1 - s) + states[n][1:, None] * s).ravel() for n in names}


def clearances(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Signed clearance of each body in its corridor at each state sample, metres."""
    out = {}
    for name, corners in body_corners(ocp, states).items():
        region = ocp.road.corridor(name)
        out[name] = clearances_in(region, corners) if isinstance(region, Region) else np.array(
            [clearance(region, c) for c in corners]
        )
    return out


def road_measures(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict:
    """Node and dense clearances, the worst body and node, and the exit the path takes."""
    v = ocp.vehicle
    px, py = v.position
    path = np.column_stack([states[px], states[py]])
    measures = {"exit_taken": exit_taken(ocp.road.roundabout, ocp.road.route.enter, path)}
    if not ocp.bodies:
        return measures | {"min_clearance": None, "min_clearance_dense": None}
    nodes = clearances(ocp, states)
    dense = clearances(ocp, substeps(states, v.states))
    worst = min(nodes, key=lambda b: float(np.min(nodes[b])))
    return measures | {
        "min_clearance": float(min(np.min(c) for c in nodes.values())),
        "min_clearance_dense": float(min(np.min(c) for c in dense.values())),
        "min_clearance_body": worst,
        "min_clearance_node": int(np.argmin(nodes[worst])),
        "body_clearance": {b: float(np.min(c)) for b, c in nodes.items()},
    }


def swept_polygons(ocp: OCP, states: Mapping[str, np.ndarray]):
    """The area each body sweeps over the nodes and sub-steps: name -> shapely (Multi)Polygon."""
    import shapely

    v = ocp.vehicle
    dense = {n: np.concatenate([states[n], substeps(states, v.states, 8)[n]]) for n in v.states}
    out = {}
    for name, corners in body_corners(ocp, dense).items():
        out[name] = shapely.union_all(shapely.polygons(corners)).buffer(0)
    return out
