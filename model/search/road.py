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
   and the search's formulation from that answer if both fail. Where the steady circulating turn
   at the outer curb still puts a body inside the edge it may not cross (``cuts_inner_edge``: the
   WB-62 at ICD 45 m, its trailer 0.137 m over the apron's inner edge), a forward turn through the
   ring does not exist in steady state and the smooth starts do not converge on the scenario's road
   (x0 from x0.25: 1464 iterations without converging): there the step on the scenario's road is
   feasibility first, the minimal-violation problem (corners) from the last relaxed answer, then,
   from a trajectory with zero violation at the nodes, the time problem (``feasible_then_fastest``).
   Its outcome, answered or not, is the evidence the search reports (``feasibility_diagnosis``).
   With a time limit the walk goes from the roomiest road (x1) straight to the scenario's
   (``FEASIBILITY_SCALES``; halved towards x1 if that fails), and a minimal violation that converged
   with the bodies still outside ends the search (``refused_with_evidence``): on the design table's
   WB-62 at ICD 25 m the walk x1 -> x0.5 spent the budget on a time problem that did not converge and
   left no evidence; straight from x1 the minimal violation converges (trailer 6.47 m over the island).
   With a time limit the minimal violation is first solved on N / 2 (``coarse_refusal``): a body at
   least ``COARSE_EVIDENCE_M`` outside at the nodes there ends the search with that evidence, in about
   half the time; less, and the coarse answer is thrown away and the step runs on N as before.

Each step is skipped once the search's time limit has passed (``Search.skip``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pyomo.environ as pyo

from model.analysis.bounds import ring_fit
from model.analysis.validation import failed_checks
from model.direct.solution import Solution
from model.direct.solve import Start
from model.problem.ocp import OCP
from model.search.accuracy import CONVERGED, grid_failures
from model.search.context import Search, better, clearly_better, cold_starts
from model.search.diagnosis import finite, road_diagnosis
from model.search.geometry_continuation import shrink_road
from model.search.road_polish import REVERSING, reverses
from model.search.starts import THREE_POINT

ROAD_FALLBACK_STARTS = ((2.0, "arc"),)  # tried where the first fails
ZERO_VIOLATION = 1e-6  # m, summed slack below which the relaxed solution is a feasible trajectory
CORNERS = "corners"
EVIDENCE_M = 0.01  # m: a converged minimal violation ends the search only if a body is at least this far outside
FEASIBILITY_SCALES = (1.0, 0.0)  # feasibility first: the scenario's road straight from the roomiest road's answer
COARSE_EVIDENCE_M = 0.5  # m: with a time limit, a minimal violation on N / 2 this far out at the nodes ends it
COARSE_MIN_INTERVALS = 20  # the coarse minimal violation's least N


def road_steps(search: Search, best: Solution, fallback: bool, geometry: bool = True) -> Solution:
    """The three steps of the module docstring, in order, on ``best`` (the answer so far).

    ``fallback``: the default starts were searched (not a given guess or given starts). A road
    problem that still fails leaves with a ``diagnosis`` (the search ends there). ``geometry``:
    False where the search ran the geometry continuation already (before its cold starts).
    """
    ocp = search.ocp
    if ocp.road is None:
        return best
    fallback = fallback and ocp.cost.free_final_time
    first = search.time_limit is not None  # within a budget the continuation before the slower fallback start
    if first and geometry:
        best = _geometry_step(search, best)
    cured_finer = grid_failures(best)  # converged, failing only between the nodes: the accuracy step's to refine
    if not (best.ok or cured_finer) and fallback and not search.skip("road fallback starts", len(ROAD_FALLBACK_STARTS)):
        search.progress("no start validated: the road's fallback starts")
        best = cold_starts(search, ROAD_FALLBACK_STARTS, None, best)
    if not ocp.bodies:
        return best
    if not first and geometry:
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


def geometry_continuation(search: Search, best: Solution | None) -> Solution | None:
    """The scenario's road reached from a relaxed one (``shrink_road``); the better of that and ``best``
    (None: no start before it; then the continuation's own answer on the scenario's road, or None).

    Each step is one solve of the step's problem in the search's formulation, sharing the search's
    clock and record; the answer on the scenario's road carries the walk in ``diagnosis`` ("recovered").
    """
    failed = best.columns if best is not None and finite(best.columns) else None
    feasibility_first = cuts_inner_edge(search.ocp)

    def step(problem, last):
        inner = dataclasses.replace(search, ocp=problem)
        if problem is search.ocp and feasibility_first and last is not None:  # the last resort: no run cap
            inner.run_cap = None
            found = feasible_then_fastest(inner, last)
            search.stopped = search.stopped or inner.stopped
            search.starts_skipped = inner.starts_skipped
            return found
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

    budgeted = feasibility_first and search.time_limit is not None  # (without a budget the walk is as it was)

    def reached(sol: Solution) -> bool:  # feasibility first: a converged answer the accuracy step may refine ends it,
        return sol.ok or (feasibility_first and bool(grid_failures(sol))) or (budgeted and refused_with_evidence(sol))

    scales = FEASIBILITY_SCALES if budgeted else None
    found, record = shrink_road(search.ocp, step, search.progress, search.expired, reached, scales)
    if found is not None and found.ok and clearly_better(found, best):
        scales = ", ".join(f"x{s['scale']:g}" for s in record["scales"])
        found.diagnosis = {"kind": "recovered", "via": "geometry continuation", "walk": record,
                           "message": f"solved on the scenario's road from relaxed roads ({scales})"}  # fmt: skip
        return found
    search.attempts.append({"pass": "none", "route": "geometry continuation", "status": "failed", "valid": False,
                            "objective": None, "walk": record})  # fmt: skip
    if best is None:  # the continuation before any cold start: what it got to
        return found
    if found is not None and feasibility_first and found.diagnosis is not None:  # feasibility first: its evidence
        if found.status in CONVERGED and best.status not in CONVERGED:
            return found  # a converged trajectory of the scenario's road (a finer grid may validate it)
        best.diagnosis = best.diagnosis or found.diagnosis
    return best


def refused_with_evidence(sol: Solution | None) -> bool:
    """Whether ``sol`` is a refusal the search ends on: the minimal-violation problem on the scenario's road
    converged (Ipopt's status "optimal"; the answer's "validation_failed") with the bodies still outside the
    corridor (``feasibility_diagnosis``) by at least ``EVIDENCE_M`` (less may be the solver's tolerance: the
    WB-62 at ICD 40 m with the apron "crosses the apron by 0.00 m", and was solved in 79.3 s without a limit).

    Evidence, not proof: a local solve of the problem whose every feasible point has zero slack, from
    the roomiest relaxed road's answer, still needs the violation; the cold starts and the time
    problem's own steps after it are local solves of the harder, constrained problem.
    """
    diagnosis = (sol.diagnosis or {}) if sol is not None and not sol.ok else {}
    return (diagnosis.get("kind") == "minimal violation" and diagnosis.get("relaxed_status") in CONVERGED
            and diagnosis.get("encroachment_m", 0.0) >= EVIDENCE_M)  # fmt: skip


def cuts_inner_edge(ocp: OCP) -> bool:
    """Whether the steady circulating turn whose outer swept radius is the outer curb still puts a body
    inside the edge it may not cross (``model.analysis.bounds.ring_fit``: inner margin < 0)."""
    fit = ring_fit(ocp) if ocp.road is not None and ocp.bodies else None
    return fit is not None and fit["inner_margin"] < 0.0


def feasible_then_fastest(search: Search, last: Solution) -> Solution | None:
    """The scenario's road from the last relaxed answer ``last``: feasibility first, then the time.

    The minimal-violation problem (the rectangles' corners, ``build_model(..., relax=True)``) from
    ``last``; if Ipopt converges to a summed slack within ``ZERO_VIOLATION`` (a trajectory inside the
    corridor at the nodes), the scenario's problem (corners) from it. Returns the better answer of the
    two (None if the time limit left neither begun); one that does not validate carries the
    ``diagnosis`` of ``feasibility_diagnosis``, the evidence the search reports.
    """
    coarse = coarse_refusal(search, last)
    if coarse is not None:
        return coarse
    relaxed = search.solve(search.intervals, "none", [search.values("none", last.columns)], relax=True,
                           formulation=CORNERS)  # fmt: skip
    if not relaxed:
        return None
    mv = relaxed[0]
    violation = float(pyo.value(mv.model.slack_total))
    search.record(mv, "none", 1.0, f"geometry continuation, minimal violation ({search.ocp.name}, corners)")
    found, fast = mv, None
    if violation <= ZERO_VIOLATION and mv.status in CONVERGED:
        sols = search.solve(search.intervals, "none", [search.values("none", mv.columns)], formulation=CORNERS)
        for sol in sols:
            search.record(sol, "none", 1.0, f"geometry continuation, from zero violation ({search.ocp.name}, corners)")
            fast = sol
            found = sol if _converged_first(sol, found) else found
    if not found.ok:
        found.diagnosis = feasibility_diagnosis(search.ocp, mv, violation, fast)
        search.evidence.append(found.diagnosis)
    return found


def coarse_refusal(search: Search, last: Solution) -> Solution | None:
    """With a time limit: the minimal-violation problem on N / 2 from ``last``; its answer, refused with the
    evidence, if it converged with a body at least ``COARSE_EVIDENCE_M`` outside at the nodes, else None (the
    search goes on on N as before, the coarse solve a guess thrown away).

    Half the cost where a road is far too tight (the design table's WB-67 at ICD 40 m without apron: 12.4 s
    instead of 26.5 s of search, the trailer 3.70 m over the island on N = 30, 3.62 m on N = 60). Half a metre
    at the nodes is far more than the coarser grid's own error, so no road a finer grid passes is refused.
    """
    n = max(COARSE_MIN_INTERVALS, search.intervals // 2)
    if search.time_limit is None or n >= search.intervals:
        return None
    sols = search.solve(n, "none", [search.values("none", last.columns, intervals=n)], relax=True,
                        formulation=CORNERS)  # fmt: skip
    if not sols:
        return None
    mv = sols[0]
    search.record(mv, "none", 1.0, f"geometry continuation, minimal violation on N = {n} ({search.ocp.name}, corners)")
    violation = float(pyo.value(mv.model.slack_total))
    if mv.status not in CONVERGED or violation <= ZERO_VIOLATION:
        return None
    diagnosis = feasibility_diagnosis(search.ocp, mv, violation, None)
    if diagnosis.get("node_encroachment_m", 0.0) < COARSE_EVIDENCE_M:
        return None
    diagnosis["message"] += f" (on N = {n}: at least {COARSE_EVIDENCE_M:g} m outside at the nodes)"
    mv.diagnosis = diagnosis | {"intervals": n}
    search.evidence.append(mv.diagnosis)
    return mv


def feasibility_diagnosis(ocp: OCP, mv: Solution, violation: float, fast: Solution | None) -> dict:
    """The evidence of ``feasible_then_fastest`` where nothing validated: the steady-turn bound, the minimal
    violation reached, and (zero violation) what failed between the nodes of the trajectory it found."""
    fit = {k: v for k, v in ring_fit(ocp).items() if k != "bodies"}
    steady = (f"the steady circulating turn at the outer curb puts the {fit['inner_body']} "
              f"{-fit['inner_margin']:.3g} m inside the edge it may not cross")  # fmt: skip
    if violation > ZERO_VIOLATION:
        out = road_diagnosis(ocp, mv, violation)
        return out | {"steady_turn": fit, "message": f"{steady}; {out['message']}"}
    if mv.status not in CONVERGED:  # zero slack, but the dynamics' defects not yet closed
        log = getattr(getattr(mv, "ipopt", None), "log", None) or []
        primal = log[-1][2] if log else None
        return {"kind": "minimal violation not converged", "steady_turn": fit, "summed_slack_m": violation,
                "relaxed_status": mv.status, "last_primal_infeasibility": primal, "final_time_s": mv.final_time,
                "message": f"{steady}; the slack-minimising solve reached zero slack at the nodes (Tf "
                           f"{mv.final_time:.4g} s) but ended {mv.status}"
                           + (f" with the defects at {primal:.2g}" if primal is not None else "")
                           + ": no trajectory yet, and no proof that none exists"}  # fmt: skip
    best = fast if fast is not None and fast.status in CONVERGED else mv
    failed = list(failed_checks(best.validation))
    measures = best.validation.get("measures", {})
    speed = np.asarray(best.columns.get(ocp.vehicle.roles.speed, []), dtype=float)
    cusps = int(np.count_nonzero(np.diff(np.sign(speed[np.abs(speed) > REVERSING * np.abs(speed).max()])))) \
        if speed.size else 0
    return {"kind": "zero violation at the nodes", "steady_turn": fit, "summed_slack_m": violation,
            "status": best.status, "final_time_s": best.final_time, "cusps": cusps, "failed_checks": failed,
            "min_clearance_integrated_m": measures.get("min_clearance_integrated"),
            "message": f"{steady}; a trajectory inside the corridor at the N = {best.intervals} nodes exists "
                       f"(Tf {best.final_time:.4g} s, {cusps} cusps: the speed changes sign {cusps} times), but it "
                       f"fails {', '.join(failed) or 'no check'}"
                       + (f" (least clearance between the nodes {measures['min_clearance_integrated']:.3g} m)"
                          if measures.get("min_clearance_integrated") is not None else "")
                       + ": a finer grid may validate it, or show that it passes only at the nodes"}  # fmt: skip


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
    if violation <= ZERO_VIOLATION and relaxed[0].status in CONVERGED:
        again = search.solve(search.intervals, "none", [search.values("none", relaxed[0].columns)])
        if again and again[0].ok:
            message = "solved from a zero-violation trajectory of the minimal-violation problem: every start failed"
            again[0].diagnosis = {"kind": "recovered", "via": "minimal violation", "message": message}
            return again[0]
    best.diagnosis = road_diagnosis(search.ocp, relaxed[0], violation)
    search.evidence.append(best.diagnosis)
    return best


__all__ = ["CONVERGED", "ROAD_FALLBACK_STARTS", "ZERO_VIOLATION", "cuts_inner_edge", "failed_road",
           "feasibility_diagnosis", "feasible_then_fastest", "geometry_continuation", "refused_with_evidence",
           "road_steps", "second_opinion"]  # fmt: skip
