"""Bodies on a road, checked as exact rectangles against the exact corridor (not the NLP's discs).

At the nodes a body must lie in its corridor (the route's, with the apron where the roundabout
lets that body use it): ``node_clearance`` is the smallest signed clearance over bodies and
nodes (>= 0 inside). Between the nodes the states are interpolated linearly on ``SUBSTEPS``
sub-steps and the worst clearance is reported (``dense_clearance``), not judged, as for
obstacles; the validation judges the clearance along the controls integrated from each node
(``model.analysis.validation``, ``dense_clearance`` and ``integration_error``).
``swept_polygons`` is the area each body sweeps (for swept_path.geojson).
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
    return measures | clearance_measures(nodes, dense)


def clearance_measures(nodes: dict[str, np.ndarray], dense: dict[str, np.ndarray]) -> dict:
    """The summary's corridor clearances from each body's clearances at the nodes and between them."""
    worst = min(nodes, key=lambda b: float(np.min(nodes[b])))
    return {
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


def rectangle_gaps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Signed distance between rectangles with corners ``a`` and ``b`` (shape (n, 4, 2) each), metres.

    Disjoint: the exact distance (shapely). Overlapping: minus the penetration depth, the least
    overlap of the projections on the four edge normals (separating axes; exact for convex shapes).
    """
    import shapely

    gap = shapely.distance(shapely.polygons(a), shapely.polygons(b))
    depth = np.full(len(a), np.inf)
    for corners in (a, b):
        for e in (0, 1):
            edge = corners[:, e + 1] - corners[:, e]
            normal = np.stack([-edge[:, 1], edge[:, 0]], -1) / np.linalg.norm(edge, axis=-1)[:, None]
            pa, pb = np.einsum("nkd,nd->nk", a, normal), np.einsum("nkd,nd->nk", b, normal)
            overlap = np.minimum(pa.max(1), pb.max(1)) - np.maximum(pa.min(1), pb.min(1))
            depth = np.minimum(depth, overlap)
    return np.where(gap > 0, gap, -np.maximum(depth, 0.0))


def moving_clearances(ocp: OCP, samples: Mapping[str, np.ndarray]) -> np.ndarray:
    """Clearance (m, minus safety) to each moving obstacle's exact rectangle at each sample, shape (obstacles, n).

    ``samples`` holds ``t`` and the states. With bodies, the least over the bodies' rectangles;
    without, the reference point's.
    """
    t = np.asarray(samples["t"], dtype=float)
    out = np.empty((len(ocp.moving_obstacles), len(t)))
    corners = body_corners(ocp, samples) if ocp.bodies else {}
    px, py = ocp.vehicle.position
    for i, ob in enumerate(ocp.moving_obstacles):
        if corners:
            other = ob.corners(t)
            out[i] = np.min([rectangle_gaps(c, other) for c in corners.values()], axis=0) - ob.safety
        else:
            out[i] = ob.clearance_at(samples[px], samples[py], t)
    return out


def moving_measures(ocp: OCP, samples: Mapping[str, np.ndarray]) -> dict:
    """``min_clearance_moving`` at the nodes (with its obstacle and node) and ``min_clearance_moving_dense``
    on ``SUBSTEPS`` linear sub-steps of every interval (states and time interpolated, as for the bodies)."""
    nodes = moving_clearances(ocp, samples)
    dense = moving_clearances(ocp, substeps(samples, [*ocp.vehicle.states, "t"]))
    i, k = np.unravel_index(int(np.argmin(nodes)), nodes.shape)
    return {
        "min_clearance_moving": float(nodes[i, k]),
        "min_clearance_moving_dense": float(min(np.min(dense), np.min(nodes))),
        "min_clearance_moving_obstacle": int(i),
        "min_clearance_moving_node": int(k),
    }
