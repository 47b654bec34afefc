"""Whether a road answer reverses: the test behind the second opinion of ``model.search.road``.

On a road the route runs forwards from the entry lane to the exit lane; an answer that reverses
(an SU-30 U-turn: reversing away from the roundabout, waiting, driving round, reversing into the
goal: 49-54 s where a forward U-turn takes 15.8 s) gets a second opinion with the corners.
"""

from __future__ import annotations

import numpy as np

from model.direct.solution import Solution

REVERSING = 0.05  # an answer reverses if u1 < -REVERSING x max |u1| somewhere (u1: roles.speed)


def reverses(sol: Solution) -> bool:
    """True if the answer's speed u1 (``roles.speed``) changes sign (beyond REVERSING of its largest magnitude)."""
    u1 = np.asarray(sol.columns.get(sol.ocp.vehicle.roles.speed, []), dtype=float)
    return u1.size > 0 and float(u1.min()) < -REVERSING * float(np.abs(u1).max())


__all__ = ["REVERSING", "reverses"]
