"""A start's node values, and the pass directions a search tries: what every step of the search builds on.

``start_values`` turns a route name ("arc", "line", a Reeds-Shepp path, a smooth route of
``model.search.curves``) or a given trajectory into the node values of a start.
"""

from __future__ import annotations

import numpy as np

from model.analysis.columns import Columns, as_arrays
from model.direct.solve import Start
from model.problem.ocp import OCP
from model.search.curves import curve_guess, curve_routes
from model.search.guess import guess_final_time, initial_guess, reeds_shepp_guess, three_point_guess

THREE_POINT = "three-point"  # the forward-reverse-forward route through a road's ring (``three_point_guess``)


def passes_to_try(ocp: OCP) -> list[str]:
    """'auto' with an obstacle tries both directions; without one there is no pass."""
    if not ocp.obstacles:
        return ["none"]
    return ["ccw", "cw"] if ocp.passing == "auto" else [ocp.passing]


def reeds_shepp_ends(start: tuple[float, str]) -> str | None:
    """The Reeds-Shepp filter of a start's route ("reeds-shepp-reverse-in" -> "reverse-in")."""
    return start[1].removeprefix("reeds-shepp-") if start[1].startswith("reeds-shepp-") else None


def start_values(
    ocp: OCP, intervals: int, passing: str, guess: Columns | None, scale: float = 1.0, route: str = "arc"
) -> Start:
    """A start's node values: a given trajectory resampled, or the geometric guess of ``route``."""
    free = ocp.cost.free_final_time
    if guess is not None:
        return Start(resample(ocp, guess, intervals), float(np.asarray(guess["t"])[-1]) if free else None)
    if route.startswith("reeds-shepp"):
        values, tf = reeds_shepp_guess(ocp, intervals, scale, reeds_shepp_ends((scale, route)))
        return Start(values, tf if free else None)
    if route == THREE_POINT:
        values, tf = three_point_guess(ocp, intervals, scale)
        return Start(values, tf if free else None)
    if route not in ("arc", "line"):
        values, tf = curve_guess(ocp, curve_routes(ocp)[route], intervals, scale)
        return Start(values, tf if free else None)
    tf_guess = guess_final_time(ocp, passing) * (scale if free else 1.0)
    return Start(initial_guess(ocp, passing, intervals, tf_guess, route), tf_guess if free else None)


def distinct_starts(starts: list[Start]) -> tuple[list[Start], list[int]]:
    """The starts that differ, and for each start given the index of its equal among them.

    Two starts are equal when their final-time guesses and every node value are equal: one
    deterministic Ipopt run from either gives the same answer, so solving it twice buys nothing
    (Reeds-Shepp paths reversing in and out are often the same path; so are a smooth route's
    tangent lengths on a straight run).
    """
    kept: list[Start] = []
    index: list[int] = []
    for start in starts:
        same = next((i for i, k in enumerate(kept) if _equal(k, start)), None)
        if same is None:
            kept.append(start)
            same = len(kept) - 1
        index.append(same)
    return kept, index


def _equal(a: Start, b: Start) -> bool:
    if not (isinstance(a, Start) and isinstance(b, Start)):  # anything else is never merged
        return False
    return (a.final_time == b.final_time and a.values.keys() == b.values.keys()
            and all(np.array_equal(a.values[k], b.values[k]) for k in a.values))  # fmt: skip


def resample(ocp: OCP, traj: Columns, intervals: int) -> dict[str, np.ndarray]:
    """A trajectory's states and controls on a uniform grid of ``intervals`` steps (normalised time)."""
    cols = as_arrays(traj)
    s_old = cols["t"] / cols["t"][-1]
    s_new = np.linspace(0.0, 1.0, intervals + 1)
    names = ocp.vehicle.states + ocp.vehicle.controls
    return {n: np.interp(s_new, s_old, cols[n]) for n in names}


__all__ = ["THREE_POINT", "distinct_starts", "passes_to_try", "reeds_shepp_ends", "resample", "start_values"]
