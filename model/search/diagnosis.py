"""Why a road problem failed, with evidence: the smallest violation a slack-minimising solve reaches.

When no start gives a valid solution of a road problem with bodies, the body constraints get
slacks and their sum is minimised (``build_model(..., relax=True)``), started from the best
failed attempt. If that reaches zero violation a trajectory exists: the original problem is
solved again from it. Otherwise the relaxed trajectory's exact rectangles are checked against
the exact corridor, and the deepest encroachment names the body, the edge that must give way
and by how many metres ("the trailer needs 1.3 m more apron"). A local solve gives an upper
bound on the violation that is needed, not a proof that less is impossible; the message says so.
"""

from __future__ import annotations

import numpy as np
import pyomo.environ as pyo

from model.analysis.bodies import body_corners
from model.direct.solution import Solution
from model.direct.solve import solve_starts
from model.problem.ocp import OCP
from model.scene.geometry import clearance_detail

ZERO_VIOLATION = 1e-6  # m, summed slack below which the relaxed solution is a feasible trajectory


def relaxed_solve(ocp: OCP, intervals: int, start, options: dict | None = None) -> tuple[Solution, float]:
    """The minimal-violation solve from ``start`` and its summed slack (metres)."""
    sol = solve_starts(ocp, intervals, "none", [start], options=options, relax=True)[0]
    return sol, float(pyo.value(sol.model.violation))


def road_diagnosis(ocp: OCP, relaxed: Solution, violation: float) -> dict:
    """The deepest exact encroachment of the relaxed trajectory: body, edge, metres, time, place."""
    worst = None
    for name, corners in body_corners(ocp, relaxed.columns).items():
        region = ocp.road.corridor(name)
        for k, c in enumerate(corners):
            value, edge, point = clearance_detail(region, c)
            if worst is None or value < worst[1]:
                worst = (name, value, edge, point, k)
    name, value, edge, point, k = worst
    t = float(relaxed.columns["t"][k])
    depth = max(0.0, -value)
    body = "vehicle" if name == "vehicle" else "trailer"
    return {
        "kind": "minimal violation",
        "constraint": "body in corridor",
        "body": body,
        "edge": edge,
        "encroachment_m": depth,
        "at_time_s": t,
        "at_point": [float(point[0]), float(point[1])],
        "summed_slack_m": violation,
        "relaxed_status": relaxed.status,
        "message": (
            f"no valid trajectory found: the {body} crosses the {edge} by {depth:.2f} m at t = {t:.2f} s on the "
            "best trajectory a slack-minimising solve reached (an upper bound on what must give way)"
        ),
    }


def failed_road(ocp: OCP, intervals: int, best: Solution, start, options: dict | None = None) -> Solution:
    """Recover a road problem no start solved: a feasible trajectory if one is found, else a diagnosis."""
    relaxed, violation = relaxed_solve(ocp, intervals, start, options)
    if violation <= ZERO_VIOLATION and relaxed.status == "optimal":
        from model.search.multistart import start_values

        again = solve_starts(ocp, intervals, "none", [start_values(ocp, intervals, "none", relaxed.columns)],
                             options=options)[0]  # fmt: skip
        if again.ok:
            again.diagnosis = {"kind": "recovered", "message": "solved from a zero-violation trajectory of the "
                               "minimal-violation problem after every cold start failed"}  # fmt: skip
            return again
    best.diagnosis = road_diagnosis(ocp, relaxed, violation)
    return best


def finite(columns) -> bool:
    """Whether every node value is finite (a failed solve may end with NaN)."""
    return all(np.all(np.isfinite(np.asarray(a, float))) for a in columns.values())
