"""A one-file CasADi Opti solve of a truck scenario: the peer process of bench_process.py.

Usage: python benchmarks/opti_script.py SCENARIO.toml [--intervals N] [--pass ccw|cw|none]
       [--route arc|line] [--tf-scale S]

Imports only the standard library, numpy and casadi (not the project's ``model``
package), so the process pays no project imports. It builds the project's trapezoid
transcription (model/transcription.py; the same NLP as benchmarks/opti_peer.py):

- states x, y, theta, phi and controls u1, u2 at the N + 1 nodes of a uniform grid,
  x' = u1 cos theta, y' = u1 sin theta, theta' = u1 tan(phi) / d, phi' = u2;
- trapezoid defects X_k - X_{k-1} = h/2 (f_{k-1} + f_k), h = Tf / N;
- bounds, initial and final values as constraints (detect_simple_bounds makes them
  variable bounds, as the project's presolve does);
- dist^2 >= R^2 at every node for every obstacle (R = radius + safety), and for a pass
  "ccw"/"cw" the signed angle swept around the first obstacle, sum_k 2 atan(cross /
  (|a||b| + dot)), >= 0 or <= 0;
- energy: J = h (sum_k L_k - (L_0 + L_N) / 2), L = 1/2 (u1^2 + u2^2) (model/costs.py);
  time: J = Tf, a variable >= 1e-3;
- the project's geometric guess (model/guess.py) for one start (pass, route, Tf scale);
  the defaults (route arc, scale 1) are the project's first start, but its best result
  may come from another (format-example, N = 100: route line), so bench_process.py
  passes the start of the attempt `roundabout solve` kept.

With the time objective and a pass constraint, CasADi's Jacobian construction costs
O(N^2) (the swept-angle row and the Tf column are both dense, which defeats its
one-directional colouring): about 1.6 s of this script's 2.2 s at N = 400.

Prints one JSON line: objective, iterations, status, and wall seconds (build, solve,
Ipopt's own t_wall_total, and the whole of main()).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import tomllib
from pathlib import Path

import casadi as ca
import numpy as np

# model/ipopt.py DEFAULT_OPTIONS (copied, not imported: this process must not import the project).
IPOPT_OPTIONS = {"tol": 1e-8, "max_iter": 3000, "sb": "yes", "print_level": 0, "mumps_pivot_order": 6}
# record_time: Ipopt's own wall time in opti.stats() (t_wall_total), without printing it.
CASADI_OPTIONS = {"expand": True, "print_time": False, "record_time": True, "detect_simple_bounds": True}
STATES = ("x", "y", "theta", "phi")
CONTROLS = ("u1", "u2")


def load(path: Path) -> dict:
    """The scenario's TOML tables, with the truck's fields checked."""
    data = tomllib.loads(path.read_text())
    if data["vehicle"].get("model") != "truck":
        raise SystemExit(f"{path}: only vehicle.model = 'truck' is supported")
    problem = data["problem"]
    if problem.get("objective") not in ("energy", "time"):
        raise SystemExit(f"{path}: problem.objective must be 'energy' or 'time'")
    return data


def keep_out(ob: dict) -> float:
    """R = radius + safety, the radius of the forbidden disc."""
    return float(ob["radius"]) + float(ob.get("safety", 0.0))


def wheelbase(data: dict) -> float:
    """d in metres (model/vehicles.py Truck's default 0.1 if absent)."""
    return float(data["vehicle"].get("wheelbase", 0.1))


def max_speed(data: dict) -> float:
    lo, hi = data["bounds"]["u1"]
    return max(abs(lo), abs(hi))


# -- the project's guess (model/guess.py, truck only) -------------------------------------
def path(data: dict, passing: str, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A line from start to goal, or an arc around the first obstacle in the pass direction."""
    ini, fin = data["initial"], data.get("final", {})
    p0 = np.array([ini["x"], ini["y"]], dtype=float)
    if "x" in fin and "y" in fin:
        p1 = np.array([fin["x"], fin["y"]], dtype=float)
    else:
        th, tf = ini.get("theta", 0.0), data["problem"].get("final_time") or 1.0
        p1 = p0 + max_speed(data) * tf * 0.5 * np.array([math.cos(th), math.sin(th)])
    obstacles = data.get("obstacles", [])
    if not obstacles or passing not in ("ccw", "cw"):
        return p0[0] + (p1[0] - p0[0]) * s, p0[1] + (p1[1] - p0[1]) * s
    c = np.array(obstacles[0]["center"], dtype=float)
    a0 = math.atan2(*(p0 - c)[::-1])
    a1 = math.atan2(*(p1 - c)[::-1])
    sweep = (a1 - a0) % (2 * math.pi)
    if passing == "cw":
        sweep -= 2 * math.pi
    r = np.maximum((1 - s) * np.linalg.norm(p0 - c) + s * np.linalg.norm(p1 - c), 1.2 * keep_out(obstacles[0]))
    a = a0 + sweep * s
    return c[0] + r * np.cos(a), c[1] + r * np.sin(a)


def guess_final_time(data: dict, passing: str) -> float:
    """The given final time, or path length over 70 % of the top speed, plus 1 s."""
    tf = data["problem"].get("final_time")
    if tf is not None:
        return float(tf)
    x, y = path(data, passing, np.linspace(0.0, 1.0, 201))
    return max(float(np.sum(np.hypot(np.diff(x), np.diff(y)))), 0.1) / (0.7 * max_speed(data)) + 1.0


def initial_guess(data: dict, passing: str, n: int, tf: float, route: str) -> dict[str, np.ndarray]:
    """Node values of every state and control, clipped to their bounds."""
    s = np.linspace(0.0, 1.0, n + 1)
    x, y = path(data, passing if route == "arc" else "none", s)
    dx, dy = np.gradient(x, s), np.gradient(y, s)
    heading = np.unwrap(np.arctan2(dy, dx))
    theta0 = data["initial"].get("theta", heading[0])
    heading += 2 * math.pi * round((theta0 - heading[0]) / (2 * math.pi))
    curvature = np.gradient(heading, s) / np.maximum(np.hypot(dx, dy), 1e-9)
    guess = {"x": x, "y": y, "theta": heading, "phi": np.arctan(curvature * wheelbase(data))}
    guess = {k: clip(v, data["bounds"].get(k)) for k, v in guess.items()}
    guess["u1"] = np.hypot(dx, dy) / tf
    guess["u2"] = np.gradient(guess["phi"], s) / tf  # phi' = u2
    return {k: clip(v, data["bounds"].get(k)) for k, v in guess.items()}


def clip(values: np.ndarray, bounds: list[float] | None) -> np.ndarray:
    return values if bounds is None else np.clip(values, bounds[0], bounds[1])


# -- the transcription -----------------------------------------------------------------------
def build(data: dict, n: int, passing: str, route: str, tf_scale: float) -> tuple[ca.Opti, ca.MX]:
    """The Opti problem with its guess and solver set; returns (opti, objective)."""
    opti = ca.Opti()
    X = {s: opti.variable(n + 1) for s in STATES + CONTROLS}
    time_optimal = data["problem"]["objective"] == "time"
    tf_guess = guess_final_time(data, passing) * (tf_scale if time_optimal else 1.0)
    tf = opti.variable() if time_optimal else tf_guess
    h = tf / n
    transcribe(opti, data, X, h)
    obstacles(opti, data.get("obstacles", []), X["x"], X["y"], passing)
    if time_optimal:
        opti.subject_to(tf >= 1e-3)
        opti.set_initial(tf, tf_guess)
        objective = tf
    else:
        L = (X["u1"] ** 2 + X["u2"] ** 2) / 2
        objective = h * (ca.sum1(L) - (L[0] + L[-1]) / 2)
    opti.minimize(objective)
    for name, vals in initial_guess(data, passing, n, tf_guess, route).items():
        opti.set_initial(X[name], vals)
    opti.solver("ipopt", CASADI_OPTIONS, IPOPT_OPTIONS)
    return opti, objective


def transcribe(opti: ca.Opti, data: dict, X: dict, h) -> None:
    """Trapezoid defects of the truck, boundary values and bounds (the project's transcription)."""
    d = wheelbase(data)
    x, y, theta, phi, u1, u2 = (X[k] for k in STATES + CONTROLS)
    rhs = {"x": u1 * ca.cos(theta), "y": u1 * ca.sin(theta), "theta": u1 * ca.tan(phi) / d, "phi": u2}
    for s in STATES:
        opti.subject_to(X[s][1:] - X[s][:-1] == h / 2 * (rhs[s][:-1] + rhs[s][1:]))
    for s, val in data["initial"].items():
        opti.subject_to(X[s][0] == val)
    for s, val in data.get("final", {}).items():
        opti.subject_to(X[s][-1] == val)
    for name, (lo, hi) in data["bounds"].items():
        opti.subject_to(opti.bounded(lo, X[name], hi))


def obstacles(opti: ca.Opti, items: list[dict], x: ca.MX, y: ca.MX, passing: str) -> None:
    """dist^2 >= R^2 at every node; the swept-angle sign around the first obstacle."""
    for ob in items:
        cx, cy = ob["center"]
        opti.subject_to((x - cx) ** 2 + (y - cy) ** 2 >= keep_out(ob) ** 2)
    if items and passing in ("ccw", "cw"):
        cx, cy = items[0]["center"]
        ax, ay, bx, by = x[:-1] - cx, y[:-1] - cy, x[1:] - cx, y[1:] - cy
        norms = ca.sqrt((ax**2 + ay**2) * (bx**2 + by**2))
        sweep = ca.sum1(2 * ca.atan((ax * by - ay * bx) / (norms + ax * bx + ay * by)))
        opti.subject_to(sweep >= 0 if passing == "ccw" else sweep <= 0)


def solve(opti: ca.Opti, objective: ca.MX) -> dict:
    """Run Ipopt; objective, iterations and status (Ipopt's return status) of the result."""
    try:
        value = float(opti.solve().value(objective))
    except RuntimeError:
        value = float(opti.debug.value(objective))
    stats = opti.stats()
    return {
        "objective": value,
        "iterations": int(stats.get("iter_count", -1)),
        "status": str(stats.get("return_status", "unknown")),
        "success": bool(stats.get("success", False)),
        "ipopt_seconds": float(stats.get("t_wall_total", math.nan)),
    }


def default_pass(data: dict) -> str:
    """The scenario's problem.pass; 'ccw' for 'auto'; 'none' without obstacles."""
    if not data.get("obstacles"):
        return "none"
    passing = data["problem"].get("pass", "auto")
    return "ccw" if passing == "auto" else passing


def main(argv: list[str] | None = None) -> int:
    start = time.perf_counter()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--intervals", type=int, help="N (default: problem.intervals, else 100)")
    ap.add_argument("--pass", dest="passing", choices=("ccw", "cw", "none"), help="default: see default_pass")
    ap.add_argument("--route", choices=("arc", "line"), default="arc", help="guess route (the project's starts)")
    ap.add_argument("--tf-scale", type=float, default=1.0, help="scale of the Tf guess (time objective)")
    args = ap.parse_args(argv)
    data = load(args.scenario)
    n = args.intervals or int(data["problem"].get("intervals", 100))
    passing = args.passing or default_pass(data)
    opti, objective = build(data, n, passing, args.route, args.tf_scale)
    built = time.perf_counter()
    result = solve(opti, objective)
    end = time.perf_counter()
    start_info = {"pass": passing, "route": args.route, "tf_scale": args.tf_scale}
    times = {"build_seconds": built - start, "solve_seconds": end - built, "wall_seconds": end - start}
    print(json.dumps({"intervals": n, **start_info, **result, **times}))
    return 0 if result["success"] else 1


if __name__ == "__main__":
    sys.exit(main())
