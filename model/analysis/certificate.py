"""A Pontryagin certificate of a solved problem, read off its node trajectory.

Conventions are those of ``model/costates.py``: maximisation, H = -L + p.f + mu c,
p at the nodes is the average of the two neighbouring interval-midpoint multipliers
(the end nodes carry the nearest midpoint value), mu >= 0 is the obstacle multiplier
density. Each item is {"value", "tolerance", "passed"} plus what it measured:

- ``costate_recovery``: the midpoint values p_{k+1/2} are rebuilt from the node values
  (p_0 = p_{1/2}, p_k = (p_{k-1/2} + p_{k+1/2}) / 2); the last one must equal p_N.
- ``adjoint``: (p_{k+1/2} - p_{k-1/2}) / h against -dH/dx at node k, the derivation
  engine's adjoint expressions (``derivations.functions``), relative to the scale of p';
  nodes next to an active phi bound (its multiplier is not adjoined) are left out and
  counted, as are nodes where mu jumps (reported separately, not judged).
- ``hamiltonian``: H constant (H = 0 for a free final time) at the interior nodes. A
  switch of a bang control lies on the grid, not at its true instant: that shifts H by at
  most |psi| at the switching node times the jump, so the tolerance is
  sum_u max_k |psi_{k+1} - psi_k| (u_max - u_min) / 2 for affine controls, a few h^2 for
  smooth ones.
- ``maximum``: the gap max_v H(x, p, v) - H(x, p, u) over the control box at each node
  (bang-bang: the sign of each switching function; energy: u = clip(psi)).
- ``transversality``: p_i(Tf) = 0 for free final states (an O(h) end-node estimate).
- ``complementarity``: max |mu c| and ``multiplier_sign``: mu >= 0 (raw duals if present).

Path constraints other than the obstacles (on a road the bodies' island, corridor and keep-out
rows, one family per body and kind; a bounded output such as the articulation) are adjoined:
H = -L + p.f + mu c + sum_j mu_j c_j. Their multiplier densities are the trajectory columns
``mu_<family>``; the gradients dc_j/dx are the NLP's, so they come with the solve (``Adjoined``,
one per family, from ``model.direct.costates.path_multipliers``). The adjoint, Hamiltonian and
transversality items then use p' = -dH/dx - sum_j mu_j dc_j/dx, and ``complementarity`` /
``multiplier_sign`` cover the families' rows too (``families``: each one's value). A trajectory
alone (no ``adjoined``) of a problem with such constraints cannot be judged on those items: they
say ``"status": "not applicable"`` with a ``"reason"`` and are listed in ``not_applicable``;
``passed`` is then False if a judged item fails, else None (not established), never a silent True.

Moving obstacles (``ocp.moving_obstacles``) are adjoined as the families ``moving`` (the reference
point) or ``<body>_moving``; their rows depend on time, so H is not constant along an optimum and
the ``hamiltonian`` item is "not applicable" with that reason.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from derivations.functions import pmp_functions
from model.analysis.columns import Columns, as_arrays
from model.problem.ocp import OCP

MOVING_H = (
    "the moving obstacles make the keep-out constraints depend on time: dH/dt = -sum_j mu_j dc_j/dt, "
    "so H is not constant (nor 0 for a free final time)"
)
TOL = {"recovery": 1e-7, "adjoint": 1e-5, "maximum": 1e-5, "complementarity": 1e-6, "sign": 1e-6}


@dataclass(frozen=True)
class Adjoined:
    """One family of adjoined path constraints at the nodes, as the solve measured it.

    ``name``: the family (its multiplier density is the trajectory column ``mu_<name>``);
    ``gradient``: per state, dc/dx per unit of that density (the family's rows at a node weighted
    by their multipliers), so that the family's part of dH/dx is ``mu_<name> * gradient``;
    ``value``: likewise c, for the term mu c of H; ``complementarity``: max over its rows of
    |nu c| (nu the row's multiplier mass, c its distance to its nearer bound); ``sign``: the most
    negative multiplier mass on the side of its nearer bound (0 if none); ``rows``: how many.
    """

    name: str
    gradient: Mapping[str, np.ndarray]
    value: np.ndarray
    complementarity: float
    sign: float
    rows: int


def _item(value: float, tol: float, **extra) -> dict:
    return {"value": float(value), "tolerance": float(tol), "passed": bool(value <= tol), **extra}


def _not_applicable(reason: str) -> dict:
    return {"status": "not applicable", "reason": reason, "passed": None}


def certify(solution) -> dict:
    """The PMP certificate of ``solution`` (a Solution): items, each with value, tolerance, passed."""
    ocp, traj = solution.ocp, as_arrays(solution.columns)
    if not all(np.all(np.isfinite(col)) for col in traj.values()):
        return {"passed": False, "items": {}, "note": "non-finite trajectory"}
    raw = _raw_obstacle_duals(solution)
    return certify_trajectory(ocp, traj, raw_duals=raw, adjoined=getattr(solution, "adjoined", None))


def certify_trajectory(
    ocp: OCP, traj: Columns, raw_duals: np.ndarray | None = None, adjoined: Sequence[Adjoined] | None = None
) -> dict:
    """The certificate from the node trajectory (e.g. a trajectory.csv).

    Only t, the states, controls, p_<state>, mu and mu_<family> are read; H and the switching
    functions are recomputed from the derivation engine's expressions. ``adjoined``: the path
    constraint families of the solve (their gradients); without it a problem that has such
    constraints gets "not applicable" adjoint, Hamiltonian and transversality items.
    """
    fns = pmp_functions(ocp)
    v = ocp.vehicle
    cols = as_arrays(traj)
    reason = _unadjoined_path_bound(ocp, cols)
    if reason:
        return {"passed": None, "items": {}, "not_applicable": reason}
    if "mu" not in cols or not ocp.obstacles:
        cols["mu"] = np.zeros(len(cols["t"]))
    derived = fns.evaluate(cols)
    t = cols["t"]
    h = (t[-1] - t[0]) / (len(t) - 1)
    families = _families(ocp)
    path = _path_terms(adjoined, cols, v.states) if families else ({s: 0.0 for s in v.states}, 0.0)
    cols["H"] = derived["H"] + (path[1] if path is not None else 0.0)
    cols.update({f"psi_{c}": derived[f"psi_{c}"] for c, _ in fns.laws})
    mids = {s: _midpoints(cols[f"p_{s}"]) for s in v.states}
    flags = _flags(ocp, cols)
    rhs = {s: derived[f"adjoint_{s}"] - path[0][s] for s in v.states} if path is not None else None
    reason = _reason(families, adjoined) if path is None else ""
    items = {"costate_recovery": _recovery(mids, cols, v.states)}
    items["adjoint"] = _adjoint(rhs, mids, h, flags, v.states) if rhs else _not_applicable(reason)
    if ocp.moving_obstacles:
        items["hamiltonian"] = _not_applicable(MOVING_H)
    else:
        items["hamiltonian"] = _hamiltonian(ocp, cols, h, flags) if rhs else _not_applicable(reason)
    items["maximum"] = _maximum(fns.laws, ocp, cols)
    if any(s not in ocp.final for s in v.states):
        items["transversality"] = _transversality(ocp, cols, rhs, h) if rhs else _not_applicable(reason)
    if ocp.obstacles or (families and adjoined is not None):
        items["complementarity"] = _complementarity(ocp, cols, h, adjoined or ())
        items["multiplier_sign"] = _sign(cols["mu"], raw_duals, ocp, adjoined or ())
    skipped = {k: i["reason"] for k, i in items.items() if i.get("status") == "not applicable"}
    judged = all(i["passed"] for k, i in items.items() if k not in skipped)
    passed = judged and (None if skipped else True)  # a failure is False; passing with items not judged, None
    out = {"passed": passed, "items": items, "flagged_nodes": {k: int(np.sum(f)) for k, f in flags.items()}}
    if adjoined:
        out["adjoined"] = {a.name: {"rows": a.rows, "max_mu": float(np.max(np.abs(cols.get(f"mu_{a.name}", 0.0))))}
                           for a in adjoined}  # fmt: skip
    if skipped:
        out["not_applicable"] = skipped
    return out


def _families(ocp: OCP) -> list[str]:
    """What the problem adjoins besides the obstacles: bounded outputs, the bodies on a road."""
    out = [name for name in ocp.vehicle.outputs() if name in ocp.bounds]
    if ocp.road is not None and ocp.bodies:
        out += [f"{body} corridor" for body in ocp.bodies]
    if ocp.moving_obstacles:
        out.append("moving obstacles")
    return out


def _reason(families: list[str], adjoined) -> str:
    what = ", ".join(families)
    if adjoined is None:
        return (f"the path constraints ({what}) are adjoined with gradients dc/dx the solve takes from its NLP "
                "(model.direct.costates.path_multipliers); a trajectory alone does not carry them")  # fmt: skip
    return f"the trajectory lacks the multiplier columns mu_<family> of the path constraints ({what})"


def _path_terms(adjoined, cols: dict, states) -> tuple[dict, np.ndarray] | None:
    """sum_j mu_j dc_j/dx per state and sum_j mu_j c_j, or None if the families are unknown."""
    if adjoined is None or any(f"mu_{a.name}" not in cols for a in adjoined):
        return None
    grad = {s: sum((cols[f"mu_{a.name}"] * a.gradient[s] for a in adjoined), np.zeros(len(cols["t"])))
            for s in states}  # fmt: skip
    value = sum((cols[f"mu_{a.name}"] * a.value for a in adjoined), np.zeros(len(cols["t"])))
    return grad, value


def _unadjoined_path_bound(ocp: OCP, cols: dict) -> str:
    """Why no certificate applies: a bound on a function of state and control (lateral acceleration)
    active at some node; the engine does not adjoin it, so there H, p' and the maximum condition differ."""
    v = ocp.vehicle
    path = {k: e for k, e in v.path_outputs().items() if k in ocp.bounds}
    if not path:
        return ""
    for name, values in zip(path, v.path_function(list(path.values()))(cols), strict=True):
        lo, hi = ocp.bounds[name]
        active = int(np.sum((values - lo < 1e-6 * max(1.0, abs(lo))) | (hi - values < 1e-6 * max(1.0, abs(hi)))))
        if active:
            return f"the {name} bound [{lo:g}, {hi:g}] (of state and control) is active at {active} nodes; not adjoined"
    return ""


def _midpoints(p: np.ndarray) -> np.ndarray:
    """p_{k+1/2}, k = 0..N-1, rebuilt from the node averages (p_0 is the first midpoint)."""
    mid = np.empty(len(p) - 1)
    mid[0] = p[0]
    for k in range(1, len(mid)):
        mid[k] = 2 * p[k] - mid[k - 1]
    return mid


def _recovery(mids: dict, cols: dict, states) -> dict:
    scale = max(1.0, max(float(np.max(np.abs(cols[f"p_{s}"]))) for s in states))
    err = max(abs(mids[s][-1] - cols[f"p_{s}"][-1]) for s in states) / scale
    return _item(err, TOL["recovery"])


def _flags(ocp: OCP, cols: dict) -> dict[str, np.ndarray]:
    """Nodes not judged: next to an active phi bound; where mu jumps (contact)."""
    n = len(cols["t"])
    state_bound = np.zeros(n, bool)
    for name, (lo, hi) in ocp.bounds.items():
        if name in ocp.vehicle.states:
            state_bound |= (cols[name] - lo < 1e-6) | (hi - cols[name] < 1e-6)
    px, py = ocp.vehicle.position
    h = (cols["t"][-1] - cols["t"][0]) / (n - 1)
    contact = cols["mu"] * h > 1e-5
    for ob in ocp.obstacles:
        contact |= ob.clearance(cols[px], cols[py]) < 1e-5
    return {"state_bound": _widen(state_bound), "contact": _widen(contact)}


def _widen(mask: np.ndarray) -> np.ndarray:
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    return out


def _adjoint(rhs: dict, mids: dict, h: float, flags: dict, states) -> dict:
    """Discrete adjoint residual at interior nodes, relative to max |p'|."""
    diff = {s: np.diff(mids[s]) / h for s in states}
    scale = max(1.0, max(float(np.max(np.abs(rhs[s][1:-1]))) for s in states))
    res = np.max([np.abs(diff[s] - rhs[s][1:-1]) for s in states], axis=0) / scale
    judged = ~(flags["state_bound"] | flags["contact"])[1:-1]
    value = float(np.max(res[judged], initial=0.0))
    at_contact = float(np.max(res[flags["contact"][1:-1]], initial=0.0))
    out = _item(value, TOL["adjoint"], judged_nodes=int(judged.sum()), at_contact=at_contact)
    out["passed"] = out["passed"] and bool(judged.sum() >= len(judged) // 2)
    return out


def _hamiltonian(ocp: OCP, cols: dict, h: float, flags: dict) -> dict:
    """max |H - H_ref| over interior nodes off contact; H_ref = 0 (free Tf) or the mean."""
    H = cols["H"][1:-1]
    judged = ~flags["contact"][1:-1]
    ref = 0.0 if ocp.cost.free_final_time else float(np.mean(H[judged])) if judged.any() else 0.0
    dev = np.abs(H - ref)
    tol = 1e-6 + _h_allowance(ocp, cols, h)
    return _item(
        float(np.max(dev[judged], initial=0.0)), tol, reference=ref, at_contact=float(np.max(dev[~judged], initial=0.0))
    )


def _h_allowance(ocp: OCP, cols: dict, h: float) -> float:
    """What a control jump between two nodes may shift H by: sum_u max|dpsi| max|du| / 2."""
    scale = max(1.0, float(np.max(np.abs(cols["H"]))))
    total = 10 * h**2 * scale
    for c in ocp.vehicle.controls:
        total += float(np.max(np.abs(np.diff(cols[f"psi_{c}"])))) * float(np.max(np.abs(np.diff(cols[c])))) / 2
    return total


def _maximum(laws: tuple[tuple[str, str], ...], ocp: OCP, cols: dict) -> dict:
    """Largest gap max_v H(v) - H(u) over the box (H separable in the controls)."""
    gap = np.zeros(len(cols["t"]))
    mismatch = 0
    for c, kind in laws:
        lo, hi = ocp.bounds[c]
        psi, u = cols[f"psi_{c}"], cols[c]
        if kind == "projection":
            best = np.clip(psi, lo, hi)
            gap += 0.5 * (u - psi) ** 2 - 0.5 * (best - psi) ** 2
        else:
            best = np.where(psi >= 0, hi, lo)
            gap += psi * (best - u)
            mismatch += int(np.sum((np.abs(psi) > 1e-3) & (np.abs(u - best) > 1e-3 * (hi - lo))))
    scale = max(1.0, float(np.max(np.abs(cols["H"]))))
    return _item(float(np.max(gap)) / scale, TOL["maximum"], sign_mismatches=mismatch)


def _transversality(ocp: OCP, cols: dict, rhs: dict, h: float) -> dict | None:
    """p_i(Tf) = 0 for free final states, p(Tf) = p_{N-1/2} + h/2 p'(Tf) (discretely exact)."""
    free = [s for s in ocp.vehicle.states if s not in ocp.final]
    if not free:
        return None
    scale = max(1.0, max(float(np.max(np.abs(cols[f"p_{s}"]))) for s in ocp.vehicle.states))
    value = max(abs(cols[f"p_{s}"][-1] + h / 2 * rhs[s][-1]) for s in free) / scale
    return _item(value, TOL["adjoint"], states=free)


def _complementarity(ocp: OCP, cols: dict, h: float, adjoined: Sequence[Adjoined]) -> dict:
    """max |mu c| h: the node's multiplier mass (mu is a density) times its clearance; and the
    path families' max |nu c| over their rows (``families``)."""
    value, extra = 0.0, {}
    if ocp.obstacles:
        px, py = ocp.vehicle.position
        c = np.min([ob.clearance(cols[px], cols[py]) for ob in ocp.obstacles], axis=0)
        value = float(np.max(np.abs(cols["mu"] * c))) * h
    if adjoined:
        extra["families"] = {a.name: a.complementarity for a in adjoined}
        value = max(value, *extra["families"].values())
    return _item(value, TOL["complementarity"], **extra)


def _sign(mu: np.ndarray, raw: np.ndarray | None, ocp: OCP, adjoined: Sequence[Adjoined]) -> dict:
    extra, value = {}, 0.0
    if ocp.obstacles:
        worst = float(np.min(raw)) if raw is not None and raw.size else float(np.min(mu))
        value = max(0.0, -worst)
        extra["source"] = "raw duals" if raw is not None else "mu"
    if adjoined:
        extra["families"] = {a.name: max(0.0, -a.sign) for a in adjoined}
        value = max(value, *extra["families"].values())
    return _item(value, TOL["sign"], **extra)


def _raw_obstacle_duals(solution) -> np.ndarray | None:
    """The obstacle duals z >= 0 straight from the Pyomo model, if it is attached."""
    m = getattr(solution, "model", None)
    if m is None or not solution.ocp.obstacles or not hasattr(m, "dual"):
        return None
    return np.array([m.dual[m.obstacle[i, t]] for i in range(len(solution.ocp.obstacles)) for t in m.nodes])


__all__ = ["Adjoined", "certify", "certify_trajectory"]
