"""Bounds of a road problem before any search: what fits, what cannot, and how short the time can be.

Everything here is geometry and closed forms (no solver, no search), so ``roundabout check`` can
print it and the search can refuse a problem in seconds (``model.search.bounds`` adds the
Reeds-Shepp length and ``refusal_from_bounds``).

Steady turn. At a constant steering angle the tractor's rear axle runs on R = d / tan(phi) and,
with a trailer, the trailer axle on R_t = sqrt(R^2 + h^2 - L^2) (off-axle hitch h, trailer
wheelbase L); each body is tangent to its axle's circle at its reference point, so in closed form
its outer swept radius is hypot(R_b + w/2, max(front, rear overhang)) and its inner one
max(R_b - w/2, 0) (the foot of the inner side lies on the body). The swept annulus at full lock
is that of the least R; a circulating steady turn fits the ring if some R >= R_min keeps every
body's outer radius within Ro and its inner radius outside the ring's inner edge (the island's
edge for a body allowed on the apron). Both radii grow with R while the swept width shrinks, so
the best R is the one whose outer radius is Ro; the margin is what is left inside.

A U-turn or a stop-and-steer manoeuvre does not need a steady circulating turn: the steady turn
only says "tight", never "infeasible". Infeasibility is claimed only where it is proven:

- a body at the start pose (or at the goal pose, where the pose fixes it) leaves the corridor
  (exact rectangle against the exact corridor);
- the tractor cannot get from start to goal: its largest inscribed disc (diameter
  min(length, width), centred on its axis) must stay inside the corridor, so its centre stays in
  the corridor eroded by that radius; if start and goal centres lie in different pieces of the
  eroded corridor (computed by shapely, with 1 cm of slack in the vehicle's favour against the
  polygon tolerance), no motion exists;
- the tractor cannot go round: its inscribed disc's centre must cross every ray from the centre
  between its start and goal angles (``ring_passage``), and some ray misses the eroded corridor;
- a fixed final time below the lower bound on the time.

Time. The tractor's reference point (rear axle centre) lies inside its body, so outside the disc
of radius r_in the body may not enter (Ri, or the island's radius where the apron is allowed).
The validation requires the path to leave by the route's exit (``exit_taken``), which fixes the
angle the reference point sweeps round the centre; the shortest path from start to goal that
sweeps that angle outside the disc (tangent, arc, tangent) is a lower bound on the path length,
with the straight-line distance; at the top speed, a lower bound on the time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import SimpleNamespace

import numpy as np

from model.analysis.bodies import clearances
from model.problem.ocp import OCP, end_pose
from model.scene.roundabout import apron_allowed, sweep
from model.vehicles import Body, Vehicle

TIGHT_MARGIN = 0.5  # m: a ring or lane margin below this makes the problem "tight"
POSE_TOL = 1e-6  # m: a body at the start or goal pose further outside its corridor than this is a proof
EROSION_SLACK = 0.01  # m: the eroded corridor is eroded by this much less (in the vehicle's favour)


# --------------------------------------------------------------------------- steady turn


def steady_radii(vehicle: Vehicle, bodies: Mapping[str, Body], radius: float) -> dict[str, dict[str, float]]:
    """Each body's axle radius and its outer and inner swept radii in the steady turn of rear-axle radius R.

    Parameters
    ----------
    vehicle : Vehicle
        A truck, tricycle or tractor-trailer (parameters d, and h, L with a trailer).
    bodies : mapping
        Body name ("vehicle", "trailer") -> Body.
    radius : float
        R, the tractor's rear-axle radius, m (R^2 + h^2 >= L^2 with a trailer).

    Returns
    -------
    dict
        Body name -> ``axle_radius``, ``outer``, ``inner`` (m).
    """
    p = vehicle.parameter_values()
    axle = {"vehicle": radius}
    if "trailer_wheelbase" in p:
        axle["trailer"] = math.sqrt(max(radius * radius + p["hitch_offset"] ** 2 - p["trailer_wheelbase"] ** 2, 0.0))
    out = {}
    for name, body in bodies.items():
        r, half = axle[name], body.width / 2.0
        out[name] = {"axle_radius": r, "outer": math.hypot(r + half, max(body.front, body.rear_overhang)),
                     "inner": max(r - half, 0.0)}  # fmt: skip
    return out


def steady_articulation(vehicle: Vehicle, radius: float) -> float:
    """theta - theta1 in the steady turn of rear-axle radius R: asin(L / sqrt(R^2 + h^2)) - atan(h / R)."""
    p = vehicle.parameter_values()
    hitch = math.hypot(radius, p["hitch_offset"])
    return math.asin(min(p["trailer_wheelbase"] / hitch, 1.0)) - math.atan2(p["hitch_offset"], radius)


def _side(ocp: OCP, name: str) -> float | None:
    """The bound on ``name`` to the side the ring turns (the upper one for counter-clockwise circulation)."""
    if name not in ocp.bounds:
        return None
    lo, hi = ocp.bounds[name]
    return max(0.0, hi if ocp.road is None or ocp.road.roundabout.circulation > 0 else -lo)


def least_steady_radius(ocp: OCP) -> tuple[float, float | None] | None:
    """(R_min, phi_max) of a steady turn in the circulation direction; None for a vehicle without steering.

    R_min is the largest of d / tan(phi_max) (phi_max the steering bound to the side the ring
    turns: left for counter-clockwise circulation), the least R with a steady trailer
    (R^2 + h^2 >= L^2) and the least R whose steady articulation keeps within its bound; inf if
    the vehicle cannot steer to that side.
    """
    v = ocp.vehicle
    p = v.parameter_values()
    if v.roles.steering is None or "wheelbase" not in p:
        return None
    trailer = "trailer_wheelbase" in p
    least = math.sqrt(max(p["trailer_wheelbase"] ** 2 - p["hitch_offset"] ** 2, 0.0)) if trailer else 0.0
    phi_max = _side(ocp, v.roles.steering)
    if phi_max is not None and phi_max <= 0.0:
        return math.inf, 0.0
    if phi_max is not None and phi_max < math.pi / 2:
        least = max(least, p["wheelbase"] / math.tan(phi_max))
    limit = _side(ocp, "articulation") if trailer else None
    if limit is not None and steady_articulation(v, least) > limit:
        lo, hi = least, max(2.0 * least, 1.0)
        while steady_articulation(v, hi) > limit:
            hi *= 2.0
        while hi - lo > 1e-9 * hi:  # bisection: the steady articulation falls as R grows
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if steady_articulation(v, mid) > limit else (lo, mid)
        least = hi
    return least, phi_max


def _summary(radii: Mapping[str, Mapping[str, float]]) -> dict:
    outer = max(radii, key=lambda b: radii[b]["outer"])
    inner = min(radii, key=lambda b: radii[b]["inner"])
    return {"outer": radii[outer]["outer"], "outer_body": outer, "inner": radii[inner]["inner"],
            "inner_body": inner, "bodies": {b: dict(r) for b, r in radii.items()}}  # fmt: skip


def swept_annulus(ocp: OCP) -> dict | None:
    """The steady swept annulus at full lock (the least steady radius): outer and inner radii, per body."""
    least = least_steady_radius(ocp)
    if least is None or not ocp.bodies or math.isinf(least[0]):
        return None
    R, phi = least
    radii = _summary(steady_radii(ocp.vehicle, ocp.bodies, R))
    return {"R": R, "phi": phi} | radii  # names: the summary's key for the steering angle


def allowed_inner_radius(ocp: OCP, body: str) -> float:
    """The least distance from the centre body ``body`` may come to: the island's with the apron, else Ri."""
    rb = ocp.road.roundabout
    return rb.island_radius if apron_allowed(rb, body) else rb.inner_radius


def ring_fit(ocp: OCP) -> dict | None:
    """Whether a circulating steady turn fits the ring, and with what margin (m, < 0: by how much not).

    ``R`` is the rear-axle radius whose outer swept radius is Ro (or R_min if even that is too
    wide); ``outer_margin`` = Ro - outer, ``inner_margin`` the least inner radius minus the body's
    allowed inner radius (``inner_body``). ``margin``: the radial slack the steady swept annulus
    leaves in the ring (the inner margin at that R), or, where no steady turn fits, the smaller
    (negative) of the two margins at R_min.
    """
    least = least_steady_radius(ocp)
    if least is None or not ocp.bodies or math.isinf(least[0]):
        return None
    rb = ocp.road.roundabout
    ro = rb.outer_radius

    def outer(R: float) -> float:
        return max(r["outer"] for r in steady_radii(ocp.vehicle, ocp.bodies, R).values())

    lo, hi = least[0], ro
    fits = outer(lo) <= ro
    if fits:
        while hi - lo > 1e-9 * ro:  # bisection: outer(R) grows with R, and outer(Ro) > Ro
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if outer(mid) <= ro else (lo, mid)
    radii = steady_radii(ocp.vehicle, ocp.bodies, lo)
    inner = {b: r["inner"] - allowed_inner_radius(ocp, b) for b, r in radii.items()}
    worst = min(inner, key=inner.get)
    outer_margin = ro - max(r["outer"] for r in radii.values())
    margin = inner[worst] if fits else min(outer_margin, inner[worst])
    return {"R": lo, "outer_margin": outer_margin, "inner_margin": inner[worst], "inner_body": worst,
            "margin": margin, "fits": margin >= 0.0, "bodies": radii}  # fmt: skip


def lane_margin(ocp: OCP) -> dict | None:
    """The narrowest lane of the route against the widest body (the width a body needs on a straight)."""
    if not ocp.bodies:
        return None
    road = ocp.road
    legs = {road.route.enter: "entry", road.exit_leg: "exit"}
    lanes = {f"leg {i} {lane} lane": road.roundabout.legs[i].lane_width for i, lane in legs.items()}
    narrowest = min(lanes, key=lanes.get)
    body = max(ocp.bodies, key=lambda b: ocp.bodies[b].width)
    width = ocp.bodies[body].width
    return {"lane": narrowest, "lane_width": lanes[narrowest], "body": body, "body_width": width,
            "margin": lanes[narrowest] - width}  # fmt: skip


# --------------------------------------------------------------------------- proofs


def pose_clearances(ocp: OCP) -> dict:
    """Exact clearance (m, < 0: outside) of each body whose pose the start or the goal fixes.

    The trailer's pose is fixed only where its angle ``theta1`` is given (at the start always).
    """
    v, r = ocp.vehicle, ocp.vehicle.roles
    out = {}
    for where, values, rest in (("start", ocp.initial, None), ("goal", ocp.final, ocp.initial)):
        free_trailer = any(t not in values for t in r.trailers)
        states = {s: np.array([float(val)]) for s, val in end_pose(v, values, rest).items()}
        fixed = {b: body for b, body in ocp.bodies.items() if not (free_trailer and b == "trailer")}
        view = SimpleNamespace(vehicle=v, bodies=fixed, road=ocp.road)
        out[where] = {b: float(c[0]) for b, c in clearances(view, states).items()}
    return out


def _pose_names(ocp: OCP) -> tuple[str, str, str]:
    """The names of the reference point's x, y and heading."""
    r = ocp.vehicle.roles
    return r.x, r.y, r.heading


def _midpoint(body: Body, x: float, y: float, heading: float) -> tuple[np.ndarray, float]:
    """Centre and radius of the body's largest inscribed disc centred on its axis."""
    along = (body.front - body.rear_overhang) / 2.0
    return np.array([x + along * math.cos(heading), y + along * math.sin(heading)]), min(body.length, body.width) / 2


def corridor_passage(ocp: OCP) -> dict | None:
    """Whether the tractor's inscribed disc can travel from its start to its goal centre inside the corridor.

    Returns None without a tractor body or a fixed goal pose, else ``connected``, the disc's
    ``radius`` and the number of ``pieces`` of the eroded corridor.
    """
    import shapely

    body, pose = ocp.bodies.get("vehicle"), _pose_names(ocp)
    if body is None or not all(k in ocp.final for k in pose):
        return None
    a, radius = _midpoint(body, *(ocp.initial[k] for k in pose))
    b, _ = _midpoint(body, *(ocp.final[k] for k in pose))
    region = ocp.road.corridor("vehicle")
    eroded = region.polygon.buffer(-(radius - EROSION_SLACK - region.tol))
    pieces = list(getattr(eroded, "geoms", [eroded])) if not eroded.is_empty else []
    pa, pb = shapely.Point(a), shapely.Point(b)
    home = [i for i, g in enumerate(pieces) if g.covers(pa)], [i for i, g in enumerate(pieces) if g.covers(pb)]
    connected = bool(set(home[0]) & set(home[1]))
    return {"connected": connected, "radius": radius, "pieces": len(pieces), "start_inside": bool(home[0]),
            "goal_inside": bool(home[1])}  # fmt: skip


# --------------------------------------------------------------------------- time


def required_sweep(ocp: OCP) -> float:
    """The angle (rad) the reference point must sweep round the centre in the circulation direction.

    The validation's ``exit_taken`` counts round((swept - delta) / 2 pi) extra loops (delta the
    exit's angle from the entry), so an admissible path sweeps the one angle congruent to the
    goal's polar angle minus the start's that lies within pi of delta.
    """
    road = ocp.road
    rb, c = road.roundabout, np.asarray(road.roundabout.center)
    px, py = ocp.vehicle.position
    a0 = math.atan2(ocp.initial[py] - c[1], ocp.initial[px] - c[0])
    a1 = math.atan2(ocp.final[py] - c[1], ocp.final[px] - c[0])
    delta = rb.circulation * sweep(rb, road.route)  # in (0, 2 pi]
    base = (rb.circulation * (a1 - a0)) % (2 * math.pi)
    candidates = [base + 2 * math.pi * m for m in range(-2, 3) if abs(base + 2 * math.pi * m - delta) <= math.pi]
    return min(candidates, key=abs, default=0.0)


def ring_passage(ocp: OCP, rays: int = 720) -> dict | None:
    """Whether the tractor's inscribed disc can cross every ray from the centre its path must cross.

    The reference point lies in the tractor's body, which keeps out of the inner disc, so the
    polar angles of the reference point and of the disc's centre differ by less than pi all the
    way: the centre's unwrapped angle runs from its start value to its goal value (the required
    sweep plus the two offsets at the poses), crossing every ray in between. A ray that the
    eroded corridor (see ``corridor_passage``) does not meet cannot be crossed.

    Returns None without a tractor body, a fixed goal pose or an inner disc; else ``sweep_rad``
    of the disc's centre, ``blocked_deg`` (polar angles, degrees, of the rays it cannot cross,
    empty if none) and the disc ``radius``.
    """
    import shapely

    body = ocp.bodies.get("vehicle")
    inner = allowed_inner_radius(ocp, "vehicle") if body is not None else 0.0
    if body is None or inner <= 0.0 or not all(k in ocp.final for k in _pose_names(ocp)):
        return None
    rb = ocp.road.roundabout
    c, turn = np.asarray(rb.center), rb.circulation
    px, py = ocp.vehicle.position
    ends = []
    for pose in (ocp.initial, ocp.final):
        mid, radius = _midpoint(body, *(pose[k] for k in _pose_names(ocp)))
        ref = math.atan2(pose[py] - c[1], pose[px] - c[0])
        offset = (math.atan2(mid[1] - c[1], mid[0] - c[0]) - ref + math.pi) % (2 * math.pi) - math.pi
        ends.append((ref, offset))
    swept = required_sweep(ocp) + turn * (ends[1][1] - ends[0][1])
    start = ends[0][0] + ends[0][1]
    region = ocp.road.corridor("vehicle")
    eroded = region.polygon.buffer(-(radius - EROSION_SLACK - region.tol))
    reach = rb.outer_radius + max(g.length for g in rb.legs) + 1.0
    blocked = []
    for s in np.linspace(0.0, swept, rays + 2)[1:-1]:
        angle = start + turn * s
        ray = shapely.LineString([tuple(c), tuple(c + reach * np.array([math.cos(angle), math.sin(angle)]))])
        if not eroded.intersects(ray):
            blocked.append(math.degrees(angle) % 360.0)
    return {"sweep_rad": float(swept), "blocked_deg": blocked, "radius": radius}


def wound_length(a: np.ndarray, b: np.ndarray, radius: float, angle: float) -> float:
    """Shortest path from a to b (relative to the centre) sweeping ``angle`` round the disc of ``radius``.

    Tangent from a, arc, tangent to b when the angle exceeds the two tangent angles; else the chord.
    """
    ra, rb = float(np.hypot(*a)), float(np.hypot(*b))
    radius = min(radius, ra, rb)
    ta, tb = math.acos(radius / ra) if ra > 0 else 0.0, math.acos(radius / rb) if rb > 0 else 0.0
    if angle > ta + tb:
        return (
            math.sqrt(max(ra * ra - radius * radius, 0.0))
            + math.sqrt(max(rb * rb - radius * radius, 0.0))
            + radius * (angle - ta - tb)
        )
    return math.sqrt(max(ra * ra + rb * rb - 2 * ra * rb * math.cos(angle), 0.0))


def path_length_bound(ocp: OCP) -> dict | None:
    """Lower bounds on the reference point's path length: straight line and the wound path round the inner disc."""
    px, py = ocp.vehicle.position
    if not all(k in ocp.final for k in (px, py)):
        return None
    c = np.asarray(ocp.road.roundabout.center)
    a = np.array([ocp.initial[px], ocp.initial[py]]) - c
    b = np.array([ocp.final[px], ocp.final[py]]) - c
    inner = allowed_inner_radius(ocp, "vehicle") if "vehicle" in ocp.bodies else 0.0
    angle = abs(required_sweep(ocp))
    return {"straight_m": float(np.hypot(*(b - a))), "wound_m": wound_length(a, b, inner, angle),
            "sweep_rad": angle, "inner_radius_m": inner}  # fmt: skip


# --------------------------------------------------------------------------- all of it


def geometric_bounds(ocp: OCP, path_lengths: Mapping[str, float] | None = None) -> dict:
    """Every bound of a road problem, the proofs of infeasibility and a verdict.

    Parameters
    ----------
    ocp : OCP
        A problem with a ``road``.
    path_lengths : mapping, optional
        Further lower bounds on the reference point's path length (m) by name (the search adds
        the Reeds-Shepp length); the longest of all gives the time bound.

    Returns
    -------
    dict
        ``swept_annulus``, ``ring_fit``, ``lane``, ``pose_clearance``, ``corridor_passage``,
        ``ring_passage``, ``path_length`` (m), ``time_lower_bound_s``; ``proofs`` (each with ``bound``,
        its numbers and a ``message``), ``tight`` (the reasons), ``verdict`` ("infeasible", "tight" or "free").
    """
    if ocp.road is None:
        raise ValueError("road bounds need a problem with a [roundabout] and a [route]")
    out: dict = {"swept_annulus": swept_annulus(ocp), "ring_fit": ring_fit(ocp), "lane": lane_margin(ocp)}
    out["pose_clearance"] = pose_clearances(ocp) if ocp.bodies else None
    out["corridor_passage"] = corridor_passage(ocp)
    out["ring_passage"] = ring_passage(ocp)
    lengths = path_length_bound(ocp) or {}
    lengths |= dict(path_lengths or {})
    out["path_length"] = lengths
    numbers = [v for k, v in lengths.items() if k.endswith("_m") and k != "inner_radius_m"]
    speed = ocp.max_speed()
    out["time_lower_bound_s"] = max(numbers) / speed if numbers and speed else None
    out["proofs"] = proofs(ocp, out)
    out["tight"] = tight_reasons(out)
    out["verdict"] = "infeasible" if out["proofs"] else "tight" if out["tight"] else "free"
    return out


def proofs(ocp: OCP, bounds: Mapping) -> list[dict]:
    """The bounds that prove the problem infeasible, each with its numbers and a one-line message."""
    found = []
    for where, per_body in (bounds["pose_clearance"] or {}).items():
        for body, value in per_body.items():
            if value < -POSE_TOL:
                found.append({"bound": f"{where} pose", "body": body, "clearance_m": value,
                              "message": f"infeasible: at the {where} pose the {body}'s rectangle lies "
                              f"{-value:.3g} m outside its corridor"})  # fmt: skip
    passage = bounds["corridor_passage"]
    if passage is not None and not passage["connected"] and passage["start_inside"] and passage["goal_inside"]:
        found.append({"bound": "corridor passage", "body": "vehicle", "disc_diameter_m": 2 * passage["radius"],
                      "message": f"infeasible: a disc of {2 * passage['radius']:.3g} m (the tractor's inscribed "
                      "disc) cannot pass from the start to the goal inside the corridor "
                      f"({passage['pieces']} separate pieces once eroded by its radius)"})  # fmt: skip
    ring = bounds["ring_passage"]
    if ring is not None and ring["blocked_deg"] and not any(p["bound"] == "corridor passage" for p in found):
        rb = ocp.road.roundabout
        found.append({"bound": "ring passage", "body": "vehicle", "disc_diameter_m": 2 * ring["radius"],
                      "blocked_deg": [ring["blocked_deg"][0], ring["blocked_deg"][-1]],
                      "ring_room_m": rb.outer_radius - allowed_inner_radius(ocp, "vehicle"),
                      "message": f"infeasible: the route must go {math.degrees(abs(ring['sweep_rad'])):.0f} deg "
                      f"round the centre, but a disc of {2 * ring['radius']:.3g} m (the tractor's inscribed disc) "
                      f"cannot cross the ray at {ring['blocked_deg'][0]:.0f} deg: the ring leaves "
                      f"{rb.outer_radius - allowed_inner_radius(ocp, 'vehicle'):.3g} m between the outer curb and "
                      "the edge the tractor may not cross"})  # fmt: skip
    bound = bounds["time_lower_bound_s"]
    if bound is not None and not ocp.cost.free_final_time and ocp.final_time is not None and ocp.final_time < bound:
        found.append({"bound": "time", "final_time_s": ocp.final_time, "time_lower_bound_s": bound,
                      "message": f"infeasible: the final time {ocp.final_time:g} s is below {bound:.4g} s, "
                      f"the shortest admissible path at the top speed {ocp.max_speed():g} m/s"})  # fmt: skip
    return found


def tight_reasons(bounds: Mapping) -> list[str]:
    """Why a problem is tight: a steady circulating turn that does not fit or fits narrowly, a narrow lane."""
    reasons = []
    fit = bounds["ring_fit"]
    if fit is not None and fit["margin"] < TIGHT_MARGIN:
        what = "leaves" if fit["fits"] else "does not fit the ring: short by"
        reasons.append(
            f"the steady circulating turn {what} {abs(fit['margin']):.3g} m "
            f"(outer margin {fit['outer_margin']:.3g} m, inner {fit['inner_margin']:.3g} m, "
            f"{fit['inner_body']})"
        )
    lane = bounds["lane"]
    if lane is not None and lane["margin"] < TIGHT_MARGIN:
        reasons.append(
            f"the {lane['lane']} is {lane['lane_width']:g} m for a {lane['body_width']:g} m wide "
            f"{lane['body']} ({lane['margin']:.3g} m to spare)"
        )
    return reasons


__all__ = ["TIGHT_MARGIN", "corridor_passage", "geometric_bounds", "lane_margin", "least_steady_radius",
           "path_length_bound", "pose_clearances", "proofs", "required_sweep", "ring_fit", "ring_passage",
           "steady_articulation", "steady_radii", "swept_annulus", "tight_reasons", "wound_length"]  # fmt: skip
