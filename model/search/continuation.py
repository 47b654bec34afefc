"""Continuation where every cold start fails: a homotopy in the final time.

An energy problem whose final time is tight may defeat every cold start although a trajectory
exists. Solved first with a generous final time (2x, then 4x the requested one), the solution
is carried down to the requested final time by warm re-solves of the built model
(``model.direct.Resolver``) on a geometric sequence of final times, halving a step that fails.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from model.direct.resolve import Resolver
from model.direct.solution import Solution
from model.problem.ocp import OCP

FACTORS = (2.0, 4.0)  # generous final times tried, as multiples of the requested one
STEPS = 6  # re-solves from the generous to the requested final time
MAX_HALVINGS = 4


def final_time_homotopy(
    ocp: OCP, solve: Callable[[OCP], Solution], progress: Callable[[str], None] | None = None
) -> Solution | None:
    """A valid solution at ``ocp.final_time`` reached from an easier one, or None.

    ``solve`` solves a problem from cold starts (without continuation).
    """
    if ocp.cost.free_final_time or ocp.final_time is None or ocp.road is not None:
        return None
    for factor in FACTORS:
        easy = solve(dataclasses.replace(ocp, final_time=ocp.final_time * factor))
        if progress is not None:
            progress(f"continuation: Tf x{factor:g}: {easy.status}")
        if easy.ok:
            final = _walk_down(easy, ocp.final_time, progress)
            if final is not None:
                return final
    return None


def _walk_down(solution: Solution, target: float, progress) -> Solution | None:
    """Warm re-solves from the solution's final time to ``target``; a failed step is halved."""
    resolver = Resolver(solution)
    current = solution.final_time
    step = (target / current) ** (1.0 / STEPS)
    halvings = 0
    while current > target * (1 + 1e-12):
        trial = max(target, current * step)
        sol = resolver.solve(final_time=trial)
        if sol.ok:
            current = trial
            if current <= target * (1 + 1e-12):
                return sol
            continue
        halvings += 1
        if halvings > MAX_HALVINGS:
            if progress is not None:
                progress(f"continuation: stuck at Tf = {current:.6g} s")
            return None
        resolver.solve(final_time=current)  # back to the last valid point before a smaller step
        step = step ** 0.5
    return None
