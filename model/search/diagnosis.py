"""Why a problem failed, with evidence: a proven bound, or the smallest violation a slack-minimising solve reaches.

Proven bound: for a fixed final time, the obstacle-free Reeds-Shepp length over the top speed
is a lower bound on the time any admissible trajectory needs (``paths.reeds_shepp_time``); a
final time below it is infeasible whatever the solver does.

Minimal violation (the road's last step, ``model.search.road.failed_road``): the relaxed
trajectory's exact rectangles are checked against the exact corridor, and the deepest
encroachment names the body, the edge that must give way and by how many metres ("the trailer
needs 1.3 m more apron"). A local solve gives an upper bound on the violation that is needed,
not a proof that less is impossible; the message says so.

Time limit: a search its budget stopped before any start validated reports what it tried (the
attempts' statuses, the starts and steps it skipped) and the solver's evidence on the best one.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from model.analysis.bodies import body_corners, substeps
from model.analysis.validation import failed_checks
from model.direct.solution import Solution
from model.problem.ocp import OCP
from model.scene.geometry import clearance_detail


def road_diagnosis(ocp: OCP, relaxed: Solution, violation: float) -> dict:
    """The deepest exact encroachment of the relaxed trajectory: body, edge, metres, time, place.

    The exact rectangles are checked at the nodes and at ``SUBSTEPS`` linear sub-steps between them
    (as ``body_clearance_dense`` is), so a trajectory that fails only between the nodes is named there.
    """
    nodes = relaxed.columns
    between = substeps(nodes, [*ocp.vehicle.states, "t"])
    at_nodes = _deepest(ocp, nodes, "node")
    name, value, edge, point, t, where = min((at_nodes, _deepest(ocp, between, "between nodes")), key=lambda w: w[1])
    depth = max(0.0, -value)
    return {
        "kind": "minimal violation",
        "constraint": "body in corridor",
        "body": name,
        "edge": edge,
        "encroachment_m": depth,
        "node_encroachment_m": max(0.0, -at_nodes[1]),
        "at_time_s": t,
        "at_point": [float(point[0]), float(point[1])],
        "where": where,
        "summed_slack_m": violation,
        "relaxed_status": relaxed.status,
        "message": (
            f"no valid trajectory found: the {name} crosses the {edge} by {depth:.2f} m at t = {t:.2f} s "
            f"({where}) on the best trajectory a slack-minimising solve reached (an upper bound on what must give way)"
        ),
    }


def _deepest(ocp: OCP, states: dict, where: str) -> tuple:
    """(body, clearance, edge, point, time, where) of the smallest exact clearance over the samples."""
    worst = None
    for name, corners in body_corners(ocp, states).items():
        region = ocp.road.corridor(name)
        for k, c in enumerate(corners):
            value, edge, point = clearance_detail(region, c)
            if worst is None or value < worst[1]:
                worst = (name, value, edge, point, float(states["t"][k]), where)
    return worst


def bound_diagnosis(ocp: OCP) -> dict | None:
    """A proof of infeasibility from the Reeds-Shepp lower bound on the minimum time, if it applies."""
    from model.search.paths import min_turning_radius, reeds_shepp_time

    if ocp.cost.free_final_time or ocp.final_time is None or ocp.max_speed() is None:
        return None
    pose = (*ocp.vehicle.position, ocp.vehicle.roles.heading)
    if not all(k in ocp.final and k in ocp.initial for k in pose):
        return None
    rho = min_turning_radius(ocp.vehicle, ocp.bounds)
    start = tuple(ocp.initial[k] for k in pose)
    goal = tuple(ocp.final[k] for k in pose)
    bound = reeds_shepp_time(start, goal, rho, ocp.max_speed())
    if not ocp.final_time < bound:
        return None
    return {
        "kind": "proven bound",
        "constraint": "problem.final_time",
        "final_time_s": ocp.final_time,
        "minimum_time_lower_bound_s": bound,
        "turning_radius_m": rho,
        "message": (
            f"infeasible: the final time {ocp.final_time:g} s is below {bound:.4g} s, the shortest Reeds-Shepp path "
            f"(turning radius {rho or 0:.4g} m) driven at the top speed {ocp.max_speed():g} m/s"
        ),
    }


def solver_diagnosis(best: Solution) -> dict:
    """No proof: what the solver ended with (status, last primal infeasibility) and the failed checks."""
    log = getattr(getattr(best, "ipopt", None), "log", None) or []
    failed = list(failed_checks(best.validation))
    return {
        "kind": "solver",
        "status": best.status,
        "last_primal_infeasibility": log[-1][2] if log else None,
        "failed_checks": failed,
        "message": f"no start gave a valid solution (best: {best.status}"
        + (f", checks failed: {', '.join(failed)}" if failed else "") + "); no infeasibility proof",
    }


def refined_diagnosis(coarse: Solution, finer: Solution) -> dict:
    """The search's evidence for a failed answer the accuracy refinement replaced by a finer grid's re-solve.

    ``coarse`` is the search's failed answer on its own grid (its ``diagnosis`` the search's evidence: a
    minimal violation, a proof, the solver's); ``finer`` the failed re-solve on a finer grid that is kept.
    The coarse evidence stands (or the solver's on ``finer`` if there was none), with the finer grid's
    status and failed checks in ``refined_to`` and in the message.
    """
    out = dict(coarse.diagnosis) if coarse.diagnosis else solver_diagnosis(finer)
    failed = list(failed_checks(finer.validation))
    out["refined_to"] = {"intervals": finer.intervals, "status": finer.status, "failed_checks": failed}
    out["message"] = (f"{out.get('message', 'no valid solution')}; re-solved on N = {finer.intervals}: "
                      f"{finer.status}" + (f" ({', '.join(failed)} failed)" if failed else ""))  # fmt: skip
    return out


def time_limit_diagnosis(best: Solution, attempts: list[dict], search: dict) -> dict:
    """No valid answer within the time limit: what was tried, what was skipped, and the solver's evidence."""
    tried = Counter(a["status"] for a in attempts)
    evidence = solver_diagnosis(best)
    skipped = search.get("starts_skipped", 0)
    return {
        "kind": "time limit",
        "time_limit_s": search.get("time_limit"),
        "clock": search.get("clock", "wall"),
        "attempts_by_status": dict(tried),
        "starts_skipped": skipped,
        "steps_skipped": search.get("steps_skipped", []),
        "best_status": evidence["status"],
        "last_primal_infeasibility": evidence["last_primal_infeasibility"],
        "failed_checks": evidence["failed_checks"],
        "message": (
            f"no valid trajectory within the time limit of {search.get('time_limit'):g} s"
            f"{' of CPU' if search.get('clock') == 'cpu' else ''}: {sum(tried.values())} "
            f"starts tried ({', '.join(f'{n} {k}' for k, n in tried.items())}), {skipped} skipped; best: "
            f"{evidence['status']}" + (f", checks failed: {', '.join(evidence['failed_checks'])}"
                                       if evidence["failed_checks"] else "") + "; a longer --time-limit may find one"
        ),
    }  # fmt: skip


def finite(columns) -> bool:
    """Whether every node value is finite (a failed solve may end with NaN)."""
    return all(np.all(np.isfinite(np.asarray(a, float))) for a in columns.values())
