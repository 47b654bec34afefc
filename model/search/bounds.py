"""Bounds before search (issue 22, item 1): the road bounds with the Reeds-Shepp length, and the refusal they prove.

``road_bounds`` is ``model.analysis.bounds.geometric_bounds`` (steady swept annulus against the
ring, lane margin, start and goal poses, corridor passage, wound path length) with the shortest
Reeds-Shepp path of the reference point at the least turning radius added to the path-length
bounds (obstacles only lengthen it, so it stays a lower bound). ``refusal_from_bounds`` is what
the search calls first: the diagnosis naming the bound that proves the problem infeasible, or
None. It never refuses on the steady turn, which a U-turn or a stop-and-steer manoeuvre does not
need.
"""

from __future__ import annotations

from model.analysis.bounds import geometric_bounds
from model.problem.ocp import OCP
from model.search.paths import min_turning_radius, reeds_shepp


def reeds_shepp_length(ocp: OCP) -> float | None:
    """Length (m) of the shortest Reeds-Shepp path start to goal at the least turning radius, or None."""
    pose = (*ocp.vehicle.position, ocp.vehicle.roles.heading)
    if not all(k in ocp.final and k in ocp.initial for k in pose):
        return None
    rho = min_turning_radius(ocp.vehicle, ocp.bounds)
    if rho is None or rho == 0.0 or rho == float("inf"):
        return None
    start = tuple(ocp.initial[k] for k in pose)
    goal = tuple(ocp.final[k] for k in pose)
    return float(reeds_shepp(start, goal, rho).length)


def road_bounds(ocp: OCP) -> dict:
    """The bounds of a road problem before any search, with a verdict.

    Returns
    -------
    dict
        As ``model.analysis.bounds.geometric_bounds``, its ``path_length`` with ``reeds_shepp_m``
        where the vehicle has a least turning radius: ``verdict`` "infeasible" (``proofs`` give
        the numbers), "tight" (``tight`` gives the margins) or "free"; ``time_lower_bound_s``.
    """
    length = reeds_shepp_length(ocp)
    return geometric_bounds(ocp, {} if length is None else {"reeds_shepp_m": length})


def refusal_from_bounds(ocp: OCP) -> dict | None:
    """The diagnosis of a road problem a bound proves infeasible, or None (no road, or nothing proven).

    The diagnosis has ``kind`` "proven bound", ``bound`` (the first proof's name), ``proofs`` (all
    of them, with their numbers), ``bounds`` (the whole ``road_bounds``) and a one-line ``message``.
    """
    if ocp.road is None:
        return None
    bounds = road_bounds(ocp)
    if not bounds["proofs"]:
        return None
    first = bounds["proofs"][0]
    return {"kind": "proven bound", "bound": first["bound"], "proofs": bounds["proofs"], "bounds": bounds,
            "message": first["message"]}  # fmt: skip


__all__ = ["reeds_shepp_length", "refusal_from_bounds", "road_bounds"]
