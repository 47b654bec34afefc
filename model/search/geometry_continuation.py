"""Continuation in the geometry (issue 22, item 2): a relaxed road first, shrunk to the scenario's in steps.

Where the search's starts fail on a tight road, the same problem is posed on a roomier copy of
its ``Roundabout``: the outer curb ``RELAX_OUTER`` m further out, the inner edge of the ring
``RELAX_INNER`` m further in (never closer than ``MIN_ISLAND`` m to the centre), the apron open
to every body and each lane ``RELAX_LANE`` m wider. The start and goal poses stay the
scenario's (only the corridor changes). That road is solved from the search's start; then the
relaxation is scaled down by ``SCALES`` (1 -> 0.5 -> 0), each step warm-started from the last
step's trajectory (resampled); the last step is the scenario's own road. A relaxed step only has
to converge (its answer is a guess, not validated: ``step`` may skip the analysis); the scenario's
own road has to validate. A step that fails is tried again halfway between it and the last step
that did (down to MIN_STEP); the walk stops
when the time budget is spent or the steps get too small, and the best answer of the scenario's
own road is returned (or None), the relaxation it got to in ``record``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from model.direct.solution import Solution
from model.errors import InputError
from model.problem.ocp import OCP
from model.scene.road import Road
from model.scene.roundabout import Roundabout

RELAX_OUTER = 3.0  # m the outer curb moves out at scale 1
RELAX_INNER = 3.0  # m the ring's inner edge moves in at scale 1
RELAX_LANE = 1.0  # m each lane widens at scale 1
MIN_ISLAND = 0.5  # m: the relaxed island keeps at least this radius
SCALES = (1.0, 0.5, 0.0)
MIN_STEP = 0.05  # a halved step below this ends the walk


def relaxed_roundabout(rb: Roundabout, scale: float) -> Roundabout:
    """A copy of ``rb`` with the relaxation of the module docstring times ``scale`` (0: ``rb`` itself).

    The fillet radii and leg lengths are kept; where the wider lanes would overlap a neighbour the
    lanes stay as they are (the ring and apron alone are relaxed).
    """
    if scale <= 0.0:
        return rb
    outer = rb.outer_radius + RELAX_OUTER * scale
    inner = max(rb.inner_radius - RELAX_INNER * scale, min(rb.inner_radius, MIN_ISLAND + 1e-3))
    apron = max(0.0, min(rb.apron_width + RELAX_INNER * scale, inner - MIN_ISLAND))
    ring = {"inscribed_diameter": 2.0 * outer, "circulatory_width": outer - inner, "apron_width": apron,
            "apron_use": "all"}  # fmt: skip
    wider = tuple(dataclasses.replace(leg, lane_width=leg.lane_width + RELAX_LANE * scale) for leg in rb.legs)
    for legs in (wider, rb.legs):
        try:
            return dataclasses.replace(rb, **ring, legs=legs)
        except InputError:
            continue
    return rb


def relaxed_ocp(ocp: OCP, scale: float) -> OCP:
    """``ocp`` on the relaxed road of ``scale`` (same vehicle, bounds, poses and cost); ``ocp`` at 0.

    The route's start and goal distances are moved with the outer curb so the route's poses stay
    put along the leg axes; the OCP keeps the scenario's own initial and final values.
    """
    if scale <= 0.0 or ocp.road is None:
        return ocp
    rb = relaxed_roundabout(ocp.road.roundabout, scale)
    shift = rb.outer_radius - ocp.road.roundabout.outer_radius
    route = dataclasses.replace(ocp.road.route, start_distance=max(ocp.road.route.start_distance - shift, 1.0),
                                goal_distance=max(ocp.road.route.goal_distance - shift, 1.0))  # fmt: skip
    return dataclasses.replace(ocp, road=Road(rb, route), name=f"{ocp.name} (relaxed x{scale:g})")


Step = Callable[[OCP, Solution | None], Solution | None]


def shrink_road(
    ocp: OCP, step: Step, progress: Callable[[str], None], out_of_time: Callable[[], bool],
    reached: Callable[[Solution], bool] | None = None, scales: tuple[float, ...] | None = None,
) -> tuple[Solution | None, dict]:  # fmt: skip
    """Walk the relaxation from ``SCALES[0]`` down to the scenario's road (module docstring).

    Parameters
    ----------
    ocp : the scenario's problem (with a road).
    step : solves a problem from the last step's answer (None: the search's own start); returns
        the Solution or None (not begun for lack of time).
    progress : one line per step.
    out_of_time : True once the budget is spent (the walk stops).
    reached : whether an answer on the scenario's road ends the walk (default: it validates; the
        feasibility-first step also ends it on a converged answer a finer grid may cure).
    scales : the relaxations to walk (default ``SCALES``), from the roomiest to 0 (the scenario's road);
        a failed step is halved towards the last one that converged as with the default.

    Returns
    -------
    (Solution or None, dict)
        The answer on the scenario's own road (validated, or the last one tried, or None if never
        reached) and the
        record: the scales tried with their outcome, and the least relaxation that validated.
    """
    record: dict = {"scales": [], "least_validated_scale": None}
    last: Solution | None = None
    own: Solution | None = None
    todo, done = list(scales or SCALES), None
    while todo and not out_of_time():
        scale = todo.pop(0)
        sol = step(relaxed_ocp(ocp, scale), last)
        ok = sol is not None and ((reached or _validated)(sol) if scale == 0.0 else sol.status == "optimal")
        record["scales"].append({"scale": scale, "status": None if sol is None else sol.status, "valid": ok,
                                 "objective": None if sol is None else sol.objective})  # fmt: skip
        word = "validated" if scale == 0.0 and sol.ok else "converged, not validated" if scale == 0.0 else "converged"
        outcome = f"{word}, objective {sol.objective:.6g}" if ok else "failed"
        progress(f"geometry continuation: road relaxed x{scale:g}: {outcome}")
        if scale == 0.0 and ok:
            return sol, record | {"least_validated_scale": 0.0 if sol.ok else done}
        if scale == 0.0 and sol is not None:
            own = sol  # the scenario's road answered, not validated: kept unless a later try validates
        if ok:
            last, done = sol, scale
        elif done is not None and (done - scale) / 2 >= MIN_STEP:
            todo.insert(0, scale)
            todo.insert(0, (done + scale) / 2)
        else:
            break  # not even the roomiest road, or the steps got too small
        record["least_validated_scale"] = done
    return own, record


def _validated(sol: Solution) -> bool:
    return sol.ok


__all__ = ["MIN_ISLAND", "RELAX_INNER", "RELAX_LANE", "RELAX_OUTER", "SCALES", "relaxed_ocp", "relaxed_roundabout",
           "shrink_road"]  # fmt: skip
