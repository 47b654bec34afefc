"""Screening then refinement: many cheap starts on a coarse grid, the best few refined at N.

A start costs about N: screening every cold start on a grid of ``N / 4`` intervals at a
loose tolerance and refining only the best distinct local optima (warm from the coarse
answer, resampled) finds the same optimum for a fraction of the cost when N is large.
"""

from __future__ import annotations

from collections.abc import Callable

from model.direct.solution import Solution
from model.search.context import Search

SCREEN_MIN = 40  # the coarsest screening grid (intervals)
SCREEN_OPTIONS = {"tol": 1e-5, "acceptable_tol": 1e-3, "max_iter": 300}  # unsettled by then: not a candidate
# a refinement starts next to its optimum: a small initial barrier parameter saves the iterations
# that would push it back into the interior (semitrailer road, N = 200: 32 instead of 66)
REFINE_OPTIONS = {"mu_init": 1e-4}
KEEP = 2  # distinct coarse optima refined at N
SAME = 1e-4  # relative objective difference below which two coarse optima count as one


def screening_intervals(intervals: int, screen: bool | int | None = None) -> int | None:
    """The coarse grid for ``intervals``, or None where screening would not pay.

    ``screen``: None for the default (N / 4 but at least SCREEN_MIN, used when N is at least
    three times that), True for that grid whenever it is coarser than N, False for none, an int
    for that grid.
    """
    if screen is False:
        return None
    coarse = max(SCREEN_MIN, intervals // 4) if screen is None or screen is True else int(screen)
    needed = 3 * coarse if screen is None else coarse + 1
    return coarse if intervals >= needed else None


def screen_starts(
    search: Search,
    coarse: int,
    passes: list[str],
    make_starts: Callable[[int, str], list[tuple[str, object]]],
) -> tuple[list[Solution], list[dict]]:
    """Solve every start of every pass on the coarse grid; the distinct optima, best first.

    ``make_starts(n, passing)`` gives (route label, Start) pairs. Returns the kept coarse
    solutions (at most KEEP) and one attempt record per start solved (the search's time limit
    may leave some out: ``Search.solve``).
    """
    found, attempts = [], []
    for passing in passes:
        routes, starts = zip(*make_starts(coarse, passing), strict=True)
        if search.skip(f"screening N={coarse} (pass {passing})", len(starts)):
            continue
        sols = search.solve(coarse, passing, starts, SCREEN_OPTIONS, analyse=False)
        for route, sol in zip(routes, sols, strict=False):
            attempts.append({"pass": passing, "route": f"screening N={coarse}: {route}", "status": sol.status,
                             "valid": None, "objective": sol.objective})  # fmt: skip
            if sol.status in ("optimal", "acceptable"):  # a guess for the refinement either way
                found.append(sol)
    return _distinct(sorted(found, key=lambda s: s.objective)), attempts


def _distinct(sols: list[Solution]) -> list[Solution]:
    kept: list[Solution] = []
    for sol in sols:
        if all(abs(sol.objective - k.objective) > SAME * max(1.0, abs(k.objective)) for k in kept):
            kept.append(sol)
        if len(kept) == KEEP:
            break
    return kept


__all__ = ["KEEP", "REFINE_OPTIONS", "SCREEN_OPTIONS", "screen_starts", "screening_intervals"]
