"""Geometric guess paths: Reeds-Shepp (forwards and backwards, with cusps) and Dubins (forwards only).

A path is a word of at most five segments, each a left arc (L), a straight (S) or a right arc
(R) of radius ``rho``, driven forwards or backwards. ``reeds_shepp`` returns the shortest of
the 48 words of Reeds & Shepp (1990), ``dubins`` the shortest of the six forward words LSL,
RSR, LSR, RSL, RLR, LRL (Dubins 1957). ``sample`` evaluates a path at equal steps of arc
length; ``path_guess`` turns it into node values of every state and control of a vehicle
model; ``reeds_shepp_time`` is the obstacle-free lower bound on the minimum time.

Conventions. A pose is (x, y, theta) of the reference point (the rear axle centre).
A segment is ``(kind, length)`` with the signed length in metres: > 0 forwards, < 0
backwards. The curvature ``kappa`` is the steering curvature d(theta)/d(signed arc length):
+1/rho on L, -1/rho on R, 0 on S, whatever the direction of travel, so a car-like model
steers phi = atan(d kappa) on it.

The Reeds-Shepp words are solved in the start's frame scaled to rho = 1, from eight base
formulas (section 8 of the paper, with the corrections OMPL's ReedsSheppStateSpace documents)
and the paper's symmetries: time flip (drive the word backwards), reflection (swap L and R)
and reversal (drive the word from its end).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from model.vehicles import integrated_speed

if TYPE_CHECKING:
    from model.vehicles import Vehicle

Pose = tuple[float, float, float]
Segment = tuple[str, float]

TWO_PI = 2.0 * math.pi
HALF_PI = 0.5 * math.pi
ZERO = 1e-12  # tolerance on the sign conditions of the base formulas (normalised units)
_CURVATURE_SIGN = {"L": 1.0, "S": 0.0, "R": -1.0}
_SWAP = str.maketrans("LR", "RL")


@dataclass(frozen=True)
class Path:
    """A word of arcs and straights from a start pose.

    Parameters
    ----------
    start : tuple of float
        (x, y, theta) where the path begins, m and rad.
    rho : float
        Radius of the arcs, m (> 0).
    segments : tuple of (str, float)
        ``(kind, length)`` in driving order: kind "L", "S" or "R", length in m, negative backwards.
        Zero-length segments are dropped by the constructors of this module.
    """

    start: Pose
    rho: float
    segments: tuple[Segment, ...]

    @property
    def length(self) -> float:
        """Total arc length, m (the sum of the segments' absolute lengths)."""
        return float(sum(abs(seg) for _, seg in self.segments))

    @property
    def word(self) -> str:
        """The word with directions, e.g. ``"L+R-S-L-"``; ``""`` for the empty path."""
        return "".join(f"{kind}{'+' if seg > 0 else '-'}" for kind, seg in self.segments)

    @property
    def cusps(self) -> int:
        """Number of changes of driving direction."""
        signs = [seg > 0 for _, seg in self.segments]
        return sum(a != b for a, b in zip(signs, signs[1:], strict=False))

    @property
    def goal(self) -> Pose:
        """The end pose (theta not wrapped: start theta plus the signed turns)."""
        pose = self.start
        for kind, seg in self.segments:
            pose = _advance(pose, _CURVATURE_SIGN[kind] / self.rho, seg)
        return pose


def _advance(pose: Pose, kappa: float, seg: float) -> Pose:
    """The pose after ``seg`` metres (signed) at steering curvature ``kappa``."""
    x, y, th = pose
    if kappa == 0.0:
        return x + seg * math.cos(th), y + seg * math.sin(th), th
    th1 = th + kappa * seg
    return x + (math.sin(th1) - math.sin(th)) / kappa, y - (math.cos(th1) - math.cos(th)) / kappa, th1


# -- small helpers ----------------------------------------------------------------------------


def _mod2pi(a: float) -> float:
    """``a`` wrapped into [-pi, pi)."""
    return (a + math.pi) % TWO_PI - math.pi


def _mod_pos(a: float) -> float:
    """``a`` wrapped into [0, 2 pi), a rounding error below 0 counted as 0 (not as a full turn)."""
    r = a % TWO_PI
    return 0.0 if TWO_PI - r < 1e-10 else r


def _polar(x: float, y: float) -> tuple[float, float]:
    return math.hypot(x, y), math.atan2(y, x)


def _local(start: Pose, goal: Pose, rho: float) -> tuple[float, float, float]:
    """The goal in the start's frame, lengths divided by ``rho``."""
    dx, dy = goal[0] - start[0], goal[1] - start[1]
    c, s = math.cos(start[2]), math.sin(start[2])
    return (c * dx + s * dy) / rho, (-s * dx + c * dy) / rho, goal[2] - start[2]


def _check_rho(rho: float) -> float:
    rho = float(rho)
    if not (rho > 0.0 and math.isfinite(rho)):
        raise ValueError(f"rho must be a finite number > 0, got {rho!r}")
    return rho


def _make_path(start: Pose, rho: float, kinds: str, params: tuple[float, ...]) -> Path:
    """A Path from normalised signed parameters, dropping zero-length segments."""
    segments = tuple((k, rho * p) for k, p in zip(kinds, params, strict=True) if abs(p) > ZERO)
    return Path((float(start[0]), float(start[1]), float(start[2])), rho, segments)


# -- Reeds-Shepp base formulas (rho = 1, goal (x, y, phi) in the start's frame) ---------------
# Each returns the signed parameters of its word, or None where the word does not apply.


def _lp_sp_lp(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ S+ L+ (8.1): circle centres (0, 1) and (x - sin phi, y + cos phi)."""
    u, t = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    v = _mod2pi(phi - t)
    return (t, u, v) if t >= -ZERO and v >= -ZERO else None


def _lp_sp_rp(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ S+ R+ (8.2): inner tangent of a left and a right circle."""
    r, t1 = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    if r * r < 4.0:
        return None
    u = math.sqrt(r * r - 4.0)
    t = _mod2pi(t1 + math.atan2(2.0, u))
    v = _mod2pi(t - phi)
    return (t, u, v) if t >= -ZERO and v >= -ZERO else None


def _lp_rm_l(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R- L+- (8.3, 8.4): C|C|C and C|CC, the sign of the last parameter telling which."""
    r, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if r > 4.0:
        return None
    u = -2.0 * math.asin(0.25 * r)
    t = _mod2pi(theta + 0.5 * u + math.pi)
    v = _mod2pi(phi - t + u)
    return (t, u, v) if t >= -ZERO and u <= ZERO else None


def _tau_omega(u: float, v: float, xi: float, eta: float, phi: float) -> tuple[float, float]:
    """First and last arcs of the four-arc words, given the middle arcs u and v."""
    delta = _mod2pi(u - v)
    a = math.sin(u) - math.sin(delta)
    b = math.cos(u) - math.cos(delta) - 1.0
    t1 = math.atan2(eta * a - xi * b, xi * a + eta * b)
    t2 = 2.0 * (math.cos(delta) - math.cos(v) - math.cos(u)) + 3.0
    tau = _mod2pi(t1 + math.pi) if t2 < 0.0 else _mod2pi(t1)
    return tau, _mod2pi(tau - u + v - phi)


def _lp_rup_lum_rm(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R+ L- R- (8.7), the two middle arcs equal."""
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rh = 0.25 * (2.0 + math.hypot(xi, eta))
    if rh > 1.0:
        return None
    u = math.acos(rh)
    t, v = _tau_omega(u, -u, xi, eta, phi)
    return (t, u, -u, v) if t >= -ZERO and v <= ZERO else None


def _lp_rum_lum_rp(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R- L- R+ (8.8), the two middle arcs equal and at most pi/2."""
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rh = (20.0 - xi * xi - eta * eta) / 16.0
    if not 0.0 <= rh <= 1.0:
        return None
    u = -math.acos(rh)
    if u < -HALF_PI:
        return None
    t, v = _tau_omega(u, u, xi, eta, phi)
    return (t, u, u, v) if t >= -ZERO and v >= -ZERO else None


def _lp_rm_sm_lm(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R-(pi/2) S- L- (8.9)."""
    r, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if r < 2.0:
        return None
    w = math.sqrt(r * r - 4.0)
    u = 2.0 - w
    t = _mod2pi(theta + math.atan2(w, -2.0))
    v = _mod2pi(phi - HALF_PI - t)
    return (t, -HALF_PI, u, v) if t >= -ZERO and u <= ZERO and v <= ZERO else None


def _lp_rm_sm_rm(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R-(pi/2) S- R- (8.10)."""
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    r, theta = _polar(-eta, xi)
    if r < 2.0:
        return None
    t, u = theta, 2.0 - r
    v = _mod2pi(t + HALF_PI - phi)
    return (t, -HALF_PI, u, v) if t >= -ZERO and u <= ZERO and v <= ZERO else None


def _lp_rm_slm_rp(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """L+ R-(pi/2) S- L-(pi/2) R+ (8.11)."""
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    r, _ = _polar(xi, eta)
    if r < 2.0:
        return None
    u = 4.0 - math.sqrt(r * r - 4.0)
    if u > ZERO:
        return None
    t = _mod2pi(math.atan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta))
    v = _mod2pi(t - phi)
    return (t, -HALF_PI, u, -HALF_PI, v) if t >= -ZERO and v >= -ZERO else None


Base = Callable[[float, float, float], tuple[float, ...] | None]

# (formula, its kinds, whether the reversed word is a different family to try as well)
_RS_BASES: tuple[tuple[Base, str, bool], ...] = (
    (_lp_sp_lp, "LSL", False),
    (_lp_sp_rp, "LSR", False),
    (_lp_rm_l, "LRL", True),
    (_lp_rup_lum_rm, "LRLR", False),
    (_lp_rum_lum_rp, "LRLR", False),
    (_lp_rm_sm_lm, "LRSL", True),
    (_lp_rm_sm_rm, "LRSR", True),
    (_lp_rm_slm_rp, "LRSLR", False),
)


def _rs_candidates(x: float, y: float, phi: float) -> Iterator[tuple[str, tuple[float, ...]]]:
    """Every applicable word as (kinds, signed parameters), through the paper's symmetries."""
    xb, yb = x * math.cos(phi) + y * math.sin(phi), x * math.sin(phi) - y * math.cos(phi)
    for base, kinds, reversible in _RS_BASES:
        for backwards in (False, True) if reversible else (False,):
            bx, by = (xb, yb) if backwards else (x, y)
            for flip in (False, True):
                for reflect in (False, True):
                    params = base(-bx if flip else bx, -by if reflect else by, -phi if flip != reflect else phi)
                    if params is None:
                        continue
                    word = kinds.translate(_SWAP) if reflect else kinds
                    if flip:
                        params = tuple(-p for p in params)
                    if backwards:
                        word, params = word[::-1], params[::-1]
                    yield word, params


def reeds_shepp(start: Pose, goal: Pose, rho: float, ends: str | None = None) -> Path:
    """The shortest path with cusps allowed (Reeds & Shepp 1990) between two poses.

    Parameters
    ----------
    start, goal : tuple of float
        (x, y, theta), m and rad.
    rho : float
        Minimum turning radius, m (> 0).
    ends : {None, "reverse-in", "reverse-out"}
        Only words that end (reverse-in) or begin (reverse-out) driving backwards: the shortest
        manoeuvre that reverses into the goal or out of the start (a start for the NLP, not a bound).

    Returns
    -------
    Path
        At most five segments and two cusps; its ``goal`` equals ``goal`` up to rounding
        (theta modulo 2 pi).

    Examples
    --------
    >>> round(reeds_shepp((0, 0, 0), (3, 0, 0), 1.0).length, 12)
    3.0
    >>> reeds_shepp((0, 0, 0), (-2, 0, 0), 1.0).word
    'S-'
    """
    rho = _check_rho(rho)
    candidates = _rs_candidates(*_local(start, goal, rho))
    if ends is not None:
        end = {"reverse-in": -1, "reverse-out": 0}[ends]
        candidates = ((k, p) for k, p in candidates if _driving(p, end) < 0.0)
    return _shortest(start, rho, candidates)


def _driving(params: tuple[float, ...], end: int) -> float:
    """The signed length of the first (end 0) or last (end -1) segment that moves."""
    moving = [q for q in params if q != 0.0]
    return moving[end] if moving else 0.0


def _shortest(start: Pose, rho: float, candidates) -> Path:
    """The path of the shortest (word, signed lengths) candidate; the first of equal ones."""
    best_len, best = math.inf, ("S", (0.0,))
    for kinds, params in candidates:
        total = sum(abs(p) for p in params)
        if total < best_len - 1e-12:
            best_len, best = total, (kinds, params)
    return _make_path(start, rho, *best)


# -- Dubins (forward only) --------------------------------------------------------------------


def _dubins_lsl(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    u, t = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    t = _mod_pos(t)
    return t, u, _mod_pos(phi - t)


def _dubins_lsr(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    r, t1 = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    if r < 2.0:
        return None
    u = math.sqrt(r * r - 4.0)
    t = _mod_pos(t1 + math.atan2(2.0, u))
    return t, u, _mod_pos(t - phi)


def _dubins_lrl(x: float, y: float, phi: float) -> tuple[float, ...] | None:
    """Left circles at (0, 1) and at the goal, a right circle touching both; the shorter of its two places."""
    c1x, c1y = x - math.sin(phi), y + math.cos(phi)
    dist, theta = _polar(c1x, c1y - 1.0)
    if dist > 4.0:
        return None
    best: tuple[float, ...] | None = None
    for side in (1.0, -1.0):
        a = theta + side * math.acos(0.25 * dist)
        mx, my = 2.0 * math.cos(a), 1.0 + 2.0 * math.sin(a)  # centre of the right circle
        h1 = math.atan2(0.5 * mx, -0.5 * (my - 1.0))  # heading where the left arc meets it
        h2 = math.atan2(-0.5 * (c1x - mx), 0.5 * (c1y - my))  # heading where it meets the last arc
        params = (_mod_pos(h1), _mod_pos(h1 - h2), _mod_pos(phi - h2))
        if best is None or sum(params) < sum(best):
            best = params
    return best


_DUBINS_BASES: tuple[tuple[Base, str], ...] = ((_dubins_lsl, "LSL"), (_dubins_lsr, "LSR"), (_dubins_lrl, "LRL"))


def dubins(start: Pose, goal: Pose, rho: float) -> Path:
    """The shortest forward-only path (Dubins 1957): the best of LSL, RSR, LSR, RSL, RLR, LRL.

    Parameters
    ----------
    start, goal : tuple of float
        (x, y, theta), m and rad.
    rho : float
        Minimum turning radius, m (> 0).

    Returns
    -------
    Path
        At most three segments, all of positive length.

    Examples
    --------
    >>> round(dubins((0, 0, 0), (0, 2, math.pi), 1.0).length, 12) == round(math.pi, 12)
    True
    """
    rho = _check_rho(rho)
    return _shortest(start, rho, _dubins_candidates(*_local(start, goal, rho)))


def _dubins_candidates(x: float, y: float, phi: float):
    """(word, lengths) of every Dubins word that exists; RSR, RSL, RLR by reflecting LSL, LSR, LRL."""
    for base, kinds in _DUBINS_BASES:
        for reflect in (False, True):
            params = base(x, -y, -phi) if reflect else base(x, y, phi)
            if params is not None:
                yield (kinds.translate(_SWAP) if reflect else kinds), params


# -- sampling ---------------------------------------------------------------------------------


def sample(path: Path, n: int) -> dict[str, np.ndarray]:
    """The path at n + 1 points equally spaced in arc length.

    Parameters
    ----------
    path : Path
    n : int
        Number of steps (>= 1).

    Returns
    -------
    dict of ndarray, each of shape (n + 1,)
        ``s``: arc length from the start, 0 .. ``path.length`` (increasing whatever the direction);
        ``s_signed``: the signed arc length (decreases on backward segments);
        ``x``, ``y``, ``theta`` (continuous, not wrapped); ``kappa``: steering curvature
        (+-1/rho on arcs, 0 on straights); ``direction``: +1 forwards, -1 backwards.
        A point on a boundary between segments (a cusp) belongs to the later segment.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    return _evaluate(path, np.linspace(0.0, path.length, n + 1))


def _evaluate(path: Path, s: np.ndarray) -> dict[str, np.ndarray]:
    segments = path.segments or (("S", 0.0),)
    kappa = np.array([_CURVATURE_SIGN[k] / path.rho for k, _ in segments])
    lengths = np.array([seg for _, seg in segments])
    direction = np.where(lengths < 0.0, -1.0, 1.0)
    bounds = np.concatenate([[0.0], np.cumsum(np.abs(lengths))])
    poses = [path.start]
    for (_, seg), k in zip(segments, kappa, strict=True):
        poses.append(_advance(poses[-1], float(k), seg))
    x0, y0, th0 = (np.array(v) for v in zip(*poses[:-1], strict=True))
    i = np.clip(np.searchsorted(bounds, s, side="right") - 1, 0, len(segments) - 1)
    along = (s - bounds[i]) * direction[i]
    k = kappa[i]
    theta = th0[i] + k * along
    safe = np.where(k == 0.0, 1.0, k)
    x = np.where(k == 0.0, x0[i] + along * np.cos(th0[i]), x0[i] + (np.sin(theta) - np.sin(th0[i])) / safe)
    y = np.where(k == 0.0, y0[i] + along * np.sin(th0[i]), y0[i] - (np.cos(theta) - np.cos(th0[i])) / safe)
    signed = np.concatenate([[0.0], np.cumsum(lengths)])[i] + along
    return {"s": s, "s_signed": signed, "x": x, "y": y, "theta": theta, "kappa": k,  # names: the path's pose
            "direction": direction[i]}  # fmt: skip


# -- vehicles ---------------------------------------------------------------------------------


def path_guess(
    vehicle: Vehicle,
    path: Path,
    final_time: float,
    n: int,
    initial: Mapping[str, float] | None = None,
    final: Mapping[str, float] | None = None,
) -> dict[str, np.ndarray]:
    """Node values of every state and control that drive ``path`` in ``final_time`` at constant speed.

    The reference point runs along the path at speed ``path.length / final_time`` (sign by
    direction), so the n + 1 nodes at equal times are the path's equal arc-length samples.
    The names are the vehicle's ``roles``. The heading is continuous; a car-like model steers
    phi = atan(d kappa) (the truck, the tricycle and the tractor; for the tricycle, whose reference
    point is the rear axle, too: its rear axle turns on radius d / tan(phi)); the steering rate is
    d(phi)/dt by finite differences (it jumps where the path's curvature does). The speed control is
    the path speed over ``vehicle.reference_speed()`` (the truck's and the tractor's: the path speed;
    the tricycle's front wheel's: path speed / cos(phi)). A turn-rate control (the unicycle's) is
    speed kappa. The trailer heading (``roles.trailers``, one trailer) is integrated along the path
    (RK4) from ``initial[<its name>]``, by default the path's start heading.

    Parameters
    ----------
    vehicle : Vehicle
        Any model of ``model.vehicles``; states other than the position, the heading, the steering
        and the trailer heading are held at ``initial[name]``.
    path : Path
    final_time : float
        s (> 0).
    n : int
        Number of time steps; nodes at ``np.linspace(0, final_time, n + 1)``.
    initial : mapping, optional
        Start values of states the path does not fix (the trailer heading; the speed v).
    final : mapping, optional
        End values: a stated final speed v (longitudinal dynamics) is blended into the guess's speed.

    Returns
    -------
    dict of ndarray
        Every name of ``vehicle.states`` and ``vehicle.controls``, each of shape (n + 1,).
    """
    if not final_time > 0.0:
        raise ValueError(f"final_time must be > 0, got {final_time!r}")
    initial = dict(initial or {})
    smp = sample(path, n)
    t = np.linspace(0.0, float(final_time), n + 1)
    speed = smp["direction"] * path.length / final_time
    d = vehicle.parameter_values().get("wheelbase")
    r = vehicle.roles
    out = {r.x: smp["x"], r.y: smp["y"], r.heading: smp["theta"]}  # names: the path's pose, keyed by the roles
    if r.steering is not None:
        if d is None:
            raise ValueError(f"vehicle {vehicle.model!r} steers {r.steering} but has no wheelbase d")
        out[r.steering] = np.arctan(d * smp["kappa"])
    for trailer in r.trailers:
        out[trailer] = _trailer_angle(vehicle, path, n, initial.get(trailer, path.start[2]))
    if r.acceleration is not None:  # longitudinal dynamics: the speed is a state, driven by a (or j)
        filled = {k: out.get(k, np.ones(n + 1)) for k in vehicle.states}
        (factor,) = vehicle.state_function([vehicle.reference_speed()])(filled)
        out.update(integrated_speed(vehicle, speed / factor, t, initial, dict(final or {})))
    for name in vehicle.states:
        if name not in out:
            if name not in initial:
                raise ValueError(f"the path does not fix state {name!r} of {vehicle.model!r}: give initial[{name!r}]")
            out[name] = np.full(n + 1, float(initial[name]))
    out.update(_path_controls(vehicle, out, smp, speed, t))
    return {name: out[name] for name in (*vehicle.states, *vehicle.controls)}


LIMIT_SHARE = 0.7  # of each bound (speed, acceleration, jerk, lateral acceleration) a limited guess drives at


def limited_path_guess(
    vehicle: Vehicle,
    path: Path,
    n: int,
    bounds: Mapping[str, tuple[float, float]],
    initial: Mapping[str, float] | None = None,
    final: Mapping[str, float] | None = None,
    share: float = LIMIT_SHARE,
) -> tuple[dict[str, np.ndarray], float] | None:
    """``path_guess`` for a vehicle with longitudinal dynamics, driven within its limits, and the time it takes.

    Each run of the path between cusps is driven at a cruise speed with smooth (half-cosine) ramps: from
    the stated initial speed (else 0), through 0 at each cusp, to the stated final speed (else 0). A ramp
    takes the time that keeps |a| (and |j|) within ``share`` of the smaller magnitude of their bounds; the
    cruise speed is ``share`` of the speed bound in the run's direction, at most sqrt(``share`` a_lat rho)
    on a run with arcs under a lateral-acceleration bound, and lower where the run is too short for both
    ramps. The nodes are at equal times of the total; the path is sampled at the arc length driven by
    then, so the poses, v, a and j agree with each other (the transcription's residuals start small).

    Parameters
    ----------
    vehicle : Vehicle
        A model with longitudinal dynamics (``roles.integrated`` not empty).
    path : Path
    n : int
        Number of time steps.
    bounds : mapping
        The problem's bounds by name: the speed's, the acceleration's, the jerk's, ``lateral_acceleration``.
    initial, final : mapping, optional
        The end values (the speed v where stated; the trailer heading at the start).
    share : float
        The share of each bound the guess uses, in (0, 1].

    Returns
    -------
    (dict of ndarray, float) or None
        Every state and control at the n + 1 nodes, and the final time (s); None where the speed's bound
        forbids a direction the path drives (a path that reverses under v >= 0).
    """
    r, initial, final = vehicle.roles, dict(initial or {}), dict(final or {})
    if r.acceleration is None:
        raise ValueError(f"the {vehicle.model} model has no longitudinal dynamics")
    lo, hi = bounds[r.speed]
    runs = _runs(path)
    if any((hi if forward else -lo) <= 0.0 for _, forward, _ in runs):
        return None
    accel, jerk = (min(-b[0], b[1]) * share if b else math.inf for b in (bounds[r.acceleration], bounds.get(r.jerk)))
    lateral = bounds.get("lateral_acceleration")
    turn = math.sqrt(share * min(-lateral[0], lateral[1]) * path.rho) if lateral else math.inf
    ends = [abs(initial.get(r.speed, 0.0))] + [0.0] * (len(runs) - 1) + [abs(final.get(r.speed, 0.0))]
    pieces = []
    for k, (length, forward, arcs) in enumerate(runs):
        cruise = min(share * (hi if forward else -lo), turn if arcs else math.inf)
        pieces += [(p[0], p[1], p[2], 1.0 if forward else -1.0) for p in
                   _run_profile(length, ends[k], ends[k + 1], cruise, accel, jerk)]  # fmt: skip
    durations = np.array([p[0] for p in pieces])
    tf = float(durations.sum())
    t = np.linspace(0.0, tf, n + 1)
    starts = np.concatenate([[0.0], np.cumsum(durations)])
    which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(pieces) - 1)
    tau = t - starts[which]
    driven = np.concatenate([[0.0], np.cumsum([_ramp(p[0], p[1], p[2], p[0])[0] for p in pieces])])
    s, v, a, j = np.zeros((4, n + 1))
    for i, k in enumerate(which):
        ds, v[i], a[i], j[i] = _ramp(*pieces[k][:3], tau[i])
        s[i] = driven[k] + ds
        v[i], a[i], j[i] = (pieces[k][3] * q for q in (v[i], a[i], j[i]))
    s = np.clip(s * path.length / max(driven[-1], 1e-12), 0.0, path.length)
    smp = _evaluate(path, s)
    out = {r.x: smp["x"], r.y: smp["y"], r.heading: smp["theta"]}  # names: the path's pose, keyed by the roles
    if r.steering is not None:
        out[r.steering] = np.arctan(vehicle.parameter_values()["wheelbase"] * smp["kappa"])
    for trailer in r.trailers:
        fine = 4 * n
        values = _trailer_angle(vehicle, path, fine, initial.get(trailer, path.start[2]))
        out[trailer] = np.interp(s, np.linspace(0.0, path.length, fine + 1), values)
    filled = {k: out.get(k, np.ones(n + 1)) for k in vehicle.states}
    (factor,) = vehicle.state_function([vehicle.reference_speed()])(filled)
    rates = dict(zip((r.speed, r.acceleration, r.jerk), (v / factor, a / factor, j / factor), strict=True))
    out |= {name: rates[name] for name in (*r.integrated, r.jerk or r.acceleration)}  # v, a, j
    for name in vehicle.states:
        if name not in out:
            out[name] = np.full(n + 1, float(initial[name]))
    out.update(_path_controls(vehicle, out, smp, v, t))
    return {name: out[name] for name in (*vehicle.states, *vehicle.controls)}, tf


def _runs(path: Path) -> list[tuple[float, bool, bool]]:
    """The path's runs between cusps: (length m, forwards, has an arc)."""
    runs: list[tuple[float, bool, bool]] = []
    for kind, seg in path.segments or (("S", 0.0),):
        forward = seg >= 0.0
        if runs and runs[-1][1] == forward:
            length, _, arcs = runs[-1]
            runs[-1] = (length + abs(seg), forward, arcs or kind != "S")
        else:
            runs.append((abs(seg), forward, kind != "S"))
    return runs


def _ramp_time(change: float, accel: float, jerk: float) -> float:
    """The duration of a half-cosine change of speed by ``change`` with |a| <= accel and |j| <= jerk."""
    change = abs(change)
    return max(change * math.pi / (2.0 * accel), math.sqrt(change * math.pi**2 / (2.0 * jerk)), 0.0)


def _run_profile(
    length: float, start: float, end: float, cruise: float, accel: float, jerk: float
) -> list[tuple[float, float, float]]:
    """A run's speed pieces (duration s, speed from, speed to, m/s >= 0): ramp, cruise, ramp; the peak lowered
    (bisection) where the run is too short for both ramps at ``cruise``, the times stretched where even a peak at
    the larger end speed does not fit."""

    def ramps(peak: float) -> tuple[float, float, float]:
        up, down = _ramp_time(peak - start, accel, jerk), _ramp_time(peak - end, accel, jerk)
        return up, down, (start + peak) / 2.0 * up + (peak + end) / 2.0 * down

    peak = max(cruise, start, end)
    up, down, used = ramps(peak)
    if used > length:
        low, high = max(start, end), peak
        for _ in range(60):
            peak = 0.5 * (low + high)
            low, high = (peak, high) if ramps(peak)[2] <= length else (low, peak)
        peak = low
        up, down, used = ramps(peak)
        if used > length:  # a stated end speed too high for the run: the ramps squeezed into it
            squeeze = length / used
            up, down, used = up * squeeze, down * squeeze, length
    cruise_time = (length - used) / peak if peak > 0.0 else 0.0
    pieces = [(up, start, peak), (cruise_time, peak, peak), (down, peak, end)]
    return [p for p in pieces if p[0] > 0.0] or [(max(length, 1e-9) / max(peak, 1e-9), peak, peak)]


def _ramp(duration: float, v0: float, v1: float, tau: float) -> tuple[float, float, float, float]:
    """Distance, speed, acceleration and jerk ``tau`` into a half-cosine ramp from v0 to v1 over ``duration``."""
    w = math.pi / duration
    half = (v1 - v0) / 2.0
    c, s = math.cos(w * tau), math.sin(w * tau)
    return v0 * tau + half * (tau - s / w), v0 + half * (1.0 - c), half * w * s, half * w * w * c


def _path_controls(
    vehicle: Vehicle, states: dict[str, np.ndarray], smp: dict[str, np.ndarray], speed: np.ndarray, t: np.ndarray
) -> dict[str, np.ndarray]:
    """The speed control (over the reference speed), the steering rate or (no steering) the turn rate."""
    r, out = vehicle.roles, {}
    if r.speed in vehicle.controls:
        (factor,) = vehicle.state_function([vehicle.reference_speed()])(states)
        out[r.speed] = speed / factor
    if r.steering_rate is not None and r.steering is not None:
        out[r.steering_rate] = np.gradient(states[r.steering], t)
    if r.turn_rate is not None:
        out[r.turn_rate] = speed * smp["kappa"]
    missing = set(vehicle.controls) - set(out) - set(states)
    if missing:
        raise ValueError(f"no path guess for controls {sorted(missing)} of {vehicle.model!r}")
    return out


def _trailer_angle(vehicle: Vehicle, path: Path, n: int, theta1_0: float) -> np.ndarray:
    """The trailer heading at the n + 1 equal arc-length nodes of ``path`` (RK4 with steps of at most
    2 % of min(rho, L))."""
    scale = min(path.rho, vehicle.parameter_values()["trailer_wheelbase"])
    m = max(2, math.ceil(path.length / (n * 0.02 * scale))) if path.length > 0 else 1
    fine = _evaluate(path, np.linspace(0.0, path.length, 2 * n * m + 1))
    heading = fine["theta"]  # names: the path's pose
    values = trailer_angle(vehicle, heading, fine["kappa"], fine["direction"], path.length / (n * m), theta1_0)
    return values[::m]


def trailer_angle(
    vehicle: Vehicle, theta: np.ndarray, kappa: np.ndarray, direction: np.ndarray, step: float, theta1_0: float
) -> np.ndarray:
    """The trailer heading along a sampled tractor path, by RK4 in arc length.

    d(theta1)/ds = direction (sin b + h kappa cos b) / L with b = theta - theta1 (the tractor-trailer's
    equation divided by |u1|). ``theta``, ``kappa`` and ``direction`` are given at 2 k + 1 points half a
    ``step`` apart; the result holds theta1 at the k + 1 whole steps.
    """
    p = vehicle.parameter_values()
    h, trailer = p.get("hitch_offset", 0.0), p["trailer_wheelbase"]

    def rate(j: int, th1: float) -> float:
        b = theta[j] - th1
        return direction[j] * (math.sin(b) + h * kappa[j] * math.cos(b)) / trailer

    values = np.empty((len(theta) - 1) // 2 + 1)
    values[0] = theta1_0
    for i in range(len(values) - 1):
        j, a = 2 * i, values[i]
        k1 = rate(j, a)
        k2 = rate(j + 1, a + 0.5 * step * k1)
        k3 = rate(j + 1, a + 0.5 * step * k2)
        k4 = rate(j + 2, a + step * k3)
        values[i + 1] = a + step * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
    return values


def min_turning_radius(
    vehicle: Vehicle, bounds: Mapping[str, tuple[float, float]], both_ways: bool = False
) -> float | None:
    """The least radius the reference point can turn on within ``bounds``.

    Parameters
    ----------
    vehicle : Vehicle
    bounds : mapping
        Name -> (lower, upper), as ``OCP.bounds``.
    both_ways : bool
        False (default): the least radius to either side, phi_max = max(|lower|, |upper|); a
        Reeds-Shepp length with it is a lower bound. True: the least radius reachable to both
        sides, phi_max = min(|lower|, |upper|) (``inf`` if one side cannot be turned to).

    Returns
    -------
    float or None
        A steered model (truck, tractor-trailer, tricycle): d / tan(phi_max) with phi its
        ``roles.steering`` (the rear axle's radius; the tricycle's front wheel runs on
        d / sin(phi_max)). A model with a turn rate w (the unicycle's u2) and speed u (u1):
        1 / max|kappa| with a curvature bound ``bounds["w/u"]`` (e.g. ``"u2/u1"``), else
        min|u| / max|w| if u's bounds exclude 0. None where the radius has no positive lower
        bound (no bound on phi, |phi| up to pi/2, a unicycle that can turn on the spot).
    """
    r = vehicle.roles
    if r.steering is not None:
        if r.steering not in bounds:
            return None
        phi_max = _extent(bounds[r.steering], both_ways)
        if phi_max >= HALF_PI:
            return None
        return math.inf if phi_max == 0.0 else vehicle.parameter_values()["wheelbase"] / math.tan(phi_max)
    if r.turn_rate is None or r.speed is None:
        return None
    curvature = f"{r.turn_rate}/{r.speed}"
    if curvature in bounds:
        k = _extent(bounds[curvature], both_ways)
        return math.inf if k == 0.0 else 1.0 / k
    if r.speed in bounds and r.turn_rate in bounds:
        lo, hi = bounds[r.speed]
        w = _extent(bounds[r.turn_rate], both_ways)
        if lo * hi > 0.0:
            return math.inf if w == 0.0 else min(abs(lo), abs(hi)) / w
    return None


def _extent(bound: tuple[float, float], both_ways: bool) -> float:
    lo, hi = float(bound[0]), float(bound[1])
    if both_ways:
        return max(0.0, min(-lo, hi))
    return max(abs(lo), abs(hi))


def reeds_shepp_time(start: Pose, goal: Pose, rho: float | None, u1max: float) -> float:
    """Obstacle-free lower bound on the minimum time: shortest Reeds-Shepp length / top speed.

    With the steering infinitely fast every admissible trajectory of the reference point is a
    path of curvature at most 1 / rho driven at |speed| <= u1max, so no fixed final time below
    this is feasible; obstacles only lengthen the path, so it stays a lower bound.

    Parameters
    ----------
    start, goal : tuple of float
        (x, y, theta), m and rad.
    rho : float or None
        Minimum turning radius (``min_turning_radius``), m; None: unbounded turning, the bound
        is the straight-line distance / u1max; ``inf``: no turning (``inf`` unless the goal lies
        straight ahead or behind with the same heading).
    u1max : float
        Largest speed magnitude of the reference point, m/s (> 0).

    Returns
    -------
    float
        Seconds.
    """
    if not u1max > 0.0:
        raise ValueError(f"u1max must be > 0, got {u1max!r}")
    distance = math.hypot(goal[0] - start[0], goal[1] - start[1])
    if rho is None or rho == 0.0:
        return distance / u1max
    if math.isinf(rho):  # no turning at all: only a straight along the common heading reaches the goal
        x, y, phi = _local(start, goal, 1.0)
        on_line = abs(y) <= 1e-9 * (1.0 + distance) and abs(_mod2pi(phi)) <= 1e-12
        return distance / u1max if on_line else math.inf
    return reeds_shepp(start, goal, rho).length / u1max


__all__ = ["LIMIT_SHARE", "Path", "dubins", "integrated_speed", "limited_path_guess", "min_turning_radius",
           "path_guess", "reeds_shepp", "reeds_shepp_time", "sample"]  # fmt: skip
