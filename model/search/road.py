"""The road's own steps of the search, after the cold starts and the smooth routes: one call from ``solve_ocp``.

1. **Fallback starts.** On a road the route is fixed and the default starts are one path's Tf
   scales; where none validates (free final time), ``ROAD_FALLBACK_STARTS`` are tried.
2. **Second opinion.** The route runs forwards from the entry lane to the exit lane. Where the
   discs' cold starts end in an answer that reverses (an SU-30 U-turn: reversing away from the
   roundabout, waiting, driving round, reversing into the goal: 49-54 s where a forward U-turn
   takes 15.8 s), the arc start is solved with the rectangles' corners in the corridor
   (formulation "corners"), and the search's formulation again from that answer; the better
   validated answer is kept.
3. **Failed road.** When no start validates a road problem with bodies: the same start with the
   corners (less conservative than the discs, it passes lanes the discs cannot); then the body
   constraints get slacks and their sum is minimised (``build_model(..., relax=True)``), started
   from the best failed attempt. If that reaches zero violation a trajectory exists: the problem
   is solved again from it. Otherwise ``model.search.diagnosis.road_diagnosis`` names the body,
   the edge and the metres that must give way.

0. **Geometry continuation** (with a time limit first, before step 1; without one after step 1,
   so the searches without a budget keep their answers). A road problem with bodies that no start
   validated is solved on a relaxed road shrunk to its own in steps
   (``model.search.geometry_continuation``): the first step from the failed start's last iterate
   where it is finite (on the roomier road it is nearly feasible), else from the arc start and, for a
   U-turn, a forward-reverse-forward start (``model.search.guess.three_point_guess``). The step on
   the scenario's own road uses the rectangles' corners (on the EU annulus they converge in 90
   iterations where the discs take 187), from the arc start and then from the last step's answer,
   and the search's formulation from that answer if both fail.

Each step is skipped once the search's time limit has passed (``Search.skip``).
"""

from __future__ import annotations

import dataclasses

import pyomo.environ as pyo

from model.direct.solution import Solution
from model.direct.solve import Start
from model.search.accuracy import grid_failures
from model.search.context import Search, better, clearly_better, cold_starts
from model.search.diagnosis import finite, road_diagnosis
from model.search.geometry_continuation import shrink_road
from model.search.road_polish import reverses
from model.search.starts import THREE_POINT

ROAD_FALLBACK_STARTS = ((2.0, "arc"),)  # tried where the first fails
ZERO_VIOLATION = 1e-6  # m, summed slack below which the relaxed solution is a feasible trajectory
CORNERS = "corners"


def road_steps(search: Search, best: Solution, fallback: bool) -> Solution:
    """The three steps of the module docstring, in order, on ``best`` (the answer so far).

    ``fallback``: the default starts were searched (not a given guess or given starts). A road
    problem that still fails leaves with a ``diagnosis`` (the search ends there).
    """
    ocp = search.ocp
    if ocp.road is None:
        return best
    fallback = fallback and ocp.cost.free_final_time
    first = search.time_limit is not None  # within a budget the continuation before the slower fallback start
    if first:
        best = _geometry_step(search, best)
    cured_finer = grid_failures(best)  # converged, failing only between the nodes: the accuracy step's to refine
    if not (best.ok or cured_finer) and fallback and not search.skip("road fallback starts", len(ROAD_FALLBACK_STARTS)):
        search.progress("no start validated: the road's fallback starts")
        best = cold_starts(search, ROAD_FALLBACK_STARTS, None, best)
    if not ocp.bodies:
        return best
    if not first:
        best = _geometry_step(search, best)
    answered = best.ok or grid_failures(best)  # a converged answer that a finer grid may still cure
    if answered and reverses(best) and search.formulation != CORNERS and not search.skip("second opinion", 2):
        search.progress("the answer reverses: a second opinion from the arc start with the rectangles' corners")
        best = second_opinion(search, best)
    if not best.ok and not search.skip("failed road: corners, minimal violation", 2):
        guess_from = best.columns if finite(best.columns) else None
        search.progress("no start validated: the corners formulation, then a minimal-violation diagnosis")
        best = failed_road(search, best, search.values("none", guess_from))
        route = (best.diagnosis or {}).get("via", "minimal violation")
        search.attempts.append({"pass": "none", "route": route, "status": best.status, "valid": best.ok,
                                "objective": best.objective})  # fmt: skip
    return best


def _geometry_step(search: Search, best: Solution) -> Solution:
    """Step 0 where the problem has bodies, no start validated and the budget is not spent."""
    if best.ok or grid_failures(best) or not search.ocp.bodies or search.skip("geometry continuation", 1):
        return best
    search.progress("no start validated: continuation in the geometry from a relaxed road")
    return geometry_continuation(search, best)


def geometry_continuation(search: Search, best: Solution) -> Solution:
    """The scenario's road reached from a relaxed one (``shrink_road``); the better of that and ``best``.

    Each step is one solve of the step's problem in the search's formulation, sharing the search's
    clock and record; the answer on the scenario's road carries the walk in ``diagnosis`` ("recovered").
    """
    failed = best.columns if finite(best.columns) else None

    def step(problem, last):
        inner = dataclasses.replace(search, ocp=problem)
        if last is not None or failed is not None:
            routes, starts = ["warm"], [inner.values("none", last.columns if last is not None else failed)]
            if problem is search.ocp:  # the corners from the arc start first: cheap where they converge at all
                routes, starts = ["arc", *routes], [inner.values("none"), *starts]
        else:
            routes = ["arc"] + ([THREE_POINT] if u_turn(problem) else [])
            starts = [inner.values("none", None, 1.0, route) for route in routes]
        own_road = problem is search.ocp
        sols = inner.solve(search.intervals, "none", starts, analyse=own_road,  # relaxed: a guess
                           formulation=CORNERS if own_road else None)  # fmt: skip
        tried = list(zip(routes, sols, strict=False))
        if own_road and sols and not any(sol.ok for sol in sols) and not inner.expired():  # the search's own
            tried += list(zip(routes[-1:], inner.solve(search.intervals, "none", starts[-1:]), strict=False))
        search.stopped = search.stopped or inner.stopped
        search.starts_skipped = inner.starts_skipped
        found = None
        for route, sol in tried:
            bodies = getattr(sol.model, "body_formulation", search.formulation)
            search.record(sol, "none", 1.0, f"geometry continuation, {route} start ({problem.name}, {bodies})")
            found = sol if found is None or _converged_first(sol, found) else found
        return found

    found, record = shrink_road(search.ocp, step, search.progress, search.expired)
    if found is not None and found.ok and clearly_better(found, best):
        scales = ", ".join(f"x{s['scale']:g}" for s in record["scales"])
        found.diagnosis = {"kind": "recovered", "via": "geometry continuation", "walk": record,
                           "message": f"solved on the scenario's road from relaxed roads ({scales})"}  # fmt: skip
        return found
    search.attempts.append({"pass": "none", "route": "geometry continuation", "status": "failed", "valid": False,
                            "objective": None, "walk": record})  # fmt: skip
    return best


def _converged_first(a: Solution, b: Solution) -> bool:
    """``a`` before ``b`` among a step's answers: validated, then converged, then the lower objective."""
    if a.ok != b.ok or (a.status == "optimal") != (b.status == "optimal"):
        return a.ok > b.ok or (a.ok == b.ok and a.status == "optimal")
    return better(a, b)


def u_turn(ocp) -> bool:
    """Whether the road route is a U-turn (exit k of k legs: back out by the leg it came in by)."""
    return ocp.road.route.exit == len(ocp.road.roundabout.legs)


def second_opinion(search: Search, best: Solution) -> Solution:
    """The corners answer from the arc start, and the search's formulation from it; the best of the three."""
    for sol in _corners_then_own(search):
        search.record(sol, "none", 1.0, f"second opinion ({sol.model.body_formulation})")
        if clearly_better(sol, best):
            best = sol
    return best


def _corners_then_own(search: Search) -> list[Solution]:
    """The corners answer from the arc start and the search formulation's from it (each only if reached)."""
    corners = search.solve(search.intervals, "none", [search.values("none")], formulation=CORNERS)
    if not corners or not corners[0].ok:
        return corners
    own = search.solve(search.intervals, "none", [search.values("none", corners[0].columns)])
    return corners + own


def failed_road(search: Search, best: Solution, start: Start) -> Solution:
    """Recover a road problem no start solved: a feasible trajectory if one is found, else a diagnosis."""
    if search.formulation != CORNERS:
        again = search.solve(search.intervals, "none", [start], formulation=CORNERS)
        if again and again[0].ok:
            message = f"solved with the rectangles' corners in the corridor after the {search.formulation} failed"
            again[0].diagnosis = {"kind": "recovered", "via": "corners formulation", "message": message}
            return again[0]
    relaxed = search.solve(search.intervals, "none", [start], relax=True)
    if not relaxed:  # the time limit passed: the diagnosis is the time limit's (solve_ocp)
        return best
    violation = float(pyo.value(relaxed[0].model.slack_total))
    if violation <= ZERO_VIOLATION and relaxed[0].status == "optimal":
        again = search.solve(search.intervals, "none", [search.values("none", relaxed[0].columns)])
        if again and again[0].ok:
            message = "solved from a zero-violation trajectory of the minimal-violation problem: every start failed"
            again[0].diagnosis = {"kind": "recovered", "via": "minimal violation", "message": message}
            return again[0]
    best.diagnosis = road_diagnosis(search.ocp, relaxed[0], violation)
    return best


__all__ = ["ROAD_FALLBACK_STARTS", "ZERO_VIOLATION", "failed_road", "geometry_continuation", "road_steps",
           "second_opinion"]  # fmt: skip
