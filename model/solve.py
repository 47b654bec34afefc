"""Solve an OCP: build, guess, Ipopt, costates, independent validation."""

from __future__ import annotations

import contextlib
import gc
import time

import numpy as np
import pandas as pd
import pyomo.environ as pyo
import sympy as sp

from model.casadi_nlp import CasadiNLP
from model.costates import costates, hamiltonian, obstacle_multiplier
from model.guess import guess_final_time, initial_guess
from model.ipopt import IpoptResult, run_ipopt
from model.ocp import OCP
from model.solution import Solution, trapezoid_energy
from model.transcription import build_model, grid
from model.validation import validate
from model.vehicles import sym

TIME_STARTS = ((1.0, "arc"), (1.5, "arc"), (2.0, "arc"))  # (scale of the Tf guess, route)
DETOUR_STARTS = ((1.0, "arc"), (1.0, "line"))


def passes_to_try(ocp: OCP) -> list[str]:
    """'auto' with an obstacle tries both directions; without one there is no pass."""
    if not ocp.obstacles:
        return ["none"]
    return ["ccw", "cw"] if ocp.passing == "auto" else [ocp.passing]


def solve_ocp(
    ocp: OCP,
    intervals: int = 100,
    verbose: bool = False,
    options: dict | None = None,
    guess: pd.DataFrame | None = None,
    starts: tuple[tuple[float, str], ...] | None = None,
    progress=None,
) -> Solution:
    """Solve every pass direction asked for and keep the best validated solution.

    ``guess``: a trajectory (t, states, controls; e.g. ``other.trajectory``) to start
    from instead of the geometric guess; it is resampled onto the new grid.
    ``starts``: cold starts (scale of the Tf guess, guess route "arc" or "line"). Both
    objectives are nonconvex (local minima): by default the time objective tries
    TIME_STARTS, a problem with an obstacle DETOUR_STARTS, and keeps the best.
    ``progress``: called with one line of text after each start (e.g. ``print``).
    """
    start = time.perf_counter()
    best: Solution | None = None
    attempts = []
    if starts is None:
        starts = _default_starts(ocp) if guess is None else ((1.0, "arc"),)
    for passing in passes_to_try(ocp):
        for (scale, route), sol in zip(
            starts, solve_starts(ocp, intervals, passing, starts, verbose, options, guess), strict=True
        ):
            attempts.append(
                {"pass": passing, "tf_guess_scale": scale, "route": route, "status": sol.status, "valid": sol.ok,
                 "objective": sol.objective}
            )  # fmt: skip
            if progress is not None:
                progress(
                    f"[{len(attempts)}] pass {passing}, start {route} x{scale:g}: {sol.status}, "
                    f"objective {sol.objective:.8g}, {sol.iterations} iterations, {sol.timings['ipopt']:.2f} s in Ipopt"
                )
            if best is None or _better(sol, best):
                best = sol
    best.nlp.load_primals(best.ipopt.x)  # the model may hold a later start's values
    best.nlp.load_duals(best.ipopt.mult_g, best.ipopt.x)
    best.attempts = attempts
    best.solve_seconds = time.perf_counter() - start
    return best


def _default_starts(ocp: OCP) -> tuple[tuple[float, str], ...]:
    if ocp.cost.free_final_time:
        return TIME_STARTS
    return DETOUR_STARTS if ocp.obstacles else ((1.0, "arc"),)


@contextlib.contextmanager
def paused_gc():
    """Suspend Python's cyclic garbage collector for a block (restores its state)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def _better(a: Solution, b: Solution) -> bool:
    if a.ok != b.ok:
        return a.ok
    return a.objective is not None and (b.objective is None or a.objective < b.objective)


def solve_pass(
    ocp: OCP,
    intervals: int,
    passing: str,
    verbose: bool = False,
    options: dict | None = None,
    guess: pd.DataFrame | None = None,
    tf_scale: float = 1.0,
    route: str = "arc",
) -> Solution:
    """One Ipopt solve with the guess and the constraint of one pass direction."""
    return solve_starts(ocp, intervals, passing, ((tf_scale, route),), verbose, options, guess)[0]


def solve_starts(
    ocp: OCP,
    intervals: int,
    passing: str,
    starts: tuple[tuple[float, str], ...],
    verbose: bool = False,
    options: dict | None = None,
    guess: pd.DataFrame | None = None,
) -> list[Solution]:
    """Build the model of one pass direction once; solve it from each start in turn."""
    t0 = time.perf_counter()
    with paused_gc():  # Pyomo creates many small objects: collections cost 3x the build
        m = build_model(ocp, intervals, passing)
    t1 = time.perf_counter()
    nlp, sols = None, []
    opts = {**({"print_level": 5} if verbose else {}), **(options or {})}
    for scale, route in starts:
        _load_start(ocp, m, intervals, passing, guess, scale, route)
        if nlp is None:
            t1 = time.perf_counter()
            with paused_gc():
                nlp = CasadiNLP(m)
            timings = {"model_build": t1 - t0, "derivative_setup": time.perf_counter() - t1}
        res = run_ipopt(nlp, opts, x0=nlp.init_primals())
        sols.append(finish(ocp, m, nlp, res, passing, timings))
    return sols


def _load_start(ocp: OCP, m: pyo.ConcreteModel, intervals: int, passing: str, guess, scale: float, route: str):
    """Put a start's node values (a given trajectory, or the geometric guess) into the model."""
    if guess is not None:
        tf_guess = float(ocp.final_time if not ocp.cost.free_final_time else guess["t"].iloc[-1])
        load_values(m, resample(ocp, guess, intervals))
    else:
        tf_guess = guess_final_time(ocp, passing) * (scale if ocp.cost.free_final_time else 1.0)
        load_values(m, initial_guess(ocp, passing, intervals, tf_guess, route))
    if ocp.cost.free_final_time:
        m.tf.set_value(tf_guess)


def finish(ocp: OCP, m: pyo.ConcreteModel, nlp: CasadiNLP, res: IpoptResult, passing: str, timings: dict) -> Solution:
    """Load Ipopt's answer into the model and make a validated, certified Solution."""
    nlp.load_primals(res.x)
    nlp.load_duals(res.mult_g, res.x)
    traj = trajectory(m, ocp)
    tf = float(pyo.value(m.tf))
    base = ["t", *ocp.vehicle.states, *ocp.vehicle.controls]
    sol = Solution(
        ocp=ocp,
        intervals=len(m.nodes) - 1,
        status=res.status,
        objective=float(pyo.value(m.objective)),
        final_time=tf,
        energy=trapezoid_energy(traj["t"].to_numpy(), [traj[c] for c in ocp.vehicle.controls]),
        iterations=res.iterations,
        solve_seconds=res.seconds,
        trajectory=traj,
        passing=passing,
        validation=validate(ocp, traj[base], tf, passing),
        solver_message=res.message,
        timings={**timings, "ipopt": res.seconds},
    )
    if sol.status == "optimal" and not sol.validation["passed"]:
        sol.status = "validation_failed"
    sol.model, sol.nlp, sol.ipopt = m, nlp, res
    sol.certificate = _certificate(sol)
    return sol


def _certificate(sol: Solution) -> dict:
    """The PMP certificate (a diagnostic): an error in it never fails a solve."""
    from model.certificate import certify

    try:
        return certify(sol)
    except Exception as exc:  # noqa: BLE001
        return {"passed": None, "error": f"{type(exc).__name__}: {exc}"}


def load_values(m: pyo.ConcreteModel, values: dict[str, np.ndarray]) -> None:
    """Set node values of the named Vars (a guess or a previous solution)."""
    for name, vals in values.items():
        var = m.component(name)
        for t, val in zip(m.nodes, vals, strict=True):
            var[t].set_value(float(val), skip_validation=True)


def resample(ocp: OCP, traj: pd.DataFrame, intervals: int) -> dict[str, np.ndarray]:
    """A trajectory's states and controls on a uniform grid of ``intervals`` steps (normalised time)."""
    s_old = traj["t"].to_numpy() / traj["t"].iloc[-1]
    s_new = np.linspace(0.0, 1.0, intervals + 1)
    names = ocp.vehicle.states + ocp.vehicle.controls
    return {n: np.interp(s_new, s_old, traj[n].to_numpy()) for n in names}


def trajectory(m: pyo.ConcreteModel, ocp: OCP) -> pd.DataFrame:
    """Nodes as a DataFrame: t, states, controls, then costates, mu, H, switching functions."""
    v = ocp.vehicle
    cols: dict[str, np.ndarray] = {"t": np.array(grid(m))}
    for name in v.states + v.controls:
        var = m.component(name)
        cols[name] = np.array([pyo.value(var[t]) for t in m.nodes], dtype=float)
    cols.update(costates(m, ocp))
    px, py = v.position
    cols["mu"] = obstacle_multiplier(m, ocp, (cols[px], cols[py]))
    cols["H"] = hamiltonian(ocp, cols)
    cols.update(switching_functions(ocp, cols))
    return pd.DataFrame(cols)


def switching_functions(ocp: OCP, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """psi_<u> = d(p.f)/du: the switching function (time) or unconstrained maximiser (energy)."""
    v = ocp.vehicle
    params = {sym(k): val for k, val in v.parameters().items()}
    pf = sum(sym(f"p_{s}") * f.subs(params) for s, f in zip(v.states, v.rhs(numeric=False), strict=True))
    names = list(v.states) + list(v.controls) + [f"p_{s}" for s in v.states]
    out = {}
    for c in v.controls:
        fn = sp.lambdify([sym(n) for n in names], sp.diff(pf, sym(c)), "numpy")
        val = fn(*[values[n] for n in names])
        out[f"psi_{c}"] = np.broadcast_to(val, values["t"].shape).astype(float)
    return out
