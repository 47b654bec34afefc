"""The arc structure of a solved problem, read off its controls and switching functions.

Each control's nodes are labelled "upper"/"lower" (at a bound) or "interior" (strictly
inside: a singular arc for an affine control, a smooth arc for a strictly concave one);
maximal runs of one label are arcs, and the instants between them are switching times
(for a bang-bang change the zero of the switching function, linearly interpolated).
Geometric arcs are the straight segments (u2 = 0 and phi = 0: the singular arcs of the
time-optimal problem) and the boundary arcs (on the obstacle, where tan(phi) = d/R is
predicted). Chattering near a singular junction shows as many label changes of one
control in a short window; such windows are reported, not drawn as a control.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from model.problem.ocp import OCP
from model.vehicles import Roles

LABELS = {1: "upper", -1: "lower", 0: "interior"}
SYMBOL = {"upper": "+", "lower": "-", "interior": "s"}


def labels(u: np.ndarray, lo: float, hi: float, tol: float = 1e-3) -> np.ndarray:
    """+1 at the upper bound, -1 at the lower bound, 0 strictly inside (relative tolerance)."""
    span = hi - lo
    out = np.zeros(len(u), dtype=int)
    out[u >= hi - tol * span] = 1
    out[u <= lo + tol * span] = -1
    return out


def runs(mask_or_labels: np.ndarray) -> list[tuple[int, int, int]]:
    """Maximal runs (value, first index, last index) of equal values."""
    vals = np.asarray(mask_or_labels)
    edges = np.flatnonzero(np.diff(vals)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges - 1, [len(vals) - 1]])
    return [(int(vals[a]), int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


def control_arcs(traj: pd.DataFrame, control: str, bounds: tuple[float, float], min_interior: int = 3) -> dict:
    """Arcs, switching times and the compact structure string of one control.

    An interior run shorter than ``min_interior`` nodes between two bang arcs is the grid's
    picture of one switch (the control crosses the box between nodes), not an arc.
    """
    t = traj["t"].to_numpy()
    u = traj[control].to_numpy()
    psi = traj[f"psi_{control}"].to_numpy() if f"psi_{control}" in traj else None
    arcs: list[dict] = []
    switches: list[float] = []
    pieces = runs(labels(u, *bounds))
    for i, (value, a, b) in enumerate(pieces):
        inner = 0 < i < len(pieces) - 1
        if value == 0 and inner and b - a + 1 < min_interior:
            if pieces[i - 1][0] != pieces[i + 1][0]:
                switches.append(_switch_time(t, psi, a - 1, b + 1))
            continue
        if arcs and arcs[-1]["kind"] == LABELS[value]:
            arcs[-1]["t1"], arcs[-1]["nodes"] = float(t[b]), arcs[-1]["nodes"] + b - a + 1
            continue
        if arcs and not (pieces[i - 1][0] == 0 and pieces[i - 1][2] - pieces[i - 1][1] + 1 < min_interior):
            switches.append(_switch_time(t, psi, a - 1, a))
        arcs.append({"kind": LABELS[value], "t0": float(t[a]), "t1": float(t[b]), "nodes": b - a + 1})
    return {"arcs": arcs, "switching_times": switches, "structure": " ".join(SYMBOL[a["kind"]] for a in arcs)}


def _switch_time(t: np.ndarray, psi: np.ndarray | None, a: int, b: int) -> float:
    """The first zero of psi between nodes a and b (interpolated), else their midpoint."""
    if psi is not None:
        for k in range(a, b):
            if psi[k] * psi[k + 1] < 0:
                return float(t[k] - psi[k] * (t[k + 1] - t[k]) / (psi[k + 1] - psi[k]))
    return float((t[a] + t[b]) / 2)


def chattering(
    traj: pd.DataFrame, control: str, bounds: tuple[float, float], window: int = 12, changes: int = 4, jump: float = 0.2
) -> list[dict]:
    """Spans where ``control`` reverses direction >= ``changes`` times within ``window`` nodes.

    A reversal is a node where the increments before and after have opposite signs and both
    exceed ``jump`` times the control's range: bang-bang switching every few nodes.
    """
    u = traj[control].to_numpy()
    t = traj["t"].to_numpy()
    du = np.diff(u)
    big = np.abs(du) > jump * (bounds[1] - bounds[0])
    events = np.flatnonzero((du[:-1] * du[1:] < 0) & big[:-1] & big[1:]) + 1
    spans: list[list[int]] = []
    for k in range(len(events) - changes + 1):
        first, last = events[k], events[k + changes - 1]
        if last - first <= window:
            if spans and first <= spans[-1][1]:
                spans[-1][1] = max(spans[-1][1], last)
            else:
                spans.append([first, last])
    n = len(t) - 1
    return [
        {
            "t0": float(t[max(a - 1, 0)]),
            "t1": float(t[min(b + 1, n)]),
            "reversals": int(np.sum((events >= a) & (events <= b))),
        }
        for a, b in spans
    ]


def straight_arcs(traj: pd.DataFrame, roles: Roles, tol: float = 1e-3, min_nodes: int = 3) -> list[dict]:
    """Runs with u2 = 0 and phi = 0 (straight line; u2 the ``roles.steering_rate``, phi the
    ``roles.steering``): the singular arcs of the time problem."""
    rate, angle = traj[roles.steering_rate].to_numpy(), traj[roles.steering].to_numpy()
    mask = (np.abs(rate) < tol) & (np.abs(angle) < tol)
    t = traj["t"].to_numpy()
    return [
        {"t0": float(t[a]), "t1": float(t[b]), "nodes": b - a + 1}
        for v, a, b in runs(mask.astype(int))
        if v and b - a + 1 >= min_nodes
    ]


def boundary_arcs(ocp: OCP, traj: pd.DataFrame, tol: float = 1e-5) -> list[dict]:
    """Runs on the first obstacle (clearance < tol) with mean phi (``roles.steering``) against atan(d / R)."""
    if not ocp.obstacles or ocp.vehicle.roles.steering is None:
        return []
    ob = ocp.obstacles[0]
    px, py = ocp.vehicle.position
    on = ob.clearance(traj[px].to_numpy(), traj[py].to_numpy()) < tol
    t, phi = traj["t"].to_numpy(), traj[ocp.vehicle.roles.steering].to_numpy()
    d = ocp.vehicle.parameter_values().get("wheelbase")
    predicted = math.atan(d / ob.keep_out) if d else None
    out = []
    for v, a, b in runs(on.astype(int)):
        if v:
            out.append(
                {
                    "t0": float(t[a]),
                    "t1": float(t[b]),
                    "nodes": b - a + 1,
                    "mean_abs_phi": float(np.mean(np.abs(phi[a : b + 1]))),
                    "predicted_phi": predicted,
                }
            )
    return out


def arc_structure(solution) -> dict:
    """All of the above for one Solution (or anything with .ocp and .trajectory)."""
    ocp, traj = solution.ocp, solution.trajectory
    r = ocp.vehicle.roles
    controls = {c: control_arcs(traj, c, ocp.bounds[c]) for c in ocp.vehicle.controls}
    chatter = {c: chattering(traj, c, ocp.bounds[c]) for c in ocp.vehicle.controls}
    return {
        "controls": controls,
        "chattering": chatter,
        "chattering_detected": any(chatter.values()),
        "straight_arcs": straight_arcs(traj, r) if r.steering_rate in traj and r.steering in traj else [],
        "boundary_arcs": boundary_arcs(ocp, traj),
    }
