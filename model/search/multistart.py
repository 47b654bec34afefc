"""Multi-start: every pass direction asked for, several cold starts each, the best validated answer.

Both objectives are nonconvex (local minima). By default the time objective tries
TIME_STARTS, a problem with an obstacle DETOUR_STARTS; each pass direction's model is
built once and solved from each start (``model.direct.solve_starts``). ``solve_ocp`` runs the
search's steps in order on one ``Search`` (``model.search.context``): screening or the cold
starts, the smooth routes, the road's own steps (``model.search.road``), continuation or a
diagnosis, the goal-accuracy refinement; with a time limit, each step once the budget is spent
is skipped and the best validated answer so far is returned, marked as such. With a time limit, on
a road whose steady turn at the outer curb cuts the inner edge (``model.search.road.cuts_inner_edge``:
the route's arc start has no forward steady turn to converge to; the WB-62 at ICD 45 m spent 30 s
of 120 on it for nothing), the geometry continuation runs first and the cold starts only if it
leaves no converged answer.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from model.analysis.columns import Columns
from model.direct.bodies import DEFAULT_FORMULATION, check_formulation
from model.direct.solution import Solution
from model.direct.solve import NOT_BELOW, paused_gc, solve_starts
from model.problem.ocp import OCP
from model.search.accuracy import GOAL_ACCURACY, grid_failures, refine_for_accuracy
from model.search.accuracy import ROUTE as ACCURACY_ROUTE
from model.search.bounds import refusal_from_bounds
from model.search.context import MIN_WALL_TIME, Reporter, Search, better, clearly_better, cold_starts, reporter
from model.search.curves import curve_routes, tf_scales
from model.search.diagnosis import bound_diagnosis, refined_diagnosis, solver_diagnosis, time_limit_diagnosis
from model.search.guess import reeds_shepp_start_path
from model.search.road import cuts_inner_edge, geometry_continuation, refused_with_evidence, road_steps
from model.search.screening import REFINE_OPTIONS, screen_starts, screening_intervals
from model.search.starts import passes_to_try, reeds_shepp_ends, resample, start_values

TIME_STARTS = ((1.0, "arc"), (1.5, "arc"), (2.0, "arc"))  # (scale of the Tf guess, route)
# on a road the route is fixed, and the Tf scales of its one path are fallbacks, not other manoeuvres:
# on the 12 routes of benchmarks/bench_road_suite.py x1, x1.5 and x2 reached the same optimum on 9,
# x1 failed on one (the semitrailer U-turn: x1.5 and x2 equal) and all three reversed on the other two
ROAD_TIME_STARTS = ((1.0, "arc"),)
ROAD_RUN_SHARE = 0.25  # with a time limit, no one Ipopt run on a road with bodies takes more than this share of it
ROAD_FINISH_SHARE = 0.2  # and the search's runs end this share of it early: analysis and files (~20 s at 120 s)
PROOF_SECONDS = 3.0  # the one start solved beside a proven bound, for the trajectory it reports
HOMOTOPY_MARGIN = 0.02  # no final-time homotopy where the least time found exceeds (1 + this) x Tf (docstring)
CURVE_MARGIN = 0.02  # a route's coarse optimum is refined if below (1 + this) x the objective so far
DETOUR_STARTS = ((1.0, "arc"), (1.0, "line"))
REEDS_SHEPP_STARTS = ((1.0, "reeds-shepp"), (1.0, "reeds-shepp-reverse-in"), (1.0, "reeds-shepp-reverse-out"))


def solve_ocp(
    ocp: OCP,
    intervals: int = 100,
    verbose: bool = False,
    options: dict | None = None,
    guess: Columns | None = None,
    starts: tuple[tuple[float, str], ...] | None = None,
    progress: Callable[[str], None] | None = None,
    continuation: bool = True,
    screen: bool | int | None = None,
    accuracy: float | None = GOAL_ACCURACY,
    search: str = "default",
    formulation: str = DEFAULT_FORMULATION,
    time_limit: float | None = None,
    clock: str = "wall",
) -> Solution:
    """Solve every pass direction asked for and keep the best validated solution.

    Parameters
    ----------
    ocp : the problem.
    intervals : N, the number of trapezoid steps.
    verbose : show Ipopt's iteration log.
    options : Ipopt options, e.g. ``{"mu_strategy": "adaptive"}``.
    guess : a trajectory (t, states, controls; e.g. ``other.trajectory``) to start from
        instead of the geometric guesses; it is resampled onto the new grid.
    starts : cold starts as (scale of the Tf guess, route "arc", "line" or "reeds-shepp").
    progress : called with one line of text after each start (e.g. ``print``).
    continuation : when no start validates, try a homotopy in the final time
        (``model.search.continuation``) before reporting a diagnosis.
    screen : screen the cold starts on a coarse grid and refine the best distinct optima at N
        (``model.search.screening``): None where N is large enough to pay, False never, an int
        for that coarse grid. If no refined solution validates, every start is solved at N.
    accuracy : goal tolerance of the re-integrated controls (``model.search.accuracy``): a
        solution that drifts further is solved again on 2N intervals; None never refines.
    search : "quick" (the first default start per pass direction), "default", or "thorough"
        (more Tf scales and both routes, every start screened on a coarse grid): time against
        thoroughness. Ignored where ``starts`` or ``guess`` is given.
    formulation : the bodies' NLP formulation on a road, one of ``model.direct.bodies.FORMULATIONS``
        (the second opinion and the failed-road step also try "corners").
    time_limit : seconds for the whole search (None: no limit). Each Ipopt run gets the time left
        as ``max_wall_time``; once it is spent the remaining steps are skipped and the best
        answer so far is returned, ``search`` (summary.json) saying so; if none validated, the
        ``diagnosis`` is the time limit's (what was tried, the solver's evidence).
    clock : what ``time_limit`` counts: "wall" seconds, or the process's "cpu" seconds (Ipopt's
        ``max_cpu_time``; a study's cells on shared cores get the same budget whatever the load).

    Returns
    -------
    Solution
        The best start: validated before unvalidated, then the lowest objective;
        ``attempts`` lists every start with its status and objective.
    """
    start = time.perf_counter()
    if time_limit is not None and not time_limit > 0:
        raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit!r}")
    tight = time_limit is not None and ocp.road is not None and bool(ocp.bodies)  # room for the geometry continuation
    ctx = Search(ocp, intervals, verbose, dict(options or {}), check_formulation(formulation), reporter(progress),
                 time_limit, clock=clock, run_cap=ROAD_RUN_SHARE * time_limit if tight else None,
                 reserve=ROAD_FINISH_SHARE * time_limit if tight else 0.0)  # fmt: skip
    proof = refusal_from_bounds(ocp) if guess is None and starts is None else None
    if proof is not None:
        refused = _refuse(ctx, proof)
        if not refused.ok:
            return _finish(ctx, refused, search, start)
    best = _search(ctx, guess, starts, screen, search)
    if not best.ok and best.diagnosis is None:
        best = _continue_or_diagnose(ctx, best, continuation)
    best = _accurate(ctx, best, accuracy)
    return _finish(ctx, best, search, start)


def _finish(ctx: Search, best: Solution, level: str, start: float) -> Solution:
    """The answer with the search's record: attempts, ``search``, timings (from ``start``, perf_counter); the
    time limit's diagnosis if due."""
    if not best.ok and best.diagnosis is None:  # the minimal-violation evidence computed on the way, if any
        best.diagnosis = dict(ctx.best_evidence() or {}) or None
    if ctx.stopped and not best.ok and (best.diagnosis or {}).get("kind") != "proven bound":  # a proof stands
        diagnosis = time_limit_diagnosis(best, ctx.attempts, ctx.record_of_search(level))
        if best.diagnosis:  # the evidence found before the limit, in the one line too
            diagnosis["message"] += f"; before the limit: {best.diagnosis['message']}"
        best.diagnosis = diagnosis | ({"before_the_limit": best.diagnosis} if best.diagnosis else {})
    if not best.ok and best.diagnosis is None:  # every failed answer says why
        best.diagnosis = solver_diagnosis(best)
    with paused_gc():  # the model may hold a later start's values
        best.nlp.load_primals(best.ipopt.x)
        best.nlp.load_duals(best.ipopt.mult_g, best.ipopt.x)
    best.attempts = ctx.attempts
    best.search = ctx.record_of_search(level)
    best.solve_seconds = time.perf_counter() - start
    best.timings = {**best.timings, "all_starts": phase_totals(ctx.solutions)}
    return best


def _refuse(ctx: Search, proof: dict) -> Solution:
    """A road problem a bound proves infeasible: one start, cut at ``PROOF_SECONDS``, for the trajectory to
    report beside the proof. Should that start validate anyway, the proof is wrong: said, and the search goes on."""
    ctx.progress(f"refused before the search: {proof['message']}")
    quick = Search(ctx.ocp, ctx.intervals, ctx.verbose, ctx.options, ctx.formulation, ctx.progress, PROOF_SECONDS,
                   clock=ctx.clock)  # fmt: skip
    first = search_starts(ctx.ocp, "quick")[:1]
    sol = cold_starts(quick, first, None, None)
    ctx.attempts.extend(quick.attempts)
    ctx.solutions.extend(quick.solutions)
    if sol.ok:
        ctx.progress("the start validated although a bound said infeasible: the bound is wrong; searching on")
        return sol
    sol.diagnosis = proof
    return sol


def _search(ctx: Search, guess: Columns | None, starts, screen, level: str) -> Solution:
    """Screening or the cold starts, the smooth routes, the road's steps: the best answer found."""
    curves = starts is None and guess is None  # the smooth routes join a search of the default starts
    if starts is None:
        starts = search_starts(ctx.ocp, level) if guess is None else ((1.0, "arc"),)
    if level == "thorough" and screen is None:
        screen = True
    coarse = screening_intervals(ctx.intervals, screen) if guess is None else None
    best = None
    early = curves and ctx.time_limit is not None and ctx.ocp.road is not None and cuts_inner_edge(ctx.ocp)
    if early:  # the arc start cannot be followed forwards: the budget goes to the continuation (module docstring)
        ctx.progress("the steady turn at the outer curb cuts the inner edge: continuation in the geometry first")
        best = geometry_continuation(ctx, None)
        if refused_with_evidence(best):  # the minimal violation on the scenario's road stands: the search ends
            ctx.progress(f"refused: {best.diagnosis['message']}")
            return best
        if best is not None and (best.ok or grid_failures(best)):
            return road_steps(ctx, best, curves, geometry=False)
    elif coarse is not None:
        best = _screen_and_refine(ctx, coarse, starts)
    if (best is None or not best.ok) and not (early and ctx.skip("cold starts", len(starts))):  # each cold start at N
        ctx.progress(f"cold starts on N = {ctx.intervals}: {len(starts)} per pass direction "
                     f"({', '.join(passes_to_try(ctx.ocp))})")  # fmt: skip
        best = cold_starts(ctx, starts, guess, best)
    if curves and level != "quick":
        best = _curve_search(ctx, best)
    return road_steps(ctx, best, curves, geometry=not early)


def _accurate(ctx: Search, best: Solution, accuracy: float | None) -> Solution:
    """The solution refined on finer grids until its re-integrated goal drift is within tolerance."""

    def solve(n, guess):
        if ctx.skip(f"N={n} {ACCURACY_ROUTE}", 1):
            return None
        same_bodies = getattr(guess.model, "body_formulation", ctx.formulation)
        sols = ctx.solve(n, guess.passing, [ctx.values(guess.passing, guess.columns, intervals=n)],
                         formulation=same_bodies)  # fmt: skip
        for sol in sols:
            ctx.record(sol, guess.passing, 1.0, f"N={n} {ACCURACY_ROUTE}")
        return sols[0] if sols else None

    sol, record = refine_for_accuracy(best, solve, accuracy, ctx.progress)
    if sol is not best and not sol.ok and sol.diagnosis is None:  # a finer grid's failed re-solve kept
        sol.diagnosis = refined_diagnosis(best, sol)
    sol.accuracy = record
    return sol


def _screen_and_refine(ctx: Search, coarse: int, starts, passes=None, within=None) -> Solution | None:
    """Screen the starts at ``coarse`` (in ``passes``, default ``passes_to_try``), refine the distinct
    optima at N (those below ``within``, if given; one build per pass); the best refined (or None)."""

    def make_starts(n, passing):
        return [(route, ctx.values(passing, None, scale, route, intervals=n)) for scale, route in starts]

    kept, screened = screen_starts(ctx, coarse, passes or passes_to_try(ctx.ocp), make_starts)
    kept = [k for k in kept if within is None or k.objective < within]
    ctx.attempts.extend(screened)
    ctx.progress(f"screening on N = {coarse}: {len(screened)} starts, {len(kept)} distinct optima to refine")
    best = None
    for passing in dict.fromkeys(k.passing for k in kept):
        values = [ctx.values(passing, k.columns) for k in kept if k.passing == passing]
        if ctx.skip(f"refinement at N={ctx.intervals} (pass {passing})", len(values)):
            continue
        for sol in _refine(ctx, passing, values):
            ctx.record(sol, passing, 1.0, f"refined from N={coarse}")
            if best is None or better(sol, best):
                best = sol
    return best


def _refine(ctx: Search, passing: str, values) -> list[Solution]:
    """Solve from coarse answers at N (one build); those that fail once more as cold starts."""
    sols = ctx.solve(ctx.intervals, passing, values, REFINE_OPTIONS, skip_worse=True)
    # the small barrier parameter presumes a good guess (an answer not below the best needs no second try)
    again = [i for i, sol in enumerate(sols) if not sol.ok and sol.validation.get("skipped") != NOT_BELOW]
    if again and not ctx.skip(f"refinement again as cold starts (pass {passing})", len(again)):
        for i, sol in zip(again, ctx.solve(ctx.intervals, passing, [values[i] for i in again]), strict=False):
            sols[i] = sol
    return sols


def _curve_search(ctx: Search, best: Solution | None) -> Solution | None:
    """The smooth routes of ``model.search.curves`` screened on a coarse grid; the distinct coarse optima
    below (1 + CURVE_MARGIN) x the answer so far (``best``) refined at N. No pass constraint unless the
    scenario asks for one. The better answer (``clearly_better``)."""
    ocp = ctx.ocp
    routes = curve_routes(ocp)
    if not routes:
        return best
    scales = tf_scales(ocp)  # one start per route where a given first guess of Tf makes the scales alike
    starts = [(k, route) for route in routes for k in scales]
    if ctx.skip("smooth routes", len(starts)):
        return best
    coarse = screening_intervals(ctx.intervals, True) or ctx.intervals
    passes = ["none"] if ocp.passing == "auto" or not ocp.obstacles else [ocp.passing]  # a pass asked for holds
    within = best.objective * (1 + CURVE_MARGIN) if best is not None and best.ok else None
    found = _screen_and_refine(ctx, coarse, starts, passes, within)
    return found if clearly_better(found, best) else best


def _continue_or_diagnose(ctx: Search, best: Solution, continuation: bool) -> Solution:
    """A proven bound ends the search; else a slowed-down minimum-time solution or a homotopy in Tf may
    find a solution; else the solver's evidence (with the least time found, if above Tf).

    The homotopy is not tried where the least time found is above (1 + ``HOMOTOPY_MARGIN``) x Tf: it would
    have to reach a Tf below a validated minimum time. On the 200 robustness scenarios of seed 0 the project
    solved none of the 54 energy problems whose Tf is below the peer's least time, and rob-s0-003 (Tf 2.513 s,
    least time 3.338 s) spent 50 of its 70 s in a homotopy stuck at 3.45 s.
    """
    from model.search.continuation import final_time_homotopy, slowed_minimum_time

    ocp = ctx.ocp
    proof = bound_diagnosis(ocp)
    least_time = None
    if proof is None and continuation:

        def solve(problem, guess=None):
            left = ctx.remaining()
            inner = solve_ocp(problem, ctx.intervals, ctx.verbose, ctx.options, guess=guess, continuation=False,
                              formulation=ctx.formulation, clock=ctx.clock,
                              time_limit=None if left is None else max(left, MIN_WALL_TIME))  # fmt: skip
            ctx.absorb(inner.search)
            return inner

        def budget():
            options = ctx.budget.run_options({})
            if options is None:
                ctx.stop()
            return options

        found, least_time = _attempt(ctx, "slowed minimum time", lambda: slowed_minimum_time(ocp, solve, ctx.progress))
        if found is not None and found.ok:
            return found
        if least_time is not None and least_time > (1 + HOMOTOPY_MARGIN) * ocp.final_time:
            ctx.progress(f"no final-time homotopy: the least time found, {least_time:.4g} s, is above Tf")
        else:
            homotopy = lambda: (final_time_homotopy(ocp, solve, ctx.progress, budget), None)  # noqa: E731
            found, _ = _attempt(ctx, "final-time homotopy", homotopy)
            if found is not None and found.ok:
                return found
    evidence = ctx.best_evidence()
    best.diagnosis = proof or (dict(evidence) if evidence else None) or solver_diagnosis(best)
    if least_time is not None and not proof:
        best.diagnosis["least_time_found_s"] = least_time
        best.diagnosis["message"] += f"; the least time found is {least_time:.4g} s > Tf = {ocp.final_time:g} s"
    return best


def _attempt(ctx: Search, route: str, attempt) -> tuple[Solution | None, float | None]:
    """Run one continuation ``route`` unless the search skips it; record it in ``ctx.attempts``.

    Returns the solution found (or None) and the least time the route found (None if it says none).
    """
    if ctx.skip(route):
        return None, None
    found, least = attempt()
    status, objective = (found.status, found.objective) if found else ("failed", None)
    ctx.attempts.append({"pass": "best", "route": route, "status": status,
                         "valid": bool(found and found.ok), "objective": objective})  # fmt: skip
    return found, least


def phase_totals(solutions: list[Solution]) -> dict[str, float]:
    """Seconds per phase summed over starts (a pass direction's build and setup counted once)."""
    totals = {"model_build": 0.0, "derivative_setup": 0.0, "ipopt": 0.0, "analysis": 0.0}
    seen_builds: set[int] = set()
    for sol in solutions:
        if id(sol.model) not in seen_builds:
            seen_builds.add(id(sol.model))
            totals["model_build"] += sol.timings.get("model_build", 0.0)
            totals["derivative_setup"] += sol.timings.get("derivative_setup", 0.0)
        totals["ipopt"] += sol.timings.get("ipopt", 0.0)
        totals["analysis"] += sol.timings.get("analysis", 0.0)
    return totals


def default_starts(ocp: OCP) -> tuple[tuple[float, str], ...]:
    """The cold starts ``solve_ocp`` tries per pass direction when none are given.

    Off the road, also the shortest Reeds-Shepp path (reversing where it pays) where it applies,
    and the shortest that reverses into the goal, and out of the start, where those differ from it.
    """
    if ocp.cost.free_final_time:
        starts = ROAD_TIME_STARTS if ocp.road is not None else TIME_STARTS
    else:
        starts = DETOUR_STARTS if ocp.obstacles else ((1.0, "arc"),)
    if ocp.road is None:
        starts += reeds_shepp_starts(ocp)
    return starts


def reeds_shepp_starts(ocp: OCP) -> tuple[tuple[float, str], ...]:
    """The Reeds-Shepp cold starts (``REEDS_SHEPP_STARTS``) that apply to a problem off the road.

    Each where its path exists (``model.search.guess.reeds_shepp_start_path``, which holds the rules). With
    longitudinal dynamics (``Vehicle.integrated_states``) that path is None where no word reverses into the goal
    (or out of the start; ``reeds_shepp`` returns the empty path there, a stand-still start that ran into Ipopt's
    3000 iterations, 57-60 s each, on the rest-to-rest truck of tests/test_longitudinal.py) and where the path
    reverses under v >= 0 (391-518 iterations to a local infeasibility); such a start drives within the limits
    (``model.search.paths.limited_path_guess``; docs/dynamics-format.md has the numbers). Without longitudinal
    dynamics the starts are as they were, the empty path included (the seed paper's searches unchanged).

    Returns
    -------
    tuple of (float, str)
        (scale of the Tf guess, route) of each start that applies, in ``REEDS_SHEPP_STARTS``' order.
    """
    paths = {start: reeds_shepp_start_path(ocp, reeds_shepp_ends(start)) for start in REEDS_SHEPP_STARTS}
    return tuple(start for start, path in paths.items() if path is not None)


SEARCHES = ("quick", "default", "thorough")


def search_starts(ocp: OCP, search: str = "default") -> tuple[tuple[float, str], ...]:
    """The cold starts of a search level (see ``solve_ocp``)."""
    if search not in SEARCHES:
        raise ValueError(f"search must be one of {', '.join(SEARCHES)}, got {search!r}")
    starts = default_starts(ocp)
    if search == "quick":
        return starts[:1]
    if search == "thorough":
        scales = (0.75, 1.0, 1.5, 2.0, 3.0) if ocp.cost.free_final_time else (1.0,)
        extra = tuple((k, r) for k in scales for r in ("arc", "line") if ocp.road is None or r == "arc")
        starts = tuple(dict.fromkeys(starts + extra))
    return starts


def solve_pass(
    ocp: OCP,
    intervals: int,
    passing: str,
    verbose: bool = False,
    options: dict | None = None,
    guess: Columns | None = None,
    tf_scale: float = 1.0,
    route: str = "arc",
) -> Solution:
    """One Ipopt solve with the guess and the constraint of one pass direction."""
    values = start_values(ocp, intervals, passing, guess, tf_scale, route)
    return solve_starts(ocp, intervals, passing, [values], verbose, options)[0]


__all__ = ["DETOUR_STARTS", "REEDS_SHEPP_STARTS", "TIME_STARTS", "Reporter", "default_starts", "passes_to_try",
           "reeds_shepp_starts", "resample", "solve_ocp", "solve_pass", "start_values"]  # fmt: skip
