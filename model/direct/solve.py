"""One direct solve: build the trapezoid model of a pass direction, run Ipopt from given starts.

Each answer becomes a Solution: its node trajectory with costates, mu, H and the
switching functions (from the engine's one numeric form, ``derivations.functions``),
validated independently of the solver and carrying a PMP certificate.
"""

from __future__ import annotations

import contextlib
import gc
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pyomo.environ as pyo

from derivations.functions import pmp_functions
from model.analysis.certificate import certify
from model.analysis.validation import validate
from model.direct.bodies import DEFAULT_FORMULATION
from model.direct.costates import costates, obstacle_multiplier, path_multipliers
from model.direct.moving import fill_moving, note_settling, solve_moving
from model.direct.solution import Solution
from model.direct.transcription import PASS_BOUNDS, build_model, grid, set_pass_direction
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import IpoptResult
from model.problem.costs import Energy
from model.problem.ocp import OCP

# What a solve is doing, as DEBUG records on "roundabout.solve": the command line's progress
# names the current one when it has printed nothing for a while.
LOG = logging.getLogger("roundabout.solve")


@dataclass
class Start:
    """Node values of states and controls (arrays of N + 1) and, for a free Tf, its guess; ``times``: the
    node times (N + 1, from 0), the steps of a free grid (``TranscriptionOptions.free_grid``)."""

    values: dict[str, np.ndarray]
    final_time: float | None = None
    times: np.ndarray | None = None


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


def solve_starts(
    ocp: OCP,
    intervals: int,
    passing: str,
    starts: Sequence[Start],
    verbose: bool = False,
    options: dict | None = None,
    relax: bool = False,
    analyse: bool = True,
    formulation: str = DEFAULT_FORMULATION,
    deadline: float | None = None,
    first_wall_time: float | None = None,
    clock: str = "wall",
    analyse_below: float | None = None,
    models: dict | None = None,
) -> list[Solution]:
    """Build the model of one pass direction once; solve it from each start in turn.

    ``relax``: solve the minimal-violation model instead (``build_model(..., relax=True)``).
    ``analyse=False``: skip validation and certificate (a screening solve, used only as a guess).
    ``formulation``: the bodies' formulation on a road (``model.direct.bodies.FORMULATIONS``).
    ``deadline``: a ``time.monotonic()`` instant; each Ipopt run gets the time left as
    ``max_wall_time`` and the starts not begun by then are left out (the list is shorter; empty,
    and no model built, if the deadline has passed already). ``first_wall_time``: the first start
    runs in any case, for at least these seconds. ``clock``: "wall" (the default), or "cpu": ``deadline``
    is a ``time.process_time()`` instant and each run gets Ipopt's ``max_cpu_time`` instead (``CLOCKS``).
    ``analyse_below``: the objective of a validated answer on this grid (inf: none yet; None: analyse
    every start): a start whose converged run does not end below it, or below a validated answer of an
    earlier start of this call, is not analysed (``finish``'s ``worse_than``).
    ``models``: built models and their NLPs by (problem, N, pass, relax, formulation), read and filled here: a
    model built by an earlier call is solved again from the new starts (a search's steps share it).
    """
    if first_wall_time is None and expired(deadline, clock):
        return []
    t0 = time.perf_counter()
    # Pyomo creates many small objects: with the collector on, its full collections over the
    # model cost 3x the build and seconds in loading the duals of a large road model
    kind = "minimal-violation model" if relax else "model"
    LOG.debug("building the N = %d %s (pass %s)", intervals, kind, passing)
    # the two pass directions share a model: their rows differ only in the swept angle's bounds
    key = (id(ocp), intervals, "ccw|cw" if passing in PASS_BOUNDS else passing, relax, formulation)
    with paused_gc():
        owner, m, nlp, built = (models or {}).get(key, (None, None, None, None))
        if owner is not ocp:
            m, nlp = build_model(ocp, intervals, passing, relax, formulation), None
            built = [v.value for v in m.component_data_objects(pyo.Var)]
        else:  # as built: the values a start does not set (auxiliaries, slacks) are not the last run's
            for var, value in zip(m.component_data_objects(pyo.Var), built, strict=True):
                var.set_value(value, skip_validation=True)
            if hasattr(m, "pass_direction"):
                set_pass_direction(m, passing)
                nlp.refresh_parameters()
        sols, timings = [], {}
        opts = {**({"print_level": 5} if verbose else {}), **(options or {})}
        for i, start in enumerate(starts, 1):
            budget = wall_time_options(opts, deadline, first_wall_time if i == 1 else None, clock)
            if budget is None:
                LOG.debug("the time limit is reached: %d of %d starts left out", len(starts) - i + 1, len(starts))
                break
            LOG.debug("solving the N = %d %s (pass %s) from start %d of %d", intervals, kind, passing, i, len(starts))
            load_start(m, start)
            fill_moving(m, ocp)  # the moving obstacles at this start's node times
            if nlp is None:
                t1 = time.perf_counter()
                nlp = CasadiNLP(m)
                timings = {"model_build": t1 - t0, "derivative_setup": time.perf_counter() - t1}
            res, settling = solve_moving(m, ocp, nlp, budget)  # run_ipopt; with moving obstacles to the Tf fixed point
            sols.append(finish(ocp, m, nlp, res, passing, timings, analyse, analyse_below))
            note_settling(sols[-1], settling)
            if analyse_below is not None and sols[-1].ok:
                analyse_below = min(analyse_below, sols[-1].objective)
    if models is not None and nlp is not None:
        models[key] = (ocp, m, nlp, built)
    return sols


CLOCKS = {"wall": (time.monotonic, "max_wall_time"), "cpu": (time.process_time, "max_cpu_time")}
"""A time limit's clock: the function its deadline is an instant of, and the Ipopt option that bounds a run."""


def time_left(deadline: float | None, clock: str = "wall") -> float | None:
    """Seconds of ``clock`` (``CLOCKS``) left until ``deadline``, an instant of that clock (negative once past;
    None: no deadline)."""
    return None if deadline is None else deadline - CLOCKS[clock][0]()


def expired(deadline: float | None, clock: str = "wall") -> bool:
    """Whether ``deadline``, an instant of ``clock`` (``CLOCKS``), has passed (never without a deadline).

    The one expiry test: ``solve_starts``, ``model.direct.map_corridor.solve_map`` and the searches' ``Budget``
    (``model.search.budget``) all ask it."""
    left = time_left(deadline, clock)
    return left is not None and left <= 0.0


def wall_time_options(options: dict, deadline: float | None, floor: float | None = None,
                      clock: str = "wall") -> dict | None:  # fmt: skip
    """``options`` with ``max_wall_time`` (``clock`` "cpu": ``max_cpu_time``) at most the seconds left until
    ``deadline`` (but at least ``floor``, if given); None if none are left.

    The one time budget of an Ipopt run: the roundabout search's starts (``solve_starts``) and the map search's
    strip solves (``model.direct.map_corridor.solve_map``, with its ``floor``) both take it from here."""
    left = time_left(deadline, clock)
    if left is None:
        return options
    if floor is not None:
        left = max(left, floor)
    if left <= 0.0:
        return None
    key = CLOCKS[clock][1]
    return {**options, key: min(left, float(options.get(key, left)))}


def load_start(m: pyo.ConcreteModel, start: Start) -> None:
    """Put a start's node values (and Tf guess, if Tf is free) into the model."""
    load_values(m, start.values)
    if start.final_time is not None and m.tf.is_variable_type():
        m.tf.set_value(start.final_time)
    step = getattr(m, "step", None)
    if step is not None:  # a free grid: the start's steps, or equal steps of its Tf
        n = len(step)
        steps = np.diff(start.times) if start.times is not None else np.full(n, (start.final_time or n) / n)
        for k, value in zip(step, steps, strict=True):
            step[k].set_value(max(float(value), step[k].lb), skip_validation=True)
    for var, expression in getattr(m, "derived_values", []):  # auxiliary variables follow the start
        for t in m.nodes:
            var[t].set_value(float(pyo.value(expression(t))), skip_validation=True)


NOT_BELOW = "not below the best validated answer"
"""The ``skipped`` reason of a start not analysed because a validated answer was as good (``finish``)."""


def finish(
    ocp: OCP, m: pyo.ConcreteModel, nlp: CasadiNLP, res: IpoptResult, passing: str, timings: dict,
    analyse: bool = True, worse_than: float | None = None,
) -> Solution:  # fmt: skip
    """Load Ipopt's answer into the model and make a validated, certified Solution.

    Without ``analyse`` the node columns are states and controls only, nothing is validated
    (``ok`` is False) and there is no certificate: a screening answer, a guess for a refinement.
    The same, skipped as "not below the best validated answer", where the objective is not below
    ``worse_than`` (a validated answer's) after a converged run: it could not become the answer, so its
    analysis buys nothing.
    """
    t0 = time.perf_counter()
    nlp.load_primals(res.x)
    skipped = "screening"
    converged = res.status in ("optimal", "acceptable")  # a failed run keeps its analysis: its diagnosis
    if analyse and converged and worse_than is not None and not float(pyo.value(m.objective)) < worse_than:
        analyse, skipped = False, NOT_BELOW
    if analyse:  # a screening answer is only a guess: its duals are never read
        nlp.load_duals(res.mult_g, res.x)
    cols = node_columns(m, ocp) if analyse else primal_columns(m, ocp)
    adjoined = None
    if analyse:  # the path constraints' multipliers (roads, bounded outputs) and their gradients
        path, adjoined = path_multipliers(m, nlp, ocp, res.x)
        cols = _after(cols, "mu", path)
    tf = float(pyo.value(m.tf))
    sol = Solution(
        ocp=ocp,
        intervals=len(m.nodes) - 1,
        status=res.status,
        objective=float(pyo.value(m.objective)),
        final_time=tf,
        energy=Energy().integral(cols, ocp.vehicle.controls),  # unit weights: summary.json's plain energy
        iterations=res.iterations,
        solve_seconds=res.seconds,
        columns=cols,
        passing=passing,
        validation=(validate(ocp, cols, tf, passing, hasattr(m, "step")) if analyse
                    else {"passed": None, "skipped": skipped}),  # fmt: skip
        solver_message=res.message,
        timings={**timings, "ipopt": res.seconds},
    )
    if analyse and sol.status == "optimal" and not sol.validation["passed"]:
        sol.status = "validation_failed"
    sol.model, sol.nlp, sol.ipopt, sol.adjoined = m, nlp, res, adjoined
    sol.certificate = _certificate(sol) if analyse else {"passed": None, "skipped": skipped}
    sol.timings["analysis"] = time.perf_counter() - t0
    return sol


def _after(cols: dict, name: str, extra: dict) -> dict:
    """``cols`` with the columns ``extra`` inserted after the column ``name``."""
    out = {}
    for key, val in cols.items():
        out[key] = val
        if key == name:
            out.update(extra)
    return out


def _certificate(sol: Solution) -> dict:
    """The PMP certificate (a diagnostic): an error in it never fails a solve."""
    if getattr(sol.model, "slack_total", None) is not None:
        reason = "the minimal-violation problem (the sum of the bodies' slacks) is not the scenario's control problem"
        return {"passed": None, "status": "not applicable", "reason": reason}
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


def primal_columns(m: pyo.ConcreteModel, ocp: OCP) -> dict[str, np.ndarray]:
    """Node arrays: t, states, controls."""
    v = ocp.vehicle
    cols: dict[str, np.ndarray] = {"t": np.array(grid(m))}
    for name in v.states + v.controls:
        var = m.component(name)
        cols[name] = np.array([pyo.value(var[t]) for t in m.nodes], dtype=float)
    return cols


def node_columns(m: pyo.ConcreteModel, ocp: OCP) -> dict[str, np.ndarray]:
    """Node arrays: t, states, controls, then costates, mu, H, switching functions."""
    v = ocp.vehicle
    cols = primal_columns(m, ocp)
    cols.update(costates(m, ocp))
    px, py = v.position
    cols["mu"] = obstacle_multiplier(m, ocp, (cols[px], cols[py]))
    derived = pmp_functions(ocp).evaluate(cols)
    cols["H"] = derived["H"]
    cols.update({f"psi_{c}": derived[f"psi_{c}"] for c in v.controls})
    return cols


__all__ = [
    "CLOCKS",
    "Start",
    "expired",
    "finish",
    "load_start",
    "load_values",
    "node_columns",
    "paused_gc",
    "primal_columns",
    "solve_starts",
    "time_left",
    "wall_time_options",
]
