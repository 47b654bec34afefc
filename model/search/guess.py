"""A first guess for the NLP: drive along a line, or around the first obstacle."""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from model.problem.ocp import OCP
from model.search.paths import (
    Path,
    integrated_speed,
    limited_path_guess,
    min_turning_radius,
    path_guess,
    reeds_shepp,
    trailer_angle,
)
from model.vehicles import sym


def guess_final_time(ocp: OCP, passing: str) -> float:
    """The given final time, or path length over 70 % of the top speed."""
    if ocp.final_time is not None:
        return float(ocp.final_time)
    s = np.linspace(0.0, 1.0, 201)
    x, y = _path(ocp, passing, s)
    length = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
    return max(length, 0.1) / (0.7 * (ocp.max_speed() or 1.0)) + 1.0


def initial_guess(ocp: OCP, passing: str, n: int, tf: float, route: str = "arc") -> dict[str, np.ndarray]:
    """Node values (n + 1 of each) of every state and control.

    ``route``: "arc" goes around the first obstacle in the ``passing`` direction;
    "line" drives straight at the goal and leaves the detour to the solver.
    """
    v, r = ocp.vehicle, ocp.vehicle.roles
    s = np.linspace(0.0, 1.0, n + 1)
    x, y = _path(ocp, passing if route == "arc" else "none", s)
    dx, dy = np.gradient(x, s), np.gradient(y, s)
    heading = np.unwrap(np.arctan2(dy, dx))
    theta0 = ocp.initial.get(r.heading, heading[0])
    heading += 2 * math.pi * round((theta0 - heading[0]) / (2 * math.pi))
    guess = {r.x: x, r.y: y, r.heading: heading}
    speed = np.hypot(dx, dy) / tf
    d = v.parameter_values().get("wheelbase")
    if d is not None and r.steering is not None:
        curvature = np.gradient(heading, s) / np.maximum(np.hypot(dx, dy), 1e-9)
        guess[r.steering] = np.arctan(curvature * d)
    for trailer in r.trailers:
        guess[trailer] = trailer_heading(ocp, heading, np.hypot(dx, dy) * np.gradient(s))
    return _complete(ocp, guess, speed, s, tf)


def trailer_heading(
    ocp: OCP, heading: np.ndarray, ds: np.ndarray, direction: np.ndarray | None = None, substeps: int = 10
) -> np.ndarray:
    """The trailer heading (``roles.trailers``, one trailer) at the nodes of a guess path
    (``paths.trailer_angle``, RK4 in arc length), inside the articulation bounds.

    ``ds`` is the path length per node step; ``direction`` (+1 forwards, -1 reversing) at the nodes,
    forwards if None; the heading is interpolated linearly between nodes, at ``substeps`` RK4 steps
    per node step.
    """
    length = np.concatenate([[0.0], np.cumsum((ds[:-1] + ds[1:]) / 2)])
    fine = np.linspace(0.0, length[-1], 2 * substeps * (len(heading) - 1) + 1)
    theta = np.interp(fine, length, heading)
    gear = np.ones_like(fine) if direction is None else np.where(np.interp(fine, length, direction) < 0, -1.0, 1.0)
    kappa = gear * np.gradient(theta, fine) if length[-1] > 0 else np.zeros_like(fine)
    step = length[-1] / (substeps * (len(heading) - 1))
    (trailer,) = ocp.vehicle.roles.trailers
    values = trailer_angle(ocp.vehicle, theta, kappa, gear, step, ocp.initial.get(trailer, heading[0]))
    theta1 = np.interp(length, fine[::2], values)
    if "articulation" in ocp.bounds:  # keep the guess inside the jackknife limit
        lo, hi = ocp.bounds["articulation"]
        theta1 = heading - np.clip(heading - theta1, lo, hi)
    return theta1


def _controls(ocp: OCP, states: dict[str, np.ndarray], speed: np.ndarray, s: np.ndarray, tf: float):
    """The speed control is the speed; a control that is some state's derivative is that derivative."""
    v = ocp.vehicle
    out = {c: np.zeros_like(s) for c in v.controls}
    if v.roles.speed in v.controls:
        out[v.roles.speed] = speed
    for name, f in zip(v.states, v.rhs(numeric=False), strict=True):
        if isinstance(f, sp.Symbol) and f.name in out and f == sym(f.name):
            out[f.name] = np.gradient(states[name], s) / tf
    return {c: _clip(val, ocp.bounds.get(c)) for c, val in out.items()}


def _path(ocp: OCP, passing: str, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if ocp.road is not None:
        return _road_path(ocp, s)
    px, py = ocp.vehicle.position
    p0 = np.array([ocp.initial[px], ocp.initial[py]])
    if px in ocp.final and py in ocp.final:
        p1 = np.array([ocp.final[px], ocp.final[py]])
    else:
        th = ocp.initial.get(ocp.vehicle.roles.heading, 0.0)
        p1 = p0 + (ocp.max_speed() or 1.0) * (ocp.final_time or 1.0) * 0.5 * np.array([math.cos(th), math.sin(th)])
    if not ocp.obstacles or passing not in ("ccw", "cw"):
        return p0[0] + (p1[0] - p0[0]) * s, p0[1] + (p1[1] - p0[1]) * s
    ob = ocp.obstacles[0]
    c = np.array(ob.center)
    a0 = math.atan2(*(p0 - c)[::-1])
    a1 = math.atan2(*(p1 - c)[::-1])
    sweep = (a1 - a0) % (2 * math.pi)
    if passing == "cw":
        sweep -= 2 * math.pi
    r = (1 - s) * np.linalg.norm(p0 - c) + s * np.linalg.norm(p1 - c)
    r = np.maximum(r, 1.2 * ob.keep_out)
    a = a0 + sweep * s
    return c[0] + r * np.cos(a), c[1] + r * np.sin(a)


def _road_path(ocp: OCP, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In along the entry lane to the ring's middle, round in the circulation direction, out along the exit lane."""
    rb = ocp.road.roundabout
    c = np.asarray(rb.center)
    p0, p1 = np.array(ocp.road.start()[:2]), np.array(ocp.road.goal()[:2])
    mid = (rb.inner_radius + rb.outer_radius) / 2
    a0 = math.atan2(*(p0 - c)[::-1])
    a1 = math.atan2(*(p1 - c)[::-1])
    sweep = rb.circulation * ((rb.circulation * (a1 - a0)) % (2 * math.pi) or 2 * math.pi)
    arc = np.linspace(0.0, 1.0, 60)
    ring = c + mid * np.column_stack([np.cos(a0 + sweep * arc), np.sin(a0 + sweep * arc)])
    points = np.vstack([p0, ring, p1])
    length = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    at = s * length[-1]
    return np.interp(at, length, points[:, 0]), np.interp(at, length, points[:, 1])


THREE_POINT = (0.45, 0.6, 0.55, 0.4)  # time fractions where the reverse leg begins and ends, path fractions there
THREE_POINT_OFFSET = 0.25  # of the ring's width: how far outwards the reverse leg swings at its middle
THREE_POINT_SLOWER = 2.0  # the Tf guess over the forward route's (longer, with two stops)


def three_point_guess(ocp: OCP, n: int, tf_scale: float = 1.0) -> tuple[dict[str, np.ndarray], float]:
    """A forward-reverse-forward (three-point) start through the ring of a road problem, and its Tf guess.

    The reference point drives the road route (in, round the ring, out) forwards to THREE_POINT's
    path fraction 0.55, reverses to 0.4 swinging outwards by THREE_POINT_OFFSET of the ring's width,
    and drives on forwards to the goal; the heading is the route's tangent throughout (the vehicle
    reverses, it does not turn round), the steering follows the route's curvature and the trailer
    is integrated along the motion with its direction.
    """
    v, r = ocp.vehicle, ocp.vehicle.roles
    rb = ocp.road.roundabout
    tau = np.linspace(0.0, 1.0, n + 1)
    t_a, t_b, p_a, p_b = THREE_POINT
    p = np.interp(tau, [0.0, t_a, t_b, 1.0], [0.0, p_a, p_b, 1.0])
    fine = np.linspace(0.0, 1.0, 801)
    fx, fy = _road_path(ocp, fine)
    length = float(np.sum(np.hypot(np.diff(fx), np.diff(fy))))
    heading = np.unwrap(np.arctan2(np.gradient(fy, fine), np.gradient(fx, fine)))
    heading += 2 * math.pi * round((ocp.initial.get(r.heading, heading[0]) - heading[0]) / (2 * math.pi))
    swing = THREE_POINT_OFFSET * rb.circulatory_width * np.sin(math.pi * np.clip((tau - t_a) / (t_b - t_a), 0, 1))
    x, y = np.interp(p, fine, fx), np.interp(p, fine, fy)
    radial = np.arctan2(y - rb.center[1], x - rb.center[0])
    guess = {r.x: x + swing * np.cos(radial), r.y: y + swing * np.sin(radial), r.heading: np.interp(p, fine, heading)}
    tf = tf_scale * THREE_POINT_SLOWER * guess_final_time(ocp, "none")
    speed = np.gradient(p, tau) * length / tf
    d = v.parameter_values().get("wheelbase")
    if d is not None and r.steering is not None:
        curvature = np.gradient(heading, fine) / max(length, 1e-9)
        guess[r.steering] = np.arctan(np.interp(p, fine, curvature) * d)
    direction = np.where(speed < 0, -1.0, 1.0)
    for trailer in r.trailers:
        guess[trailer] = trailer_heading(ocp, guess[r.heading], np.abs(np.gradient(p)) * length, direction)
    return _complete(ocp, guess, speed, tau, tf), tf


def _complete(ocp: OCP, guess: dict, speed: np.ndarray, s: np.ndarray, tf: float) -> dict:
    """``guess`` with its missing states linear in ``s`` from start to goal, every state clipped to its
    bounds, and the controls that drive it at ``speed`` over ``tf``."""
    r = ocp.vehicle.roles
    if r.acceleration is not None:  # longitudinal dynamics: the speed is a state, driven by a (or j)
        guess.update(integrated_speed(ocp.vehicle, speed, s * tf, ocp.initial, ocp.final))
    for name in ocp.vehicle.states:
        if name not in guess:
            a, b = ocp.initial[name], ocp.final.get(name, ocp.initial[name])
            guess[name] = a + (b - a) * s
        guess[name] = _clip(guess[name], ocp.bounds.get(name))
    guess.update(_controls(ocp, guess, speed, s, tf))
    return guess


def _clip(values: np.ndarray, bounds: tuple[float, float] | None) -> np.ndarray:
    return values if bounds is None else np.clip(values, bounds[0], bounds[1])


RS_DETOUR = 2.0  # a Reeds-Shepp start that must reverse is used only up to this x the shortest length


def reeds_shepp_start_path(ocp: OCP, ends: str | None = None) -> Path | None:
    """The Reeds-Shepp path of ``reeds_shepp_guess`` (same rules), or None where it does not apply.

    With longitudinal dynamics (``Vehicle.integrated_states``) also None for the empty path (no word
    reverses into the goal or out of the start: a stand-still start, 3000 Ipopt iterations on the
    rest-to-rest truck of tests/test_longitudinal.py) and for a path that drives a direction the bound
    of the speed forbids (reversing under v >= 0). Without them the empty path is returned as before.
    """
    rho = min_turning_radius(ocp.vehicle, ocp.bounds, both_ways=True)
    keys = (*ocp.vehicle.position, ocp.vehicle.roles.heading)
    if rho is None or math.isinf(rho) or not all(k in ocp.final for k in keys) or ocp.max_speed() is None:
        return None
    start, goal = tuple(ocp.initial[k] for k in keys), tuple(ocp.final[k] for k in keys)
    path = reeds_shepp(start, goal, rho)
    if ends is not None:
        shortest, path = path, reeds_shepp(start, goal, rho, ends)
        if path.word == shortest.word or path.length > RS_DETOUR * shortest.length:
            return None
    if ocp.vehicle.integrated_states and not (path.segments and _may_drive(ocp, path)):
        return None
    return path


def _may_drive(ocp: OCP, path: Path) -> bool:
    """Whether the bound of the speed lets the vehicle drive ``path``'s directions (backwards: lower bound < 0)."""
    lo, hi = ocp.bounds.get(ocp.vehicle.roles.speed, (-math.inf, math.inf))
    return all((hi if length >= 0.0 else -lo) > 0.0 for _, length in path.segments)


def reeds_shepp_guess(
    ocp: OCP, n: int, tf_scale: float = 1.0, ends: str | None = None
) -> tuple[dict[str, np.ndarray], float] | None:
    """The shortest Reeds-Shepp path (cusps, reversing; obstacles ignored) as node values, and its time.

    Without longitudinal dynamics: driven at constant speed in the given final time, or (free Tf) at
    70 % of the top speed times ``1 / tf_scale``. With them (``Vehicle.integrated_states``): driven
    within the limits (``model.search.paths.limited_path_guess``: v, a, j and the lateral acceleration
    at 0.7 of their bounds, through 0 at each cusp), its time times ``tf_scale``, or retimed to the given
    final time (``retimed``). ``ends`` ("reverse-in", "reverse-out"): the shortest that reverses into
    the goal or out of the start, if it differs from the shortest and is at most RS_DETOUR x as long.
    None where it does not apply: no turning radius to both sides, no top speed, x, y, theta not all
    fixed at the goal, or (longitudinal dynamics) an empty path or a direction the speed's bound forbids.
    """
    path = reeds_shepp_start_path(ocp, ends)
    if path is None:
        return None
    if ocp.vehicle.integrated_states:
        limited = limited_path_guess(ocp.vehicle, path, n, ocp.bounds, ocp.initial, ocp.final)
        if limited is None:
            return None
        values, tf = limited
        target = float(ocp.final_time) if ocp.final_time is not None else tf_scale * tf
        return (values, tf) if target == tf else (retimed(ocp, values, target / tf), target)
    tf = ocp.final_time if ocp.final_time is not None else tf_scale * max(path.length, 1e-3) / (0.7 * ocp.max_speed())
    return path_guess(ocp.vehicle, path, tf, n, initial=ocp.initial, final=ocp.final), tf


def retimed(ocp: OCP, values: dict[str, np.ndarray], stretch: float) -> dict[str, np.ndarray]:
    """Node values of a guess driven ``stretch`` x as long (same nodes, same poses): every rate divided.

    The speed (state or control), the steering rate and the turn rate by ``stretch``, the acceleration by
    its square, the jerk by its cube; every state clipped to its bounds as ``_complete`` does.

    Parameters
    ----------
    ocp : OCP
        The problem (its vehicle's roles name the rates, its bounds clip the states).
    values : dict of ndarray
        Node values of every state and control.
    stretch : float
        New final time over the old (> 0).

    Returns
    -------
    dict of ndarray
        The same names, the rates rescaled.
    """
    if not stretch > 0.0:
        raise ValueError(f"stretch must be > 0, got {stretch!r}")
    r = ocp.vehicle.roles
    order = {r.speed: 1, r.steering_rate: 1, r.turn_rate: 1, r.acceleration: 2, r.jerk: 3}
    out = {k: val / stretch ** order[k] if k in order else val for k, val in values.items()}
    for name in ocp.vehicle.states:
        out[name] = _clip(out[name], ocp.bounds.get(name))
    return out
