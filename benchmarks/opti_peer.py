"""The peer: the same trapezoid transcription in CasADi Opti (expand=True, bundled Ipopt).

Dynamics, cost, obstacle and pass constraints, guess and tolerance are the project's
own (from the OCP's SymPy definition), so both sides solve the same NLP.
"""

from __future__ import annotations

import gc
import time

import casadi as ca
import numpy as np
import sympy as sp

from model.nlp.ipopt import DEFAULT_OPTIONS
from model.problem.ocp import OCP
from model.search.guess import initial_guess
from model.vehicles import sym

_CASADI = {"sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "sqrt": ca.sqrt, "atan": ca.atan}


def solve_with_opti(ocp: OCP, intervals: int, passing: str, simple_bounds: bool = True) -> dict:
    """Build and solve with Opti; return times, iterations, objective, status.

    ``simple_bounds``: CasADi's detect_simple_bounds (bounds and boundary values become
    variable bounds, as the project's presolve does); False is Opti's default.
    """
    gc.collect()  # each timing starts from a clean heap (as timeit and pyperf do)
    t0 = time.perf_counter()
    v = ocp.vehicle
    n = intervals
    tf = float(ocp.final_time)
    opti = ca.Opti()
    X = {s: opti.variable(n + 1) for s in v.states}
    U = {c: opti.variable(n + 1) for c in v.controls}
    f = sp.lambdify(v.state_symbols() + v.control_symbols(), v.rhs(numeric=True), modules=[_CASADI])
    F = f(*X.values(), *U.values())
    h = tf / n
    for s, fs in zip(v.states, F, strict=True):
        opti.subject_to(X[s][1:] - X[s][:-1] == h / 2 * (fs[:-1] + fs[1:]))
    for s, val in ocp.initial.items():
        opti.subject_to(X[s][0] == val)
    for s, val in ocp.final.items():
        opti.subject_to(X[s][-1] == val)
    for name, (lo, hi) in ocp.bounds.items():
        var = X.get(name, U.get(name))
        opti.subject_to(opti.bounded(lo, var, hi))
    _obstacles(opti, ocp, X, passing)
    L = sp.lambdify(v.control_symbols(), ocp.cost.lagrangian(v), modules=[_CASADI])(*U.values())
    opti.minimize(h * (ca.sum1(L) - (L[0] + L[-1]) / 2))
    for name, vals in initial_guess(ocp, passing, n, tf).items():
        opti.set_initial(X.get(name, U.get(name)), vals)
    opts = {k: v for k, v in DEFAULT_OPTIONS.items() if k != "sb"}
    opti.solver("ipopt", {"expand": True, "print_time": False, "detect_simple_bounds": simple_bounds}, opts)
    t1 = time.perf_counter()
    try:
        sol = opti.solve()
        status, obj = "optimal", float(sol.value(opti.f))
    except RuntimeError:
        status, obj = "failed", float(opti.debug.value(opti.f))
    t2 = time.perf_counter()
    stats = opti.stats()
    return {
        "build": t1 - t0,
        "solve": t2 - t1,
        "ipopt": float(stats.get("t_wall_total", np.nan)),
        "total": t2 - t0,
        "iterations": int(stats.get("iter_count", -1)),
        "objective": obj,
        "status": status,
    }


def _obstacles(opti: ca.Opti, ocp: OCP, X: dict, passing: str) -> None:
    px, py = ocp.vehicle.position
    for ob in ocp.obstacles:
        cx, cy = ob.center
        opti.subject_to((X[px] - cx) ** 2 + (X[py] - cy) ** 2 >= ob.keep_out**2)
    if ocp.obstacles and passing in ("ccw", "cw"):
        cx, cy = ocp.obstacles[0].center
        ax, ay = X[px][:-1] - cx, X[py][:-1] - cy
        bx, by = X[px][1:] - cx, X[py][1:] - cy
        norms = ca.sqrt((ax**2 + ay**2) * (bx**2 + by**2))
        sweep = ca.sum1(2 * ca.atan((ax * by - ay * bx) / (norms + ax * bx + ay * by)))
        opti.subject_to(sweep >= 0 if passing == "ccw" else sweep <= 0)


__all__ = ["solve_with_opti", "sym"]
