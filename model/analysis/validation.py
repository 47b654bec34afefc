"""Validation of a trajectory independent of the solver that produced it.

It reads only the node values (as written to trajectory.csv) and the OCP's SymPy
definition: trapezoid defects, bounds, boundary conditions, obstacle clearance at
the nodes (of the static discs and, as exact rectangles, of the moving obstacles, ``moving_clearance``)
and the pass direction decide; the clearance between the nodes and the
drift of a scipy re-integration of the controls are measured and reported. The
lateral acceleration (``Vehicle.lateral_acceleration``) is measured at the nodes and on
the dense re-integration; bounded, it is checked at the nodes with the other bounds and
between them within 5 % of the bound (``lateral_acceleration_dense``); so are the speed, acceleration
and jerk of longitudinal dynamics (``longitudinal_dense``, docs/dynamics-format.md).

Between the nodes, on a road with bodies: the controls are integrated from each node to the next
(``one_step``). The exact rectangles along that motion, interval ends included, may not leave the
corridor by more than ``DENSE_CLEARANCE_TOL`` (check ``dense_clearance``: a grid too coarse for
the steering fails, with the numbers). Where a body ends an interval further from the next node
than ``max(clearance there, INTEGRATION_TOL)`` the measure ``integration_error`` says so
(``within_clearance`` False, with the error, the node and the clearance): the search then solves
again on a finer grid (``model.search.accuracy``); such an answer is reported, not failed, as long
as the integrated motion itself stays in the corridor.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

from model.analysis.bodies import moving_measures, road_measures
from model.analysis.columns import Columns, as_arrays
from model.analysis.maps import map_clearances, map_measures
from model.problem.ocp import OCP

TOL = {"defect": 1e-6, "bound": 1e-6, "boundary": 1e-6, "clearance": 1e-6, "grid": 1e-9}
DENSE_SHARE = 0.05  # between the nodes a bounded lateral acceleration may exceed its bound by 5 % of max(|lo|, |hi|)
DENSE_STEPS = 10  # samples of the re-integration per interval
INTEGRATION_TOL = 0.02  # m: a body may end an interval this far from its node whatever the clearance there
DENSE_CLEARANCE_TOL = 0.02  # m: between the nodes a body may leave its corridor by this much at most
# m: on a free grid (the map routes' arclength grid) each interval re-integrated from its node with the controls
# linear must end this close to the next node (the check ``one_step_error``): its free steps let the speed jump
# between 0 and its bound from node to node where the wheels turn (Thiergarten 88 -> 50, SU-30: 0.071 m), an
# error of the trapezoid rule the equal steps of the time grid do not invite (benchmarks/check_map_routes.py: 0.05)
ONE_STEP_TOL = 0.05


# the checks of the motion between the nodes (a free step's accuracy, ``one_step_error``, is one: a finer grid mends it)
BETWEEN_NODES = ("body_clearance_dense", "dense_clearance", "one_step_error")


def failed_checks(validation: dict) -> dict[str, float | None]:
    """The checks a validation failed, each with its value (in the order of ``validation["checks"]``)."""
    return {k: c.get("value") for k, c in validation.get("checks", {}).items() if not c["passed"]}


def fails_only_between_nodes(validation: dict) -> bool:
    """Whether a validation failed, and only checks of the motion between the nodes (``BETWEEN_NODES``): every
    body inside at the nodes, a corner cut between two of them (the grid too coarse, not the road too narrow)."""
    failed = set(failed_checks(validation))
    return bool(failed) and failed <= set(BETWEEN_NODES)


def rhs_lambdified(ocp: OCP, module: str):
    """The dynamics f(*states, *controls) (parameters substituted) as a ``module`` ("numpy", "math") function."""
    v = ocp.vehicle
    return _lambdified(tuple(v.state_symbols() + v.control_symbols()), tuple(v.rhs(numeric=True)), module)


@lru_cache(maxsize=64)
def _lambdified(args: tuple, exprs: tuple, module: str):
    """``sp.lambdify`` of the same expressions once (tens of ms each; every start's validation needs two)."""
    return sp.lambdify(list(args), list(exprs), module)


def dynamics_function(ocp: OCP):
    """Numpy f(X, U) from the SymPy dynamics: arrays of shape (n_states, ...) out."""
    fn = rhs_lambdified(ocp, "numpy")

    def f(states: np.ndarray, controls: np.ndarray) -> np.ndarray:
        out = fn(*states, *controls)
        return np.array([np.broadcast_to(o, np.shape(states[0])) for o in out], dtype=float)

    return f


def _check(value: float, tol: float, ok: bool | None = None) -> dict:
    passed = bool(value <= tol) if ok is None else bool(ok)
    return {"value": float(value), "tolerance": tol, "passed": passed}


def validate(ocp: OCP, traj: Columns, tf: float, passing: str | None = None, free_grid: bool = False) -> dict:
    """Checks (each with value, tolerance, passed) and measures of a node trajectory.

    Only t, the states and the controls of ``traj`` (a DataFrame or a dict of arrays) are read.
    """
    v = ocp.vehicle
    traj = {k: a for k, a in as_arrays(traj).items() if k in ("t", *v.states, *v.controls)}
    t = traj["t"]
    X = np.array([traj[s] for s in v.states])
    U = np.array([traj[c] for c in v.controls])
    n = len(t) - 1
    f = dynamics_function(ocp)(X, U)
    h = np.diff(t) if free_grid else np.full(n, tf / n)  # the trapezoid rule on the steps (a free grid's own)
    defects = X[:, 1:] - X[:, :-1] - h / 2 * (f[:, :-1] + f[:, 1:])
    checks = {
        "finite": _check(0.0, 0.0, all(bool(np.all(np.isfinite(a))) for a in traj.values())),
        "grid": _grid_check(t, tf, n, free_grid),
        "defects": _check(float(np.max(np.abs(defects))), TOL["defect"]),
        "bounds": _check(_bound_violation(ocp, traj), TOL["bound"]),
        "boundary_conditions": _check(_boundary_error(ocp, traj), TOL["boundary"]),
    }
    measures = {}
    if ocp.obstacles:
        node_clear = _clearance(ocp, X, v)
        checks["clearance"] = _check(-min(node_clear, 0.0), TOL["clearance"])
        measures["min_clearance"] = node_clear
        measures["min_clearance_dense"] = _dense_clearance(ocp, X, f, h[:, None])
        px, py = v.position
        swept = ocp.obstacles[0].swept_angle(traj[px], traj[py])
        measures["swept_angle"] = swept
        if passing in ("ccw", "cw"):
            ok = swept > 0 if passing == "ccw" else swept < 0
            checks["pass_direction"] = _check(swept, 0.0, ok)
    elif ocp.road is not None:
        measures.update(road_measures(ocp, traj))
        if ocp.bodies:
            checks["body_clearance"] = _check(-min(measures["min_clearance"], 0.0), TOL["clearance"])
            checks.update(_between_nodes(ocp, traj, measures))
        checks["exit_taken"] = _check(0.0, 0.0, measures["exit_taken"] == ocp.road.route.exit)
    elif ocp.map_route is not None:
        measures.update(map_measures(ocp, traj))
        if ocp.bodies:
            checks["body_clearance"] = _check(-min(measures["min_clearance"], 0.0), TOL["clearance"])
            dense = -min(measures["min_clearance_dense"], 0.0)  # linear sub-steps: the integrated motion's tolerance
            checks["body_clearance_dense"] = _check(dense, DENSE_CLEARANCE_TOL)
            checks.update(_integrated_map_clearance(ocp, traj, measures))
    else:
        measures["min_clearance"] = None
    if ocp.moving_obstacles:
        measures.update(moving_measures(ocp, traj))
        checks["moving_clearance"] = _check(-min(measures["min_clearance_moving"], 0.0), TOL["clearance"])
    if "integration_error" not in measures:
        measures["integration_error"] = _position_step_error(ocp, t, X, U)
    if free_grid:  # the free steps' accuracy is judged, not only measured (see ONE_STEP_TOL)
        error = measures["integration_error"]
        value = float(error.get("integration_error_max", np.inf)) if error.get("success", True) else np.inf
        checks["one_step_error"] = _check(value, ONE_STEP_TOL)
    drift, dense = _reintegration_drift(ocp, t, X, U)
    measures["reintegration"] = drift
    if v.path_outputs():
        measures["lateral_acceleration"] = lateral = _lateral_acceleration(ocp, traj, dense)
        if "bound" in lateral:
            ok = dense is not None and lateral["dense_excess"] <= DENSE_SHARE * lateral["scale"]
            checks["lateral_acceleration_dense"] = _check(lateral["dense_excess"], DENSE_SHARE * lateral["scale"], ok)
    if v.roles.acceleration is not None:
        measures["longitudinal"] = longitudinal = longitudinal_measures(ocp, traj, dense)
        ok = dense is not None and longitudinal["dense_excess_share"] <= DENSE_SHARE
        checks["longitudinal_dense"] = _check(longitudinal["dense_excess_share"], DENSE_SHARE, ok)
    return {"passed": all(c["passed"] for c in checks.values()), "checks": checks, "measures": measures}


def longitudinal_measures(ocp: OCP, traj: dict[str, np.ndarray], dense: dict[str, np.ndarray] | None) -> dict:
    """The speed, acceleration (and jerk) of longitudinal dynamics at the nodes and on the dense re-integration.

    ``max_acceleration``, ``min_acceleration`` (and ``max_abs_jerk``) at the nodes and ``..._dense``
    between them, each variable's ``bounds``, and ``dense_excess_share``: the largest excess of v, a or j
    over its bound between the nodes as a share of that bound's scale max(|lo|, |hi|) (the check allows
    ``DENSE_SHARE``).
    """
    r = ocp.vehicle.roles
    names = [n for n in (r.speed, r.acceleration, r.jerk) if n is not None]
    out: dict = {"bounds": {n: list(ocp.bounds[n]) for n in names if n in ocp.bounds}}
    for where, series in (("", traj), ("_dense", dense)):
        acc = None if series is None else np.asarray(series[r.acceleration], float)
        out["max_acceleration" + where] = None if acc is None else float(np.max(acc))
        out["min_acceleration" + where] = None if acc is None else float(np.min(acc))
        if r.jerk is not None:
            out["max_abs_jerk" + where] = None if series is None else float(np.max(np.abs(series[r.jerk])))
    share = 0.0
    for name, (lo, hi) in out["bounds"].items():
        values = np.asarray((dense if dense is not None else traj)[name], float)
        excess = max(float(np.max(lo - values, initial=0.0)), float(np.max(values - hi, initial=0.0)))
        share = max(share, excess / max(abs(lo), abs(hi), 1e-12))
    out["dense_excess_share"] = share
    return out


def _grid_check(t: np.ndarray, tf: float, n: int, free_grid: bool = False) -> dict:
    """The node times: the largest gap from the equal steps k Tf / N; on a ``free_grid`` (the map routes'
    arclength grid, whose steps differ) that gap is only reported and the check is t_0 = 0, t_N = Tf, increasing."""
    tol = TOL["grid"] * max(1.0, tf)
    gap = float(np.max(np.abs(t - np.arange(n + 1) * tf / n)))
    if not free_grid:
        return _check(gap, tol)
    ends = max(abs(float(t[0])), abs(float(t[-1]) - tf))
    return _check(gap, tol, ends <= tol and bool(np.all(np.diff(t) > 0.0)))


def _bound_violation(ocp: OCP, traj: dict[str, np.ndarray]) -> float:
    """Largest excess over a bound, of a state, a control or a bounded output (articulation)."""
    worst = 0.0
    outputs = _outputs(ocp, traj)
    for name, (lo, hi) in ocp.bounds.items():
        col = traj[name] if name in traj else outputs[name]
        worst = max(worst, float(np.max(lo - col, initial=0.0)), float(np.max(col - hi, initial=0.0)))
    return worst


def _outputs(ocp: OCP, traj: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The vehicle's bounded outputs (of the state, and of state and control) evaluated at the nodes."""
    v = ocp.vehicle
    outputs, path = v.outputs(), v.path_outputs()
    values = dict(zip(outputs, v.state_function(list(outputs.values()))(traj), strict=True))
    return values | dict(zip(path, v.path_function(list(path.values()))(traj), strict=True))


def _lateral_acceleration(ocp: OCP, traj: dict[str, np.ndarray], dense: dict[str, np.ndarray] | None) -> dict:
    """max |a_lat| at the nodes and on the dense re-integration; with a bound, the dense excess over it.

    ``dense_excess`` is the largest amount by which a_lat leaves [lo, hi] between the nodes (0 inside),
    ``scale`` = max(|lo|, |hi|): the check allows 5 % of it (``DENSE_SHARE``).
    """
    v = ocp.vehicle
    evaluate = v.path_function([v.path_outputs()["lateral_acceleration"]])
    nodes = evaluate(traj)[0]
    out: dict = {"max_abs_nodes": float(np.max(np.abs(nodes)))}
    values = evaluate(dense)[0] if dense is not None else None
    out["max_abs_dense"] = float(np.max(np.abs(values))) if values is not None else None
    if "lateral_acceleration" in ocp.bounds:
        lo, hi = ocp.bounds["lateral_acceleration"]
        out["bound"] = [lo, hi]
        out["scale"] = max(abs(lo), abs(hi))
        series = values if values is not None else nodes
        out["dense_excess"] = float(max(np.max(lo - series, initial=0.0), np.max(series - hi, initial=0.0)))
    return out


def _boundary_error(ocp: OCP, traj: dict[str, np.ndarray]) -> float:
    errs = [abs(traj[s][0] - val) for s, val in ocp.initial.items()]
    errs += [abs(traj[s][-1] - val) for s, val in ocp.final.items()]
    return float(max(errs, default=0.0))


def _clearance(ocp: OCP, X: np.ndarray, v) -> float:
    ix, iy = v.states.index(v.position[0]), v.states.index(v.position[1])
    return float(min(np.min(ob.clearance(X[ix], X[iy])) for ob in ocp.obstacles))


def _dense_clearance(ocp: OCP, X: np.ndarray, f: np.ndarray, h, sub: int = 20) -> float:
    """Clearance along the quadratic the trapezoid rule implies between nodes (``h``: the steps, (N, 1))."""
    v = ocp.vehicle
    ix, iy = v.states.index(v.position[0]), v.states.index(v.position[1])
    s = np.linspace(0.0, 1.0, sub + 1)[None, :] * h
    worst = np.inf
    qx = X[ix, :-1, None] + f[ix, :-1, None] * s + (f[ix, 1:, None] - f[ix, :-1, None]) * s**2 / (2 * h)
    qy = X[iy, :-1, None] + f[iy, :-1, None] * s + (f[iy, 1:, None] - f[iy, :-1, None]) * s**2 / (2 * h)
    for ob in ocp.obstacles:
        worst = min(worst, float(np.min(ob.clearance(qx, qy))))
    return worst


def one_step(ocp: OCP, t: np.ndarray, X: np.ndarray, U: np.ndarray, steps: int = DENSE_STEPS) -> np.ndarray | None:
    """Every interval integrated from its own node with the controls linear in between (scipy DOP853).

    All intervals in one integration over the normalised time s in [0, 1] (x_k' = h_k f(x_k, u_k(s))).

    Returns
    -------
    ndarray, shape (n_states, N, steps + 1), or None if the integration failed
        The states at ``steps + 1`` equally spaced points of each interval; ``[:, k, -1]`` is where
        interval k's controls take the vehicle from node k (compare node k + 1).
    """
    from scipy.integrate import solve_ivp  # here, not at import: see model/nlp/imports.py

    f = dynamics_function(ocp)
    shape = (X.shape[0], len(t) - 1)
    h, u0, du = np.diff(t), U[:, :-1], U[:, 1:] - U[:, :-1]

    def rhs(s, y):
        return (f(y.reshape(shape), u0 + du * s) * h).ravel()

    sol = solve_ivp(rhs, (0.0, 1.0), X[:, :-1].ravel(), method="DOP853", rtol=1e-9, atol=1e-11,
                    t_eval=np.linspace(0.0, 1.0, steps + 1))  # fmt: skip
    return sol.y.reshape(*shape, steps + 1) if sol.success else None


def one_step_columns(ocp: OCP, columns: dict[str, np.ndarray], steps: int = DENSE_STEPS) -> np.ndarray | None:
    """``one_step`` of a trajectory's columns (``t``, the states, the controls)."""
    v = ocp.vehicle
    return one_step(ocp, np.asarray(columns["t"], float), np.array([columns[s] for s in v.states]),
                    np.array([columns[c] for c in v.controls]), steps)  # fmt: skip


def interval_clearances(ocp: OCP, paths: np.ndarray, clearances) -> dict[str, np.ndarray]:
    """Per body, its clearance (``clearances(ocp, states)``) at each interval's integrated sub-steps after its node
    (``one_step``'s paths, the interval's end included): arrays (N, steps)."""
    n, count, points = paths.shape
    inside = {s: paths[i, :, 1:].ravel() for i, s in enumerate(ocp.vehicle.states)}
    return {b: c.reshape(count, points - 1) for b, c in clearances(ocp, inside).items()}


def _position_step_error(ocp: OCP, t: np.ndarray, X: np.ndarray, U: np.ndarray) -> dict:
    """Without bodies (measured, not judged): the reference point's one-step error, its largest value and node."""
    paths = one_step(ocp, t, X, U, steps=1)
    if paths is None:
        return {"success": False}
    ix, iy = (ocp.vehicle.states.index(n) for n in ocp.vehicle.position)
    error = np.hypot(paths[ix, :, -1] - X[ix, 1:], paths[iy, :, -1] - X[iy, 1:])
    return {"success": True, "integration_error_max": float(np.max(error)), "max_node": int(np.argmax(error)) + 1}


def _between_nodes(ocp: OCP, traj: dict[str, np.ndarray], measures: dict) -> dict:
    """The one-step integration error of the bodies against their node clearances, and the clearance on the way.

    The error at node k + 1 is the largest distance between a body's corners there and where
    interval k's controls, integrated from node k, put them. Adds ``integration_error`` to
    ``measures`` (``integration_error_max`` with its ``max_body`` and ``max_node``; the ``node``
    and ``body`` with the largest error over the allowance, its ``body_error``, the exact
    ``clearance`` there, the ``tolerance`` max(clearance, INTEGRATION_TOL) and ``within_clearance``)
    and ``min_clearance_integrated`` (the least clearance of the bodies along the integrated
    motion, interval ends included); returns the check ``dense_clearance``.
    """
    from model.analysis.bodies import body_corners
    from model.analysis.bodies import clearances as body_clearances

    v = ocp.vehicle
    paths = one_step_columns(ocp, traj)
    if paths is None:
        measures["integration_error"] = {"success": False}
        return {"dense_clearance": _check(np.inf, DENSE_CLEARANCE_TOL, False)}
    ends = dict(zip(v.states, paths[:, :, -1], strict=True))
    nodes = {s: traj[s][1:] for s in v.states}
    moved = {b: np.max(np.linalg.norm(c - body_corners(ocp, nodes)[b], axis=-1), axis=-1)
             for b, c in body_corners(ocp, ends).items()}  # fmt: skip
    clear = body_clearances(ocp, nodes)
    excess = {b: moved[b] - np.maximum(clear[b], INTEGRATION_TOL) for b in moved}
    body = max(excess, key=lambda b: float(np.max(excess[b])))
    k = int(np.argmax(excess[body]))
    worst = max(moved, key=lambda b: float(np.max(moved[b])))
    measures["integration_error"] = {
        "success": True,
        "integration_error_max": float(np.max(moved[worst])), "max_body": worst,
        "max_node": int(np.argmax(moved[worst])) + 1,
        "node": k + 1, "body": body, "body_error": float(moved[body][k]), "clearance": float(clear[body][k]),
        "tolerance": max(float(clear[body][k]), INTEGRATION_TOL), "within_clearance": bool(excess[body][k] <= 0.0),
    }  # fmt: skip
    return _integrated_clearance(ocp, paths, body_clearances, measures)


def _integrated_clearance(ocp: OCP, paths: np.ndarray, clearances, measures: dict) -> dict:
    """``min_clearance_integrated`` (the bodies' least clearance, by ``clearances(ocp, states)``, along the
    one-step paths ``one_step`` integrated) into ``measures``; returns the check ``dense_clearance``."""
    dense = min(float(np.min(c)) for c in interval_clearances(ocp, paths, clearances).values())
    measures["min_clearance_integrated"] = dense
    return {"dense_clearance": _check(-min(dense, 0.0), DENSE_CLEARANCE_TOL)}


def _integrated_map_clearance(ocp: OCP, traj: dict[str, np.ndarray], measures: dict) -> dict:
    """On a map, the bodies' exact rectangles along each interval integrated from its node (``one_step``, the
    controls linear) within ``DENSE_CLEARANCE_TOL`` of the corridor, as on roads: a free step of the arclength
    grid can swing a body out between nodes that both lie inside (Thiergarten 51 -> 90, SU-30, once round the ring:
    0.165 m, where the linear sub-steps of ``body_clearance_dense`` saw +0.004 m)."""
    paths = one_step_columns(ocp, traj)
    if paths is None:
        return {"dense_clearance": _check(np.inf, DENSE_CLEARANCE_TOL, False)}
    return _integrated_clearance(ocp, paths, map_clearances, measures)


def _reintegration_drift(
    ocp: OCP, t: np.ndarray, X: np.ndarray, U: np.ndarray
) -> tuple[dict, dict[str, np.ndarray] | None]:
    """Integrate the piecewise-linear controls from X(0) with scipy; compare at the nodes.

    Interval by interval (the controls are smooth inside each), carrying the integrated
    state across nodes, so the drift accumulates as in one long integration. Also returns the
    dense path: t, states and controls at ``DENSE_STEPS`` + 1 points of each interval (the
    integrator's own dense output, which does not change its steps), or None if it failed.
    """
    from scipy.integrate import solve_ivp  # here, not at import: see model/nlp/imports.py

    v = ocp.vehicle
    fn = rhs_lambdified(ocp, "math")
    path = np.empty_like(X)
    path[:, 0] = X[:, 0]
    share = np.linspace(0.0, 1.0, DENSE_STEPS + 1)
    dense_t, dense_x, dense_u = [], [], []
    for k in range(len(t) - 1):
        t0, h, u0, du = t[k], t[k + 1] - t[k], U[:, k], U[:, k + 1] - U[:, k]

        def rhs(tt, x, t0=t0, h=h, u0=u0, du=du):
            return fn(*x, *(u0 + du * ((tt - t0) / h)))

        times = t0 + h * share
        sol = solve_ivp(rhs, (t0, t[k + 1]), path[:, k], rtol=1e-9, atol=1e-11, method="DOP853", t_eval=times)
        if not sol.success:
            return {"success": False, "message": sol.message}, None
        path[:, k + 1] = sol.y[:, -1]
        dense_t.append(times)
        dense_x.append(sol.y)
        dense_u.append(u0[:, None] + du[:, None] * share[None, :])
    err = np.abs(path - X)
    ix, iy = v.states.index(v.position[0]), v.states.index(v.position[1])
    pos = np.hypot(path[ix] - X[ix], path[iy] - X[iy])
    drift = {
        "success": True,
        "max_position_error": float(np.max(pos)),
        "final_position_error": float(pos[-1]),
        "max_state_error": {s: float(np.max(err[i])) for i, s in enumerate(v.states)},
        "final_state_error": {s: float(err[i, -1]) for i, s in enumerate(v.states)},
    }
    states, controls = np.concatenate(dense_x, axis=1), np.concatenate(dense_u, axis=1)
    dense = {"t": np.concatenate(dense_t)} | dict(zip(v.states, states, strict=True))
    return drift, dense | dict(zip(v.controls, controls, strict=True))
