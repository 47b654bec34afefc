"""The search for map scenarios: the curvilinear corridor strips' sequence of solves (docs/map-corridor.md).

``solve_map_route`` is ``OCP.solve``'s default method when the problem has a ``map_route``: it runs
``model.direct.map_corridor.solve_map`` (fixed-projection strip solves from the centre-line start,
re-projected until the projections move less than 5 cm, at most 8 solves) and returns the last
solve's Solution. That Solution is validated as every answer is, and its bodies as exact rectangles in
the shapely corridor at the nodes and between them (``model.analysis.maps``); when a body leaves
the corridor, or the solve fails, ``diagnosis`` says which body leaves it where and by how much.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from model.analysis.maps import corridor_diagnosis
from model.direct.map_corridor import solve_map
from model.direct.solution import Solution
from model.problem.ocp import OCP

ITERATIONS = 8  # at most this many strip solves
TOLERANCE = 0.05  # m: the sequence stops when no projection moved more than this


def solve_map_route(ocp: OCP, intervals: int = 100, options: dict | None = None, verbose: bool = False,
                    **_ignored: Any) -> Solution:  # fmt: skip
    """Solve a route through a lanelet map by the sequence of corridor strip solves.

    Parameters
    ----------
    ocp : OCP
        A problem with a ``map_route``.
    intervals : int
        N, the trapezoid steps of each solve.
    options : dict, optional
        Ipopt options (``verbose`` adds ``print_level`` 5).
    **_ignored
        The roundabout search's options (``progress``, ``search``, ``time_limit``, ...), not used here.

    Returns
    -------
    Solution
        The last solve of the sequence; ``search`` records each solve (status, Tf, how far the
        projections moved, the exact clearance at the nodes), ``diagnosis`` is set unless ``ok``.
    """
    ipopt = dict(options or {})
    if verbose:
        ipopt.setdefault("print_level", 5)
    result = solve_map(ocp, intervals, iterations=ITERATIONS, tol=TOLERANCE, options=ipopt)
    sol = result.solution
    sol.search = {
        "method": "map corridor strips (fixed projections)",
        "solves": [{"status": it.solution.status, "final_time": it.solution.final_time, "moved": it.moved,
                    "exact_clearance": it.exact_clearance, "seconds": it.seconds} for it in result.iterates],
        "converged": result.iterates[-1].moved < TOLERANCE,
    }  # fmt: skip
    sol.timings = {**sol.timings, "solves_seconds": float(sum(it.seconds for it in result.iterates))}
    if not sol.ok:
        sol.diagnosis = diagnosis(sol)
    return sol


def diagnosis(sol: Solution) -> dict:
    """Why a map solve failed: the bodies that leave the corridor (where and by how much) and the failed checks."""
    ocp = sol.ocp
    states = {k: np.asarray(sol.columns[k]) for k in ("t", *ocp.vehicle.states)}
    bodies = corridor_diagnosis(ocp, states)
    failed = [k for k, c in sol.validation.get("checks", {}).items() if not c["passed"]]
    parts = [f"the {b['body']} body leaves the corridor by {b['outside']:.3f} m ({b['where']}, t = {b['t']:.2f} s, "
             f"reference point ({b['x']:.2f}, {b['y']:.2f}), lanelets {b['lanelets']})" for b in bodies]  # fmt: skip
    if sol.status not in ("optimal", "validation_failed"):  # validation_failed: Ipopt converged, a check failed
        parts.insert(0, f"Ipopt: {sol.status}")
    if not sol.search.get("converged", True):
        parts.append(f"the projections did not converge in {len(sol.search['solves'])} solves")
    return {"kind": "map corridor", "message": "; ".join(parts) or "validation failed: " + ", ".join(failed),
            "bodies": bodies, "failed_checks": failed}  # fmt: skip
