"""A second opinion on road answers that reverse: the corners formulation, then the discs from it.

On a road the route runs forwards from the entry lane to the exit lane. Where the discs' cold
starts end in an answer that reverses (an SU-30 U-turn: reversing away from the roundabout, waiting,
driving round, reversing into the goal: 49-54 s where a forward U-turn takes 15.8 s), the arc start
is solved with the rectangles' corners in the corridor, and the discs again from that answer; the
best validated of the three answers is kept.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from model.direct import bodies
from model.direct.solution import Solution
from model.direct.solve import Start, solve_starts
from model.problem.ocp import OCP

REVERSING = 0.05  # an answer reverses if u1 < -REVERSING x max |u1| somewhere (u1: roles.speed)


def reverses(sol: Solution) -> bool:
    """True if the answer's speed u1 (``roles.speed``) changes sign (beyond REVERSING of its largest magnitude)."""
    u1 = np.asarray(sol.columns.get(sol.ocp.vehicle.roles.speed, []), dtype=float)
    return u1.size > 0 and float(u1.min()) < -REVERSING * float(np.abs(u1).max())


def second_opinion(
    ocp: OCP, intervals: int, start_of: Callable[[object], Start], options: dict | None = None
) -> list[Solution]:
    """The corners answer from the arc start and the discs answer from it (each only if it was reached).

    ``start_of(columns)``: the start values of a trajectory (None: the arc guess) on ``intervals``.
    """
    with bodies.use_formulation("corners"):
        corners = solve_starts(ocp, intervals, "none", [start_of(None)], options=options)[0]
    if not corners.ok:
        return [corners]
    discs = solve_starts(ocp, intervals, "none", [start_of(corners.columns)], options=options)[0]
    return [corners, discs]


__all__ = ["REVERSING", "reverses", "second_opinion"]
