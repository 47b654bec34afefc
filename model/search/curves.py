"""Smooth routes for starts: chains of cubic Hermite curves between poses, driven forwards or reversing.

Where a steering-rate bound makes the Reeds-Shepp arcs a poor guess, a time-optimal or tight
energy manoeuvre is often found from a smooth curve instead: straight at the goal with short or
long tangents, reversing first and turning, driving past the goal and reversing into it, reversing
all the way, or beside each obstacle on a chosen side. Each route is a list of legs
(from pose, to pose, gear, tangent scale); ``curve_guess`` drives it at constant speed.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from model.problem.ocp import OCP
from model.search.guess import trailer_heading

Pose = tuple[float, float, float]
Leg = tuple[Pose, Pose, int, float]  # from pose, to pose, gear (+1 / -1), tangent scale
SAMPLES = 200  # points per leg
TANGENTS = (0.5, 1.0, 2.0)  # Hermite tangent lengths, as multiples of the chord
TURN = 0.6  # rad: the heading change of a reversing-first leg
TF_SCALES = (1.0, 2.0)  # Tf guesses of a route's start (free final time without a first guess of it)


def hermite(a: Pose, b: Pose, gear: int, scale: float, m: int = SAMPLES) -> np.ndarray:
    """(m, 2) points of the cubic Hermite curve from pose ``a`` to pose ``b``; gear -1 reverses along it."""
    p0, p1 = np.array(a[:2]), np.array(b[:2])
    k = gear * scale * float(np.linalg.norm(p1 - p0))
    t0, t1 = k * np.array([math.cos(a[2]), math.sin(a[2])]), k * np.array([math.cos(b[2]), math.sin(b[2])])
    s = np.linspace(0.0, 1.0, m)[:, None]
    return (2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * t0 + (3 * s**2 - 2 * s**3) * p1 + (s**3 - s**2) * t1


def end_poses(ocp: OCP) -> tuple[Pose, Pose] | None:
    """Start and goal poses (a free final heading: the start-goal bearing); None without a goal position."""
    ini, fin, r = ocp.initial, ocp.final, ocp.vehicle.roles
    if not all(k in fin for k in r.position) or not all(k in ini for k in (*r.position, r.heading)):
        return None
    start = (float(ini[r.x]), float(ini[r.y]), float(ini[r.heading]))
    bearing = math.atan2(fin[r.y] - start[1], fin[r.x] - start[0])
    return start, (float(fin[r.x]), float(fin[r.y]), float(fin.get(r.heading, bearing)))


def curve_routes(ocp: OCP) -> dict[str, list[Leg]]:
    """Every route that applies to ``ocp`` (off the road, a goal position given): name -> legs."""
    ends = end_poses(ocp)
    if ocp.road is not None or ends is None:
        return {}
    start, goal = ends
    back = 0.25 * math.dist(start[:2], goal[:2]) + 0.1
    routes = {f"hermite-x{k:g}": [(start, goal, 1, k)] for k in TANGENTS}
    for side, turn in (("left", TURN), ("right", -TURN)):
        p = (start[0] - back * math.cos(start[2]), start[1] - back * math.sin(start[2]), start[2] + turn)
        routes[f"reverse-first-{side}"] = [(start, p, -1, 1.0), (p, goal, 1, 1.0)]
    q = (goal[0] + back * math.cos(goal[2]), goal[1] + back * math.sin(goal[2]), goal[2])
    routes["reverse-into-goal"] = [(start, q, 1, 1.0), (q, goal, -1, 1.0)]
    routes["all-reverse"] = [(start, goal, -1, 1.0)]
    for sides in itertools.product("LR", repeat=len(ocp.obstacles)) if ocp.obstacles else ():
        stops = [start, *_beside(ocp, start, goal, sides), goal]
        routes["sides-" + "".join(sides)] = [(a, b, 1, 1.0) for a, b in itertools.pairwise(stops)]
    return routes


def _beside(ocp: OCP, start: Pose, goal: Pose, sides: tuple[str, ...]) -> list[Pose]:
    """A pose beside each obstacle (L: left of the start-goal line), ordered along the line."""
    e = np.array(goal[:2]) - np.array(start[:2])
    e /= max(float(np.linalg.norm(e)), 1e-9)
    normal, heading = np.array([-e[1], e[0]]), math.atan2(e[1], e[0])
    points = []
    for ob, side in zip(ocp.obstacles, sides, strict=True):
        w = np.array(ob.center, dtype=float) + (1 if side == "L" else -1) * normal * (1.3 * ob.keep_out + 0.05)
        points.append((float(np.dot(w - np.array(start[:2]), e)), (float(w[0]), float(w[1]), heading)))
    return [pose for _, pose in sorted(points)]


def tf_scales(ocp: OCP) -> tuple[float, ...]:
    """The Tf scales that make distinct starts of one route: TF_SCALES where ``curve_guess`` reads its
    ``tf_scale`` (a free final time with no first guess), else (1.0,): with ``problem.final_time``
    given, every scale is the same start, and the same start solved twice is the same answer twice
    (the paper's time scenarios screened each route twice before)."""
    return TF_SCALES if ocp.cost.free_final_time and ocp.final_time is None else (1.0,)


def curve_guess(ocp: OCP, legs: list[Leg], n: int, tf_scale: float = 1.0) -> tuple[dict[str, np.ndarray], float]:
    """Node values of every state and control driving ``legs`` at constant speed, and the final time.

    Parameters
    ----------
    ocp : OCP
        The problem (vehicle, bounds, initial values, final time if fixed).
    legs : list of (Pose, Pose, int, float)
        From pose, to pose, gear (+1 forwards, -1 reversing), tangent length as a multiple of
        the chord; poses are vehicle headings.
    n : int
        Number of intervals; the n + 1 nodes are equally spaced in arc length.
    tf_scale : float
        Free final time without ``problem.final_time`` only (``tf_scales``): the guess's time is
        its length over 70 % of the top speed, plus 1 s, times this.

    Returns
    -------
    dict of ndarray, float
        Every state and control (the steering phi = atan(d kappa), the trailer heading integrated
        along the path, other
        states interpolated from their initial to their final values; all clipped to their
        bounds), and the final time.
    """
    pts, gears = _chain(legs)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    length = max(float(s[-1]), 1e-6)
    tf = ocp.final_time if ocp.final_time is not None else tf_scale * (length / (0.7 * (ocp.max_speed() or 1.0)) + 1.0)
    motion = np.arctan2(np.gradient(pts[:, 1]), np.gradient(pts[:, 0]))
    heading = np.unwrap(motion + np.where(gears < 0, math.pi, 0.0))
    v, r = ocp.vehicle, ocp.vehicle.roles
    heading += 2 * math.pi * round((ocp.initial[r.heading] - heading[0]) / (2 * math.pi))
    kappa = gears * np.gradient(heading) / np.maximum(np.gradient(s), 1e-9)
    at = np.linspace(0.0, s[-1], n + 1)
    values = {r.x: np.interp(at, s, pts[:, 0]), r.y: np.interp(at, s, pts[:, 1]), r.heading: np.interp(at, s, heading)}
    direction = np.sign(np.interp(at, s, gears))
    d = v.parameter_values().get("wheelbase")
    if r.steering is not None and d is not None:
        values[r.steering] = np.arctan(d * np.interp(at, s, kappa))
    for trailer in r.trailers:
        values[trailer] = trailer_heading(ocp, values[r.heading], np.full(n + 1, at[1] - at[0]), direction)
    for name in v.states:
        if name not in values:
            a = ocp.initial.get(name, 0.0)
            values[name] = a + (ocp.final.get(name, a) - a) * at / length
    t = np.linspace(0.0, tf, n + 1)
    controls = {r.speed: direction * length / tf}
    if r.steering_rate is not None:
        controls[r.steering_rate] = np.gradient(values[r.steering], t) if r.steering in values else 0 * t
    values.update({c: controls.get(c, np.zeros(n + 1)) for c in v.controls})
    return {k: _clip(val, ocp.bounds.get(k)) for k, val in values.items()}, float(tf)


def _chain(legs: list[Leg]) -> tuple[np.ndarray, np.ndarray]:
    """The legs' Hermite points joined (shared ends once) and the gear at each point."""
    pts, gears = [], []
    for a, b, gear, scale in legs:
        p = hermite(a, b, gear, scale)
        pts.append(p if not pts else p[1:])
        gears.append(np.full(len(pts[-1]), float(gear)))
    return np.vstack(pts), np.concatenate(gears)


def _clip(values: np.ndarray, bounds: tuple[float, float] | None) -> np.ndarray:
    return values if bounds is None else np.clip(values, bounds[0], bounds[1])


__all__ = ["curve_guess", "curve_routes", "end_poses", "hermite"]
