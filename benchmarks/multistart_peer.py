"""An independent, thorough multi-start for truck scenario files: the benchmark peer of bench_robustness.py.

Usage: python benchmarks/multistart_peer.py SCENARIO.toml [--intervals N] [--max-starts K]

A benchmark peer, not the project's code path: it imports only the standard library, numpy,
casadi and ``benchmarks/opti_script.py`` (itself standard library + numpy + casadi), never the
project's ``model`` package. The NLP is the project's trapezoid transcription, built in CasADi
Opti exactly as opti_script.py builds it (node states and controls, trapezoid defects, bounds,
boundary values, dist^2 >= R^2 at every node, the swept-angle sign for an explicit
``problem.pass``; energy by the trapezoid rule on the nodes, or the free final time), except that
for the energy objective Tf is an Opti parameter, so one built NLP serves a homotopy in Tf.

Starts (at most ``--max-starts``, default 20), each solved from its own geometric guess:

- opti_script's guesses (the project's old ones): the straight line, and an arc around the
  first obstacle in each direction;
- cubic Hermite curves from the start pose to the goal pose (tangent scales 0.5, 1 and 2),
  forward, and the whole way in reverse;
- for every choice of side (left/right of the start-goal line) around every obstacle, a chain
  of Hermite legs through a waypoint beside each obstacle;
- a reversing start (back up while turning left or right, then drive to the goal) and an
  overshoot that reverses into the goal;
- time objective: every route at 1x its Tf guess, then as many as fit at 2x;
- energy objective: a homotopy in Tf (2, 1.6, 1.3, 1.1, 1 x the requested Tf, each solve
  warm-started from the previous one) from the line, the Hermite curve and each side choice;
  and, beyond the cap, the minimum time T found by the same multi-start on the time problem:
  waiting being admissible, the energy problem is feasible if and only if Tf >= the true
  minimum time, and when T <= Tf the time-optimal trajectory slowed down to Tf (controls
  times T / Tf) is an exactly feasible start ("stretched min-time").

A start counts only if its node values are feasible, checked here in numpy independently of
Ipopt's status: max violation (defects, boundary values, bounds, clearance R - dist, pass sign)
below 1e-6. The best feasible objective (recomputed from the node values) is kept.

Prints one JSON line: the best start (label, objective, final time, violation) and every start.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

try:  # imported as benchmarks.multistart_peer
    from benchmarks import opti_script as script
except ImportError:  # run as a script: benchmarks/ itself is sys.path[0]
    import opti_script as script

STATES, CONTROLS, keep_out, wheelbase = script.STATES, script.CONTROLS, script.keep_out, script.wheelbase
FEASIBLE = 1e-6  # max constraint violation of a start that counts
PEER_IPOPT = {**script.IPOPT_OPTIONS, "max_iter": 1000, "max_wall_time": 30.0}
HOMOTOPY = (2.0, 1.6, 1.3, 1.1, 1.0)  # Tf / requested Tf, energy objective
Pose = tuple[float, float, float]
Guess = dict[str, np.ndarray]


# -- the transcription (opti_script.build, with Tf a parameter for the energy objective) ----
@dataclass
class Transcription:
    """One built Opti NLP, solved again from each start."""

    opti: ca.Opti
    X: dict[str, ca.MX]
    tf: ca.MX
    objective: ca.MX
    time_optimal: bool
    n: int


def build(data: dict, n: int) -> Transcription:
    """The project's trapezoid transcription in Opti (see opti_script.build).

    Parameters
    ----------
    data : dict
        The scenario's TOML document (``opti_script.load``).
    n : int
        Number of trapezoid intervals.

    Returns
    -------
    Transcription
        The Opti problem with Ipopt set (tol 1e-8, at most 1000 iterations and 30 s per solve);
        Tf is a variable (time objective) or a parameter set to problem.final_time (energy).
    """
    opti = ca.Opti()
    X = {s: opti.variable(n + 1) for s in STATES + CONTROLS}
    time_optimal = data["problem"]["objective"] == "time"
    tf = opti.variable() if time_optimal else opti.parameter()
    h = tf / n
    script.transcribe(opti, data, X, h)
    script.obstacles(opti, data.get("obstacles", []), X["x"], X["y"], pass_constraint(data))
    if time_optimal:
        opti.subject_to(tf >= 1e-3)
        objective = tf
    else:
        opti.set_value(tf, float(data["problem"]["final_time"]))
        L = (X["u1"] ** 2 + X["u2"] ** 2) / 2
        objective = h * (ca.sum1(L) - (L[0] + L[-1]) / 2)
    opti.minimize(objective)
    opti.solver("ipopt", script.CASADI_OPTIONS, PEER_IPOPT)
    return Transcription(opti, X, tf, objective, time_optimal, n)


def pass_constraint(data: dict) -> str:
    """The scenario's explicit pass direction; 'none' for 'auto' (the union of both) or no obstacle."""
    passing = data["problem"].get("pass", "auto")
    return passing if data.get("obstacles") and passing in ("ccw", "cw") else "none"


def solve_from(tr: Transcription, guess: Guess, tf: float) -> tuple[Guess, float, dict]:
    """One Ipopt run from ``guess``; node values, Tf and Ipopt's statistics."""
    for name, vals in guess.items():
        tr.opti.set_initial(tr.X[name], vals)
    if tr.time_optimal:
        tr.opti.set_initial(tr.tf, tf)
    else:
        tr.opti.set_value(tr.tf, tf)
    try:
        value = tr.opti.solve().value
    except RuntimeError:
        value = tr.opti.debug.value
    values = {k: np.atleast_1d(np.asarray(value(v), dtype=float)).ravel() for k, v in tr.X.items()}
    tf_value = float(value(tr.tf)) if tr.time_optimal else tf
    return values, tf_value, tr.opti.stats()


# -- feasibility and objective, in numpy ----------------------------------------------------
def violation(data: dict, values: Guess, tf: float) -> float:
    """Largest violation of any constraint of the NLP at the node values.

    Parameters
    ----------
    data : dict
        The scenario document.
    values : dict of numpy.ndarray
        x, y, theta, phi, u1, u2 at the N + 1 nodes.
    tf : float
        Final time, s.

    Returns
    -------
    float
        max of |trapezoid defects|, |boundary values - given|, bound excess, R - dist at every
        node and obstacle, the wrong sign of the swept angle (explicit pass only) and 1e-3 - Tf
        (time objective), at least 0; inf if any value is not finite.
    """
    if not all(np.all(np.isfinite(v)) for v in values.values()) or not math.isfinite(tf):
        return math.inf
    n = len(values["x"]) - 1
    x, y, th, phi, u1, u2 = (values[k] for k in STATES + CONTROLS)
    f = {"x": u1 * np.cos(th), "y": u1 * np.sin(th), "theta": u1 * np.tan(phi) / wheelbase(data), "phi": u2}
    worst = [max(float(np.max(np.abs(np.diff(values[s]) - tf / n / 2 * (f[s][:-1] + f[s][1:])))) for s in STATES)]
    worst += [abs(values[s][0] - v) for s, v in data["initial"].items()]
    worst += [abs(values[s][-1] - v) for s, v in data.get("final", {}).items()]
    worst += [float(np.max(np.maximum(lo - values[k], values[k] - hi))) for k, (lo, hi) in data["bounds"].items()]
    for ob in data.get("obstacles", []):
        worst.append(float(np.max(keep_out(ob) - np.hypot(x - ob["center"][0], y - ob["center"][1]))))
    passing = pass_constraint(data)
    if passing != "none":
        sweep = swept_angle(x, y, data["obstacles"][0]["center"])
        worst.append(-sweep if passing == "ccw" else sweep)
    if data["problem"]["objective"] == "time":
        worst.append(1e-3 - tf)
    return max(0.0, *worst)


def swept_angle(x: np.ndarray, y: np.ndarray, center: list[float]) -> float:
    """Signed angle swept around ``center`` from node to node, rad."""
    a = np.stack([x - center[0], y - center[1]])
    cross = a[0, :-1] * a[1, 1:] - a[1, :-1] * a[0, 1:]
    dot = np.sum(a[:, :-1] * a[:, 1:], axis=0)
    return float(np.sum(np.arctan2(cross, dot)))


def objective(data: dict, values: Guess, tf: float) -> float:
    """Energy 1/2 int (u1^2 + u2^2) dt by the trapezoid rule on the nodes, or Tf."""
    if data["problem"]["objective"] == "time":
        return tf
    L = (values["u1"] ** 2 + values["u2"] ** 2) / 2
    n = len(L) - 1
    return float(tf / n * (np.sum(L) - (L[0] + L[-1]) / 2))


# -- geometric guesses ------------------------------------------------------------------------
def hermite(a: Pose, b: Pose, gear: int, scale: float, m: int = 200) -> np.ndarray:
    """(m, 2) points of a cubic Hermite curve from pose a to pose b; gear -1 drives it in reverse."""
    p0, p1 = np.array(a[:2]), np.array(b[:2])
    length = float(np.linalg.norm(p1 - p0))
    t0 = gear * scale * length * np.array([math.cos(a[2]), math.sin(a[2])])
    t1 = gear * scale * length * np.array([math.cos(b[2]), math.sin(b[2])])
    s = np.linspace(0.0, 1.0, m)[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * p0 + h10 * t0 + h01 * p1 + h11 * t1


def chain_guess(data: dict, legs: list[tuple[Pose, Pose, int]], n: int, tf: float, scale: float = 1.0) -> Guess:
    """Node values along a chain of Hermite legs, driven at constant speed.

    Parameters
    ----------
    data : dict
        The scenario document (wheelbase, bounds, initial heading).
    legs : list of (Pose, Pose, int)
        From pose, to pose, gear (+1 forward, -1 reverse); the poses are vehicle headings.
    n : int
        Number of intervals.
    tf : float
        Final time the guess is driven in, s.
    scale : float
        Tangent length of each leg as a multiple of its chord.

    Returns
    -------
    dict of numpy.ndarray
        x, y, theta (unwrapped from the initial heading), phi = atan(d kappa), u1 = +-length / tf,
        u2 = dphi/dt at the n + 1 nodes (equally spaced in arc length); phi, u1, u2 clipped to
        their bounds.
    """
    pts, gears = [], []
    for a, b, gear in legs:
        p = hermite(a, b, gear, scale)
        pts.append(p if not pts else p[1:])
        gears.append(np.full(len(pts[-1]), gear))
    p, gear = np.vstack(pts), np.concatenate(gears).astype(float)
    ds = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(ds)])
    motion = np.arctan2(np.gradient(p[:, 1]), np.gradient(p[:, 0]))
    heading = np.unwrap(motion + np.where(gear < 0, math.pi, 0.0))
    heading += 2 * math.pi * round((data["initial"]["theta"] - heading[0]) / (2 * math.pi))
    kappa = gear * np.gradient(heading) / np.maximum(np.gradient(s), 1e-9)
    at = np.linspace(0.0, s[-1], n + 1)
    guess = {"x": np.interp(at, s, p[:, 0]), "y": np.interp(at, s, p[:, 1]), "theta": np.interp(at, s, heading)}
    guess["phi"] = bounded(data, "phi", np.arctan(wheelbase(data) * np.interp(at, s, kappa)))
    guess["u1"] = bounded(data, "u1", np.interp(at, s, gear) * s[-1] / tf)
    guess["u2"] = bounded(data, "u2", np.gradient(guess["phi"]) * n / tf)
    return guess


def bounded(data: dict, name: str, values: np.ndarray) -> np.ndarray:
    lo, hi = data["bounds"].get(name, (-math.inf, math.inf))
    return np.clip(values, lo, hi)


def poses(data: dict) -> tuple[Pose, Pose]:
    """Start and goal poses (a free final heading: the start-goal direction)."""
    ini, fin = data["initial"], data["final"]
    start = (float(ini["x"]), float(ini["y"]), float(ini["theta"]))
    bearing = math.atan2(fin["y"] - start[1], fin["x"] - start[0])
    return start, (float(fin["x"]), float(fin["y"]), float(fin.get("theta", bearing)))


def side_waypoints(data: dict, sides: tuple[int, ...]) -> list[Pose]:
    """A pose beside each obstacle (side +1: left of the start-goal line), in order along the line."""
    start, goal = poses(data)
    e = np.array(goal[:2]) - np.array(start[:2])
    e /= max(float(np.linalg.norm(e)), 1e-9)
    normal, heading = np.array([-e[1], e[0]]), math.atan2(e[1], e[0])
    points = []
    for ob, side in zip(data["obstacles"], sides, strict=True):
        c = np.array(ob["center"], dtype=float)
        w = c + side * normal * (1.3 * keep_out(ob) + 0.05)
        points.append((float(np.dot(w - np.array(start[:2]), e)), (float(w[0]), float(w[1]), heading)))
    return [pose for _, pose in sorted(points)]


def routes(data: dict) -> list[tuple[str, Callable[[int, float], Guess]]]:
    """Every geometric route as (label, guess(n, tf))."""
    start, goal = poses(data)
    dist = math.hypot(goal[0] - start[0], goal[1] - start[1])
    out = [("line", lambda n, tf: script.initial_guess(data, "none", n, tf, "line"))]
    for scale in (1.0, 0.5, 2.0):
        out.append((f"hermite x{scale:g}", lambda n, tf, k=scale: chain_guess(data, [(start, goal, 1)], n, tf, k)))
    obs = data.get("obstacles", [])
    if obs:
        for passing in ("ccw", "cw"):
            out.append((f"arc {passing}", lambda n, tf, p=passing: script.initial_guess(data, p, n, tf, "arc")))
    for sides in itertools.product((1, -1), repeat=len(obs)) if obs else ():
        label = "sides " + "".join("L" if s > 0 else "R" for s in sides)
        out.append((label, lambda n, tf, s=sides: chain_guess(data, side_legs(data, s), n, tf)))
    back = 0.25 * dist + 0.1
    for turn in (0.6, -0.6):
        p = (start[0] - back * math.cos(start[2]), start[1] - back * math.sin(start[2]), start[2] + turn)
        out.append((f"reverse first {turn:+g}", lambda n, tf, p=p: chain_guess(data, [(start, p, -1), (p, goal, 1)],
                                                                                  n, tf)))  # fmt: skip
    q = (goal[0] + back * math.cos(goal[2]), goal[1] + back * math.sin(goal[2]), goal[2])
    out.append(("reverse into goal", lambda n, tf: chain_guess(data, [(start, q, 1), (q, goal, -1)], n, tf)))
    out.append(("all reverse", lambda n, tf: chain_guess(data, [(start, goal, -1)], n, tf)))
    return out


def side_legs(data: dict, sides: tuple[int, ...]) -> list[tuple[Pose, Pose, int]]:
    start, goal = poses(data)
    stops = [start, *side_waypoints(data, sides), goal]
    return [(a, b, 1) for a, b in itertools.pairwise(stops)]


def tf_guess(data: dict, guess: Guess) -> float:
    """Time objective: the guess path's length over 70 % of the top speed, plus 1 s (opti_script's rule)."""
    length = float(np.sum(np.hypot(np.diff(guess["x"]), np.diff(guess["y"]))))
    return max(length, 0.1) / (0.7 * script.max_speed(data)) + 1.0


# -- the multi-start --------------------------------------------------------------------------
def start_plan(data: dict, max_starts: int) -> list[tuple[str, Callable[[int, float], Guess], tuple[float, ...]]]:
    """(label, guess, Tf factors): time: factor scales the Tf guess; energy: the homotopy's Tf / Tf."""
    base = routes(data)
    if data["problem"]["objective"] == "time":
        plan = [(label + " tf x1", g, (1.0,)) for label, g in base]
        plan += [(label + " tf x2", g, (2.0,)) for label, g in base]
    else:
        homotopy = [(f"homotopy {lb}", g, HOMOTOPY) for lb, g in base if lb in ("line", "hermite x1") or "sides" in lb]
        # the plain starts give way to the homotopies under the cap
        plan = [(label, g, (1.0,)) for label, g in base][: max(max_starts - len(homotopy), 0)] + homotopy
    return plan[:max_starts]


def run_start(tr: Transcription, data: dict, guess_of: Callable[[int, float], Guess], factors: tuple[float, ...]):
    """Solve one start (a homotopy: each Tf from the previous solution); its record and node values."""
    t0, iters = time.perf_counter(), 0
    if tr.time_optimal:
        tf = tf_guess(data, guess_of(tr.n, 1.0)) * factors[0]
        values, tf, stats = solve_from(tr, guess_of(tr.n, tf), tf)
        iters = int(stats.get("iter_count", 0))
    else:
        requested = float(data["problem"]["final_time"])
        values, prev = guess_of(tr.n, factors[0] * requested), factors[0] * requested
        for factor in factors:
            tf = factor * requested
            values = {**values, "u1": values["u1"] * prev / tf, "u2": values["u2"] * prev / tf}
            values, tf, stats = solve_from(tr, values, tf)
            iters += int(stats.get("iter_count", 0))
            prev = tf
    viol = violation(data, values, tf)
    record = {"status": str(stats.get("return_status", "unknown")), "objective": objective(data, values, tf),
              "final_time": tf, "violation": viol, "feasible": viol < FEASIBLE, "iterations": iters,
              "seconds": time.perf_counter() - t0}  # fmt: skip
    return record, values


def best_of(tr: Transcription, data: dict, plan: list) -> tuple[list[dict], dict | None, Guess | None]:
    """Solve every start of ``plan``; all records, the best feasible record and its node values."""
    records, best, best_values = [], None, None
    for label, guess_of, factors in plan:
        record, values = run_start(tr, data, guess_of, factors)
        records.append({"label": label, **record})
        if record["feasible"] and (best is None or record["objective"] < best["objective"]):
            best, best_values = records[-1], values
    return records, best, best_values


def as_time_problem(data: dict) -> dict:
    """The same scenario with the free final time minimised."""
    problem = {k: v for k, v in data["problem"].items() if k != "final_time"}
    return {**data, "problem": {**problem, "objective": "time"}}


def stretched_start(data: dict, n: int, max_starts: int) -> tuple[dict, Callable[[int, float], Guess] | None]:
    """Energy objective: the minimum time found by a time multi-start, and its trajectory slowed to Tf.

    Waiting is admissible (u1 = u2 = 0), so the energy problem is feasible if and only if its
    Tf is at least the minimum time; a trajectory of the time problem with its controls
    divided by Tf / T (h multiplied by it) satisfies the trapezoid defects of the energy NLP
    exactly, so it is a feasible start whenever T <= Tf.
    """
    tdata = as_time_problem(data)
    records, best, values = best_of(build(tdata, n), tdata, start_plan(tdata, max_starts))
    info = {"objective": best["objective"] if best else None, "label": best["label"] if best else None,
            "feasible_starts": sum(r["feasible"] for r in records), "starts": len(records)}  # fmt: skip
    tf = float(data["problem"]["final_time"])
    if best is None or best["objective"] > tf:
        return info, None
    slow = best["objective"] / tf
    return info, lambda _n, _tf: {**values, "u1": values["u1"] * slow, "u2": values["u2"] * slow}


def multistart(data: dict, n: int, max_starts: int = 20) -> dict:
    """The peer's multi-start on one scenario.

    Parameters
    ----------
    data : dict
        The scenario document.
    n : int
        Number of intervals.
    max_starts : int
        At most this many starts of ``start_plan`` (energy: plus the stretched minimum-time
        start, after a time multi-start of the same size).

    Returns
    -------
    dict
        ``best`` (the feasible start of least objective, or None), ``starts`` (every start: label,
        Ipopt status, objective, final time, violation, feasible, iterations, seconds),
        ``feasible_starts``, ``min_time`` (energy: the least time found and its start) and
        ``seconds``.
    """
    t0 = time.perf_counter()
    tr = build(data, n)
    records, best, _ = best_of(tr, data, start_plan(data, max_starts))
    min_time = None
    if not tr.time_optimal:
        min_time, stretched = stretched_start(data, n, max_starts)
        if stretched is not None:
            more, other, _ = best_of(tr, data, [("stretched min-time", stretched, (1.0,))])
            records += more
            if other is not None and (best is None or other["objective"] < best["objective"]):
                best = other
    return {"intervals": n, "objective_name": data["problem"]["objective"], "best": best,
            "feasible_starts": sum(r["feasible"] for r in records), "starts": records, "min_time": min_time,
            "seconds": time.perf_counter() - t0}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--intervals", type=int, help="N (default: problem.intervals, else 100)")
    ap.add_argument("--max-starts", type=int, default=20, help="at most this many starts (default 20)")
    args = ap.parse_args(argv)
    data = script.load(args.scenario)
    if "x" not in data.get("final", {}) or "y" not in data.get("final", {}):
        raise SystemExit(f"{args.scenario}: the peer needs final.x and final.y")
    n = args.intervals or int(data["problem"].get("intervals", 100))
    result = multistart(data, n, args.max_starts)
    print(json.dumps({"scenario": str(args.scenario), **result}))
    return 0 if result["best"] is not None else 1


if __name__ == "__main__":
    sys.exit(main())
