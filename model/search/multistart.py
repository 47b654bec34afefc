"""Multi-start: every pass direction asked for, several cold starts each, the best validated answer.

Both objectives are nonconvex (local minima). By default the time objective tries
TIME_STARTS, a problem with an obstacle DETOUR_STARTS; each pass direction's model is
built once and solved from each start (``model.direct.solve_starts``).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from model.analysis.columns import Columns, as_arrays
from model.direct import bodies
from model.direct.solution import Solution
from model.direct.solve import Start, paused_gc, solve_starts
from model.problem.ocp import OCP
from model.search.accuracy import GOAL_ACCURACY, refine_for_accuracy
from model.search.accuracy import ROUTE as ACCURACY_ROUTE
from model.search.curves import curve_guess, curve_routes
from model.search.guess import guess_final_time, initial_guess, reeds_shepp_guess, reeds_shepp_start_path
from model.search.road_polish import reverses, second_opinion
from model.search.screening import REFINE_OPTIONS, screen_starts, screening_intervals

TIME_STARTS = ((1.0, "arc"), (1.5, "arc"), (2.0, "arc"))  # (scale of the Tf guess, route)
# on a road the route is fixed, and the Tf scales of its one path are fallbacks, not other manoeuvres:
# on the 12 routes of benchmarks/bench_road_suite.py x1, x1.5 and x2 reached the same optimum on 9,
# x1 failed on one (the semitrailer U-turn: x1.5 and x2 equal) and all three reversed on the other two
ROAD_TIME_STARTS = ((1.0, "arc"),)
ROAD_FALLBACK_STARTS = ((2.0, "arc"),)  # tried where the first fails
CURVE_TF_SCALES = (1.0, 2.0)  # Tf guesses of a smooth route's start (free final time)
CURVE_MARGIN = 0.02  # a route's coarse optimum is refined if below (1 + this) x the objective so far
SAME_OPTIMUM = 1e-6  # relative: a route's answer replaces the default starts' only if better by more
DETOUR_STARTS = ((1.0, "arc"), (1.0, "line"))
REEDS_SHEPP_STARTS = ((1.0, "reeds-shepp"), (1.0, "reeds-shepp-reverse-in"), (1.0, "reeds-shepp-reverse-out"))


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
    guess: Columns | None = None,
    starts: tuple[tuple[float, str], ...] | None = None,
    progress: Callable[[str], None] | None = None,
    continuation: bool = True,
    screen: bool | int | None = None,
    accuracy: float | None = GOAL_ACCURACY,
    search: str = "default",
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

    Returns
    -------
    Solution
        The best start: validated before unvalidated, then the lowest objective;
        ``attempts`` lists every start with its status and objective.
    """
    start = time.perf_counter()
    progress = progress if isinstance(progress, Reporter) else Reporter(progress)
    curves = starts is None and guess is None  # the smooth routes join a search of the default starts
    if starts is None:
        starts = search_starts(ocp, search) if guess is None else ((1.0, "arc"),)
    if search == "thorough" and screen is None:
        screen = True
    attempts: list[dict] = []
    solutions: list[Solution] = []
    coarse = screening_intervals(intervals, screen) if guess is None else None
    best = None
    if coarse is not None:
        best = _screen_and_refine(ocp, intervals, coarse, starts, verbose, options, attempts, solutions, progress)
    if best is None or not best.ok:  # no screening, or nothing refined validated: every cold start at N
        progress(f"cold starts on N = {intervals}: {len(starts)} per pass direction ({', '.join(passes_to_try(ocp))})")
        best = _cold_starts(ocp, intervals, starts, guess, verbose, options, attempts, solutions, progress, best)
    if curves and search != "quick":
        best = _curve_search(ocp, intervals, best, verbose, options, attempts, solutions, progress)
    if not best.ok and ocp.road is not None and curves and ocp.cost.free_final_time:
        progress("no start validated: the road's fallback starts")
        best = _cold_starts(ocp, intervals, ROAD_FALLBACK_STARTS, None, verbose, options, attempts, solutions,
                            progress, best)  # fmt: skip
    if best.ok and ocp.road is not None and ocp.bodies and reverses(best) and bodies.FORMULATION != "corners":
        progress("the answer reverses: a second opinion from the arc start with the rectangles' corners")
        for sol in second_opinion(ocp, intervals, lambda cols: start_values(ocp, intervals, "none", cols), options):
            _record(attempts, solutions, progress, sol, "none", 1.0, f"second opinion ({sol.model.body_formulation})")
            if _clearly_better(sol, best):
                best = sol
    if not best.ok and ocp.road is not None and ocp.bodies:
        from model.search.diagnosis import failed_road, finite

        guess_from = best.columns if finite(best.columns) else None
        progress("no start validated: the corners formulation, then a minimal-violation diagnosis")
        best = failed_road(ocp, intervals, best, start_values(ocp, intervals, "none", guess_from), options)
        route = (best.diagnosis or {}).get("via", "minimal violation")
        attempts.append({"pass": "none", "route": route, "status": best.status, "valid": best.ok,
                         "objective": best.objective})  # fmt: skip
    elif not best.ok:
        best = _continue_or_diagnose(ocp, intervals, best, attempts, verbose, options, progress, continuation)
    best = _accurate(ocp, best, attempts, verbose, options, progress, accuracy)
    with paused_gc():  # the model may hold a later start's values
        best.nlp.load_primals(best.ipopt.x)
        best.nlp.load_duals(best.ipopt.mult_g, best.ipopt.x)
    best.attempts = attempts
    best.solve_seconds = time.perf_counter() - start
    best.timings = {**best.timings, "all_starts": phase_totals(solutions)}
    return best


def _accurate(ocp, best, attempts, verbose, options, progress, accuracy) -> Solution:
    """The solution refined on finer grids until its re-integrated goal drift is within tolerance."""

    def solve(n, guess):
        with bodies.use_formulation(getattr(guess.model, "body_formulation", bodies.FORMULATION)):  # same bodies
            sol = solve_starts(ocp, n, guess.passing, [start_values(ocp, n, guess.passing, guess.columns)], verbose,
                               options)[0]  # fmt: skip
        _record(attempts, [], progress, sol, guess.passing, 1.0, f"N={n} {ACCURACY_ROUTE}")
        return sol

    sol, record = refine_for_accuracy(best, solve, accuracy, progress)
    sol.accuracy = record
    return sol


class Reporter:
    """The search's progress: phase lines as given, start lines numbered as they are printed."""

    def __init__(self, sink: Callable[[str], None] | None) -> None:
        self.sink, self.count = sink, 0

    def __call__(self, line: str) -> None:
        if self.sink is not None:
            self.sink(line)

    def start(self, sol: Solution, passing: str, scale, route: str) -> None:
        """One line for a solved start: its number, pass, route, and its outcome."""
        self.count += 1
        outcome = (f"objective {sol.objective:.8g}" + ("" if sol.ok else " (not validated)")
                   if sol.status in ("optimal", "acceptable") else "no answer")  # fmt: skip
        self(f"[{self.count}] pass {passing}, start {route} x{scale:g}: {sol.status}, {outcome}, "
             f"{sol.iterations} iterations, {sol.timings['ipopt']:.2f} s in Ipopt")  # fmt: skip


def _record(attempts, solutions, progress: Reporter, sol: Solution, passing: str, scale, route: str) -> None:
    attempts.append({"pass": passing, "tf_guess_scale": scale, "route": route, "status": sol.status,
                     "valid": sol.ok, "objective": sol.objective})  # fmt: skip
    solutions.append(sol)
    progress.start(sol, passing, scale, route)


def _cold_starts(ocp, intervals, starts, guess, verbose, options, attempts, solutions, progress, best):
    """Every start of every pass direction at N; the best so far (``best`` may be None)."""
    for passing in passes_to_try(ocp):
        values = [start_values(ocp, intervals, passing, guess, scale, route) for scale, route in starts]
        for (scale, route), sol in zip(starts, solve_starts(ocp, intervals, passing, values, verbose, options),
                                       strict=True):  # fmt: skip
            _record(attempts, solutions, progress, sol, passing, scale, route)
            if best is None or _better(sol, best):
                best = sol
    return best


def _screen_and_refine(ocp, intervals, coarse, starts, verbose, options, attempts, solutions, progress,
                       passes=None, within=None):  # fmt: skip
    """Screen the starts at ``coarse`` (in ``passes``, default ``passes_to_try``), refine the distinct
    optima at N (those below ``within``, if given; one build per pass); the best refined (or None)."""

    def make_starts(n, passing):
        return [(route, start_values(ocp, n, passing, None, scale, route)) for scale, route in starts]

    kept, screened, coarse_sols = screen_starts(ocp, coarse, passes or passes_to_try(ocp), make_starts, options)
    kept = [k for k in kept if within is None or k.objective < within]
    attempts.extend(screened)
    solutions.extend(coarse_sols)
    if progress is not None:
        progress(f"screening on N = {coarse}: {len(screened)} starts, {len(kept)} distinct optima to refine")
    best = None
    for passing in dict.fromkeys(k.passing for k in kept):
        values = [start_values(ocp, intervals, passing, k.columns) for k in kept if k.passing == passing]
        for sol in _refine(ocp, intervals, passing, values, verbose, options):
            _record(attempts, solutions, progress, sol, passing, 1.0, f"refined from N={coarse}")
            if best is None or _better(sol, best):
                best = sol
    return best


def _refine(ocp, intervals, passing, values, verbose, options) -> list[Solution]:
    """Solve from coarse answers at N (one build); those that fail once more as cold starts."""
    sols = solve_starts(ocp, intervals, passing, values, verbose, {**REFINE_OPTIONS, **(options or {})})
    again = [i for i, sol in enumerate(sols) if not sol.ok]  # the small barrier parameter presumes a good guess
    if again:
        for i, sol in zip(again, solve_starts(ocp, intervals, passing, [values[i] for i in again], verbose, options),
                          strict=True):  # fmt: skip
            sols[i] = sol
    return sols


def _curve_search(ocp, intervals, best, verbose, options, attempts, solutions, progress) -> Solution | None:
    """The smooth routes of ``model.search.curves`` screened on a coarse grid; the distinct coarse optima
    below (1 + CURVE_MARGIN) x the answer so far (``best``) refined at N. No pass constraint unless the
    scenario asks for one. The better answer (``_clearly_better``)."""
    routes = curve_routes(ocp)
    if not routes:
        return best
    scales = CURVE_TF_SCALES if ocp.cost.free_final_time else (1.0,)
    starts = [(k, route) for route in routes for k in scales]
    coarse = screening_intervals(intervals, True) or intervals
    passes = ["none"] if ocp.passing == "auto" or not ocp.obstacles else [ocp.passing]  # a pass asked for holds
    within = best.objective * (1 + CURVE_MARGIN) if best is not None and best.ok else None
    found = _screen_and_refine(ocp, intervals, coarse, starts, verbose, options, attempts, solutions, progress,
                               passes, within)  # fmt: skip
    return found if _clearly_better(found, best) else best


def _clearly_better(sol: Solution | None, best: Solution | None) -> bool:
    """``sol`` replaces ``best``: better (``_better``), and by more than SAME_OPTIMUM where both validate
    (the same optimum found again leaves the earlier answer standing)."""
    if sol is None:
        return False
    if best is None:
        return True
    if not _better(sol, best):
        return False
    return not (best.ok and sol.objective > best.objective * (1 - SAME_OPTIMUM))


def _continue_or_diagnose(ocp, intervals, best, attempts, verbose, options, progress, continuation) -> Solution:
    """A proven bound ends the search; else a slowed-down minimum-time solution or a homotopy in Tf may
    find a solution; else the solver's evidence (with the least time found, if above Tf)."""
    from model.search.continuation import final_time_homotopy, slowed_minimum_time
    from model.search.diagnosis import bound_diagnosis, solver_diagnosis

    proof = bound_diagnosis(ocp)
    least_time = None
    if proof is None and continuation:

        def solve(problem, guess=None):
            return solve_ocp(problem, intervals, verbose, options, guess=guess, continuation=False)

        attempts_to_make = (
            ("slowed minimum time", lambda: slowed_minimum_time(ocp, solve, progress)),
            ("final-time homotopy", lambda: (final_time_homotopy(ocp, solve, progress), None)),
        )
        for route, attempt in attempts_to_make:
            found, least = attempt()
            least_time = least_time if least is None else least
            status, objective = (found.status, found.objective) if found else ("failed", None)
            attempts.append({"pass": "best", "route": route, "status": status,
                             "valid": bool(found and found.ok), "objective": objective})  # fmt: skip
            if found is not None and found.ok:
                return found
    best.diagnosis = proof or solver_diagnosis(best)
    if least_time is not None and not proof:
        best.diagnosis["least_time_found_s"] = least_time
        best.diagnosis["message"] += f"; the least time found is {least_time:.4g} s > Tf = {ocp.final_time:g} s"
    return best


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
        starts += tuple(start for start in REEDS_SHEPP_STARTS if reeds_shepp_start_path(ocp, _ends(start)))
    return starts


def _ends(start: tuple[float, str]) -> str | None:
    """The Reeds-Shepp filter of a start's route ("reeds-shepp-reverse-in" -> "reverse-in")."""
    return start[1].removeprefix("reeds-shepp-") if start[1].startswith("reeds-shepp-") else None


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
    guess: Columns | None = None,
    tf_scale: float = 1.0,
    route: str = "arc",
) -> Solution:
    """One Ipopt solve with the guess and the constraint of one pass direction."""
    values = start_values(ocp, intervals, passing, guess, tf_scale, route)
    return solve_starts(ocp, intervals, passing, [values], verbose, options)[0]


def start_values(
    ocp: OCP, intervals: int, passing: str, guess: Columns | None, scale: float = 1.0, route: str = "arc"
) -> Start:
    """A start's node values: a given trajectory resampled, or the geometric guess of ``route``."""
    free = ocp.cost.free_final_time
    if guess is not None:
        return Start(resample(ocp, guess, intervals), float(np.asarray(guess["t"])[-1]) if free else None)
    if route.startswith("reeds-shepp"):
        values, tf = reeds_shepp_guess(ocp, intervals, scale, _ends((scale, route)))
        return Start(values, tf if free else None)
    if route not in ("arc", "line"):
        values, tf = curve_guess(ocp, curve_routes(ocp)[route], intervals, scale)
        return Start(values, tf if free else None)
    tf_guess = guess_final_time(ocp, passing) * (scale if free else 1.0)
    return Start(initial_guess(ocp, passing, intervals, tf_guess, route), tf_guess if free else None)


def resample(ocp: OCP, traj: Columns, intervals: int) -> dict[str, np.ndarray]:
    """A trajectory's states and controls on a uniform grid of ``intervals`` steps (normalised time)."""
    cols = as_arrays(traj)
    s_old = cols["t"] / cols["t"][-1]
    s_new = np.linspace(0.0, 1.0, intervals + 1)
    names = ocp.vehicle.states + ocp.vehicle.controls
    return {n: np.interp(s_new, s_old, cols[n]) for n in names}


__all__ = ["DETOUR_STARTS", "TIME_STARTS", "default_starts", "passes_to_try", "resample", "solve_ocp", "solve_pass",
           "start_values"]  # fmt: skip
