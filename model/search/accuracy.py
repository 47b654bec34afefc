"""Accuracy of a solution: do its controls, integrated exactly, reach the goal?

The trapezoid rule is second order: on a coarse grid the optimal controls, re-integrated by
an accurate integrator (the validation's ``reintegration``), end a little off the goal. A
solution whose drift at the goal exceeds the tolerance is solved again on a grid twice as
fine, warm from itself, at most ``MAX_DOUBLINGS`` times, and kept unless the finer grid landed in
another local optimum (objective more than ``SAME_OPTIMUM`` above); the summary says what was
reached.

Tolerance: ``GOAL_ACCURACY * max(1, L)`` for the position states (L the start-goal distance,
metres) and ``GOAL_ACCURACY`` for every other state fixed at the goal (radians for angles).

Between the nodes (on a road with bodies): a solution whose controls, integrated from a node,
take a body further from the next node than its clearance there (the validation's
``integration_error``, ``within_clearance`` False), or that fails validation only because the
integrated motion leaves the corridor (``dense_clearance``), is solved again on 2N the same way,
and on 4N if 2N still shows either (``MAX_GRID_DOUBLINGS``); if the finer grids do not cure it,
the numbers stay in its validation (``measures.integration_error``,
``measures.min_clearance_integrated``) and the record says so (``grid_failures``).
"""

from __future__ import annotations

from collections.abc import Callable

from model.analysis.validation import failed_checks
from model.direct.solution import Solution
from model.problem.ocp import OCP

CONVERGED = ("optimal", "validation_failed")  # Ipopt converged (a check of the validation may have failed)

GOAL_ACCURACY = 1e-3
MAX_DOUBLINGS = 1
MAX_GRID_DOUBLINGS = 2  # a solution failing only the between-node checks may be refined up to 4N
MAX_INTERVALS = 1600  # never refine beyond this grid
ROUTE = "for accuracy"  # the end of an attempt's route when it is a re-solve on a finer grid
SAME_OPTIMUM = 0.02  # a finer grid's objective more than 2 % above the coarse one is another local optimum
GRID_CHECKS = frozenset({"dense_clearance"})  # failed checks a finer grid can cure


def goal_tolerances(ocp: OCP, accuracy: float = GOAL_ACCURACY) -> dict[str, float]:
    """The drift allowed at the goal for each state fixed there."""
    scale = max(1.0, ocp.straight_distance() or 0.0)
    position = set(ocp.vehicle.position)
    return {s: accuracy * (scale if s in position else 1.0) for s in ocp.final}


def goal_drift(sol: Solution, accuracy: float = GOAL_ACCURACY) -> tuple[float, str | None]:
    """The largest re-integrated goal error relative to its tolerance (<= 1 is accurate), and its state."""
    errors = (sol.validation.get("measures", {}).get("reintegration") or {}).get("final_state_error")
    if not errors:
        return float("inf"), None
    tol = goal_tolerances(sol.ocp, accuracy)
    worst = max(tol, key=lambda s: errors[s] / tol[s], default=None)
    return (errors[worst] / tol[worst], worst) if worst else (0.0, None)


def grid_failures(sol: Solution) -> list[str]:
    """What a finer grid may cure in a converged solution: ``integration_error`` beyond the clearance, and
    ``dense_clearance`` if it is the only failed check ([] if nothing, or if another check fails)."""
    if sol.status not in CONVERGED:
        return []
    failed = list(failed_checks(sol.validation))
    if not set(failed) <= GRID_CHECKS:
        return []
    error = sol.validation.get("measures", {}).get("integration_error") or {}
    return failed + (["integration_error"] if error.get("within_clearance") is False else [])


def refine_for_accuracy(
    sol: Solution,
    solve: Callable[[int, Solution], Solution | None],
    accuracy: float | None = GOAL_ACCURACY,
    progress: Callable[[str], None] | None = None,
) -> tuple[Solution, dict]:
    """Double the grid (warm) while the goal drift exceeds its tolerance; the best accurate solution.

    ``solve(n, guess)`` solves the problem on n intervals from ``guess`` (None: not solved, the
    search's time limit has passed). Returns the solution to keep and the record for the summary
    (``accuracy``).
    """
    if accuracy is None or not (sol.ok or grid_failures(sol)):
        return sol, {}
    ratio, state = goal_drift(sol, accuracy)
    record = {"tolerance": goal_tolerances(sol.ocp, accuracy), "intervals_requested": sol.intervals}
    for doubling in range(max(MAX_DOUBLINGS, MAX_GRID_DOUBLINGS)):
        failures = grid_failures(sol)
        drifts = ratio > 1.0 and doubling < MAX_DOUBLINGS
        if not (drifts or (failures and doubling < MAX_GRID_DOUBLINGS)) or 2 * sol.intervals > MAX_INTERVALS:
            break
        if progress is not None:
            why = f"goal drift {ratio:.3g} x the tolerance ({state})"
            why = why if ratio > 1.0 else f"{', '.join(failures)} failed"
            progress(f"{why} on N = {sol.intervals}: now N = {2 * sol.intervals}")
        finer = solve(2 * sol.intervals, sol)
        if finer is None:
            record["refinement_failed"] = "time limit"
            break
        if not (sol.ok or finer.ok) and grid_failures(finer) and doubling + 1 < MAX_GRID_DOUBLINGS:
            sol, (ratio, state) = finer, goal_drift(finer, accuracy)  # closer: one more doubling may cure it
            continue
        if not finer.ok:
            failed = list(failed_checks(finer.validation))
            record["refinement_failed"] = finer.status + (f" ({', '.join(failed)})" if failed else "")
            break
        if sol.ok and finer.objective > sol.objective + SAME_OPTIMUM * abs(sol.objective):
            record["refinement_failed"] = f"N = {finer.intervals} found another local optimum ({finer.objective:.6g})"
            break
        sol = finer
        ratio, state = goal_drift(sol, accuracy)
    return sol, record | {"drift_over_tolerance": ratio, "worst_state": state, "reached": ratio <= 1.0,
                          "intervals": sol.intervals, "grid_failures": grid_failures(sol)}  # fmt: skip


def objectives_on_grid(attempts: list[dict] | None) -> list[float]:
    """Objectives of the validated attempts on the search's own grid (not re-solves for accuracy)."""
    return [a["objective"] for a in attempts or []
            if a.get("valid") is True and not str(a.get("route", "")).endswith(ROUTE)]  # fmt: skip


__all__ = ["GOAL_ACCURACY", "ROUTE", "goal_drift", "goal_tolerances", "grid_failures", "objectives_on_grid",
           "refine_for_accuracy"]
