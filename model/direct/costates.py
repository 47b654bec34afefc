"""Costate estimates from the NLP multipliers (the paper's maximisation convention).

Ipopt's Lagrangian is J + sum_k lam_k . c_k + ..., with the trapezoid defect
c_k = X_{k+1} - X_k - h/2 (f_k + f_{k+1}). Its stationarity in X_k and U_k is the
trapezoid discretisation of p' = -dH/dX, dH/dU = 0 for H = -L + p.f + mu c with
p = lam: lam_k estimates p at the interval midpoint t_{k+1/2}. Pyomo stores
dual = -lam (minimisation), so p_mid = -dual. Node values average the two
neighbouring midpoints; at t_0 and t_N the nearest midpoint value is used, which
is the value for which the discrete maximum condition holds exactly at those nodes.

The obstacle constraint is written dist^2 >= R^2; its dual z_k >= 0 is a point mass
at node k, with quadrature weight w_k (h inside, h/2 at the ends). The density of
the multiplier of c = dist - R >= 0 is then mu_k = 2 dist_k z_k / w_k >= 0.

The other path constraints (``path_multipliers``: the bodies' rows on a road, one family per
body and kind, ``model.direct.bodies.body_rows``, and the bounded outputs such as the
articulation) are adjoined the same way, each row r at node k as it is written (c_r = its body
minus its active bound): its density is nu_r / w_k (nu the Pyomo dual) and its share of p' is
-nu_r dc_r/dx / w_k, the gradient taken from the NLP's own Jacobian (``CasadiNLP.jacobian_at``)
through the rows that define the auxiliary points (disc centres, corners) from the state.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo

from model.analysis.certificate import Adjoined
from model.direct.families import PRICED, transcription_of
from model.nlp.casadi_nlp import CasadiNLP
from model.problem.ocp import OCP


def midpoint_to_nodes(mid: np.ndarray) -> np.ndarray:
    """Average neighbouring midpoint values; the end nodes take the nearest one."""
    inner = (mid[:-1] + mid[1:]) / 2
    return np.concatenate([[mid[0]], inner, [mid[-1]]])


def costates(m: pyo.ConcreteModel, ocp: OCP) -> dict[str, np.ndarray]:
    """p_<state> at the nodes, from the duals of the trapezoid constraints."""
    out = {}
    for s, con in zip(ocp.vehicle.states, transcription_of(m).dynamics(), strict=True):
        mid = np.array([-m.dual[con[k]] for k in sorted(con.keys())])
        out[f"p_{s}"] = midpoint_to_nodes(mid)
    return out


def obstacle_multiplier(m: pyo.ConcreteModel, ocp: OCP, xy: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """mu >= 0 at the nodes, summed over obstacles (a density in 1/s units of p)."""
    n = len(m.nodes) - 1
    h = float(pyo.value(m.tf)) / n
    weights = np.full(n + 1, h)
    weights[[0, -1]] = h / 2
    mu = np.zeros(n + 1)
    for i, ob in enumerate(ocp.obstacles):
        z = np.array([m.dual[m.obstacle[i, t]] for t in m.nodes])
        dist = np.hypot(xy[0] - ob.center[0], xy[1] - ob.center[1])
        mu += 2 * dist * np.maximum(z, 0.0) / weights
    return mu


def path_multipliers(
    m: pyo.ConcreteModel, nlp: CasadiNLP, ocp: OCP, x: np.ndarray
) -> tuple[dict[str, np.ndarray], list[Adjoined]]:
    """The path constraints' multiplier columns ``mu_<family>`` and their parts of the adjoint.

    Families: each bounded output (``mu_articulation``, signed: >= 0 at the lower bound, <= 0 at
    the upper) and, on a road, ``<body>_<kind>`` (``mu_vehicle_corridor`` ...; >= 0), each the sum
    over the family's rows at a node (the body's cover discs or corners) of nu_r / w_k. With them,
    one ``Adjoined`` per family: its gradient per unit multiplier (sum_r nu_r dc_r/dx / sum_r nu_r
    at each node), likewise its constraint value, and its complementarity and sign. ``x`` is the
    reduced primal answer whose duals ``m.dual`` holds.
    """
    families = transcription_of(m).rows_of_kind(*PRICED)
    if not families:
        return {}, []
    J, body = nlp.jacobian_at(x).tocsr(), nlp.constraint_values_at(x)
    column = {id(v): i for i, v in enumerate(nlp.variables)}
    row = {id(c): i for i, c in enumerate(nlp.constraints)}
    nodes, states = m.nodes, ocp.vehicle.states
    n = len(nodes) - 1
    h = float(pyo.value(m.tf)) / n
    weights = np.full(n + 1, h)
    weights[[0, -1]] = h / 2
    cols = np.array([column[id(m.component(s)[t])] for s in states for t in nodes])
    G = J[:, cols]  # rows x (state, node): the direct dependence on the state ...
    defs = transcription_of(m).definitions
    if defs:  # ... plus that through the auxiliary points, a = position(x): da/dx = -J[def, x] / J[def, a]
        aux = np.array([column[id(var[t])] for var, _ in defs for t in nodes])
        drows = np.array([row[id(con[t])] for _, con in defs for t in nodes])
        own = np.asarray(J[drows, aux]).ravel()
        G = G - J[:, aux] @ (J[drows][:, cols].multiply(1.0 / own[:, None])).tocsr()
    G = G.tocsr()
    position = {t: k for k, t in enumerate(nodes)}
    grouped: dict[str, list] = {}
    for name, comp in families:
        keys = [(key, key[-1] if isinstance(key, tuple) else key) for key in comp]  # the node time is the last index
        grouped.setdefault(name, []).extend((row[id(comp[key])], position[t], comp[key]) for key, t in keys)
    columns, adjoined = {}, []
    for name, rows in grouped.items():
        r = np.array([q[0] for q in rows])
        k = np.array([q[1] for q in rows])
        nu = np.array([float(m.dual[q[2]]) for q in rows])
        c, side, active = _slack([q[2] for q in rows], body[r], nu)
        mu = np.bincount(k, weights=nu, minlength=n + 1) / weights
        weighted = np.asarray((G[r].multiply(nu[:, None])).sum(axis=0)).ravel().reshape(len(states), n + 1)
        value = np.bincount(k, weights=nu * active, minlength=n + 1) / weights
        safe = np.where(mu != 0, mu, 1.0)
        per_unit = {s: np.where(mu != 0, weighted[i] / weights / safe, 0.0) for i, s in enumerate(states)}
        columns[f"mu_{name}"] = mu
        adjoined.append(Adjoined(
            name=name, gradient=per_unit, value=np.where(mu != 0, value / safe, 0.0),
            complementarity=float(np.max(np.abs(nu * c), initial=0.0)),
            sign=float(np.min(nu * side, initial=0.0)), rows=len(rows),
        ))  # fmt: skip
    return columns, adjoined


def _slack(datas: list, body: np.ndarray, nu: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row (its ``body`` value): the distance to its nearer bound, which bound that is (+1 lower,
    -1 upper), and c = body - b for the bound b its dual ``nu`` pushes from (the lower one if nu >= 0)."""
    lo = np.array([np.nan if d.lower is None else float(pyo.value(d.lower)) for d in datas])
    hi = np.array([np.nan if d.upper is None else float(pyo.value(d.upper)) for d in datas])
    below = np.where(np.isnan(lo), np.inf, body - lo)
    above = np.where(np.isnan(hi), np.inf, hi - body)
    use_lower = ~np.isnan(lo) & ((nu >= 0) | np.isnan(hi))
    return np.minimum(below, above), np.where(below <= above, 1.0, -1.0), np.where(use_lower, below, -above)
