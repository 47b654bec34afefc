"""Continuation where every cold start fails: a slowed-down minimum-time solution, or a homotopy in the final time.

The vehicle models are driftless (x' = f(x) u): a trajectory driven in time T is also driven in any
Tf >= T with the controls scaled by T / Tf. So an energy problem whose cold starts fail is first
solved for minimum time; if that time is at most Tf, the minimum-time trajectory slowed down to Tf
is an exactly feasible start.

An energy problem whose final time is tight may defeat every cold start although a trajectory
exists. Solved first with a generous final time (2x, then 4x the requested one), the solution
is carried down to the requested final time by warm re-solves of the built model
(``model.direct.Resolver``) on a geometric sequence of final times, halving a step that fails.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from model.direct.resolve import Resolver
from model.direct.solution import Solution
from model.problem.ocp import OCP

FACTORS = (2.0, 4.0)  # generous final times tried, as multiples of the requested one
STEPS = 6  # re-solves from the generous to the requested final time
MAX_HALVINGS = 4


def slowed_minimum_time(
    ocp: OCP, solve: Callable[..., Solution], progress: Callable[[str], None] | None = None
) -> tuple[Solution | None, float | None]:
    """The energy problem solved from its minimum-time solution slowed down to Tf; and that minimum time.

    ``solve(problem, guess=None)`` solves a problem from cold starts (without continuation).
    """
    if ocp.cost.free_final_time or ocp.final_time is None or ocp.road is not None:
        return None, None
    from model.problem.costs import Time

    timed = dataclasses.replace(ocp, cost=Time(), final_time=None)
    fastest = solve(timed)
    shortest = _reeds_shepp_start(timed, solve)
    if shortest is not None and shortest.ok and (not fastest.ok or shortest.objective < fastest.objective):
        fastest = shortest
    if progress is not None:
        progress(f"continuation: minimum time {fastest.final_time:.6g} s ({fastest.status})")
    if not fastest.ok:
        return None, None
    if fastest.final_time > ocp.final_time:
        return None, fastest.final_time
    stretch = ocp.final_time / fastest.final_time
    v = ocp.vehicle
    guess = {"t": fastest.columns["t"] * stretch, **{s: fastest.columns[s] for s in v.states},
             **{c: fastest.columns[c] / stretch for c in v.controls}}  # fmt: skip
    found = solve(ocp, guess=guess)
    return (found if found.ok else None), fastest.final_time


def _reeds_shepp_start(timed: OCP, solve: Callable[..., Solution]) -> Solution | None:
    """The time problem solved from the shortest Reeds-Shepp path (cusps, reversing), as ``reeds_shepp_guess``
    drives it: at 70 % of the speed bound, or within the limits (``limited_path_guess``) with longitudinal
    dynamics."""
    from model.search.guess import reeds_shepp_guess

    found = reeds_shepp_guess(timed, 200)
    if found is None:
        return None
    guess, tf = found
    guess["t"] = np.linspace(0.0, tf, 201)
    return solve(timed, guess=guess)


def final_time_homotopy(
    ocp: OCP,
    solve: Callable[[OCP], Solution],
    progress: Callable[[str], None] | None = None,
    budget: Callable[[], dict | None] | None = None,
) -> Solution | None:
    """A valid solution at ``ocp.final_time`` reached from an easier one, or None.

    ``solve`` solves a problem from cold starts (without continuation). ``budget()``: the Ipopt
    options of the next warm re-solve (``max_wall_time``, the search's time left), None once the
    time limit has passed (the walk stops there).
    """
    if ocp.cost.free_final_time or ocp.final_time is None or ocp.road is not None:
        return None
    for factor in FACTORS:
        easy = solve(dataclasses.replace(ocp, final_time=ocp.final_time * factor))
        if progress is not None:
            progress(f"continuation: Tf x{factor:g}: {easy.status}")
        if easy.ok:
            final = _walk_down(easy, ocp.final_time, progress, budget or dict)
            if final is not None:
                return final
    return None


def _walk_down(solution: Solution, target: float, progress, budget: Callable[[], dict | None]) -> Solution | None:
    """Warm re-solves from the solution's final time to ``target``; a failed step is halved; None once
    ``budget()`` is None (the time limit)."""
    resolver = Resolver(solution)
    current = solution.final_time
    step = (target / current) ** (1.0 / STEPS)
    halvings = 0
    while current > target * (1 + 1e-12):
        trial = max(target, current * step)
        options = budget()
        if options is None:
            if progress is not None:
                progress(f"continuation: the time limit stops the walk at Tf = {current:.6g} s")
            return None
        sol = resolver.solve(final_time=trial, options=options)
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
        step = step**0.5
    return None
