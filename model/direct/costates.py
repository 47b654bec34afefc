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
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo

from model.problem.ocp import OCP


def midpoint_to_nodes(mid: np.ndarray) -> np.ndarray:
    """Average neighbouring midpoint values; the end nodes take the nearest one."""
    inner = (mid[:-1] + mid[1:]) / 2
    return np.concatenate([[mid[0]], inner, [mid[-1]]])


def costates(m: pyo.ConcreteModel, ocp: OCP) -> dict[str, np.ndarray]:
    """p_<state> at the nodes, from the duals of the trapezoid constraints."""
    out = {}
    for s in ocp.vehicle.states:
        con = m.component(f"d{s}_trapezoid")
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
