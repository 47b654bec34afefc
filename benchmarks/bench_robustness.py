"""Robustness suite: seeded random disc-obstacle truck scenarios through ``roundabout solve``.

Usage: python benchmarks/bench_robustness.py [--count 200] [--seed 0] [--jobs 2] [--subset 20]
       [--timeout 120] [--peer-timeout 900] [--json out.json] [--keep DIR]

1. ``generate(seed, index)`` draws one scenario in the style of the seed paper's problems
   (``numpy.random.default_rng([seed, index])``: scenario ``index`` of seed ``seed`` is the same
   whatever ``--count``): truck, d in [0.05, 0.3]; |u1| <= 0.9-1.1, |u2| <= 0.3-0.4,
   |phi| <= 0.5-0.7; start at the origin, heading 0 (70 %) or random, phi = 0; a goal 0.5-2 m
   away, mostly ahead, 35 % of them off to the side, final heading near the bearing or (40 %)
   sharp, final phi free or (25 %) 0; 0-2 obstacles of radius 0.05-0.4 (safety 0-0.05) near the
   start-goal line, never covering the start or the goal (the radius is cut to keep 5 cm, an
   obstacle that cannot keep them is dropped); energy with Tf = 1.2-3 x distance / u1max (60 %),
   or time (free Tf); N = 60-100; pass "auto".
2. Each file is solved by ``sys.executable -m model.cli solve FILE --out DIR`` in a subprocess
   (per-scenario timeout) and classified:

   - solved: exit 0, summary.json ``valid`` and the independent re-check below passes;
   - refused: exit 1, summary.json written, its status not "optimal" or ``valid`` false
     (honest; those with a ``diagnosis`` are counted too);
   - crashed: any other exit code (2 included: the generator never writes invalid input), a
     traceback on stderr, a timeout, no summary.json, or exit 1 with a valid optimal summary;
   - silent: exit 0 but ``valid`` false, or the re-check fails: the controls of trajectory.csv,
     linear between nodes, re-integrated with scipy (DOP853, interval by interval) from the
     initial state, must end within the accuracy of docs/scenario-format.md (1e-3 x max(1, L)
     for x and y, L the start-goal distance; 1e-3 for the other goal values); every node must keep
     dist >= radius + safety - 1e-6 from every obstacle; the summary's objective must match
     the one recomputed from the file (relative 1e-6).
3. On a subset (``--subset``: every refused scenario up to half of it, the rest solved ones
   spread over the indices) the objective is compared with ``benchmarks/multistart_peer.py``,
   an independent multi-start in plain CasADi Opti. Every time problem (obstacles only lengthen
   the path) is checked against the Reeds-Shepp lower bound Tf >= RS length / u1max
   (``model.search.paths.reeds_shepp_time``), and every energy problem whose Tf is below it is
   marked infeasible by that bound.

Prints Markdown tables (counts, seconds per scenario, gaps to the peer) and the lists of
crashes, silent failures and cases the project refused but the peer solved; ``--json`` writes
every record.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PEER = ROOT / "benchmarks" / "multistart_peer.py"
GOAL_TOL, CLEARANCE_TOL, OBJECTIVE_RTOL = 1e-3, 1e-6, 1e-6
GAP_TOL = 1e-3  # 0.1 %
MARGIN = 0.05  # least distance kept between an obstacle's keep-out disc and the start or the goal
CATEGORIES = ("solved", "refused", "crashed", "silent")


# -- the generator -----------------------------------------------------------------------------
def generate(seed: int, index: int) -> dict:
    """Scenario ``index`` of ``seed`` as the TOML document's dictionary (deterministic).

    Parameters
    ----------
    seed, index : int
        Together they seed ``numpy.random.default_rng([seed, index])``.

    Returns
    -------
    dict
        Tables name, vehicle, bounds, obstacles, initial, final, problem.
    """
    rng = np.random.default_rng([seed, index])
    r4 = lambda v: round(float(v), 4)  # noqa: E731
    d = r4(rng.uniform(0.05, 0.3))
    u1max, u2max, phimax = r4(rng.uniform(0.9, 1.1)), r4(rng.uniform(0.3, 0.4)), r4(rng.uniform(0.5, 0.7))
    theta0 = 0.0 if rng.random() < 0.7 else r4(rng.uniform(-math.pi, math.pi))
    dist = rng.uniform(0.5, 2.0)
    bearing = theta0 + (rng.uniform(-0.4, 0.4) if rng.random() < 0.65 else rng.uniform(-1.6, 1.6))
    heading = bearing + (rng.uniform(-0.5, 0.5) if rng.random() < 0.6 else rng.uniform(-2.6, 2.6))
    goal = {"x": r4(dist * math.cos(bearing)), "y": r4(dist * math.sin(bearing)), "theta": r4(heading)}
    if rng.random() < 0.25:
        goal["phi"] = 0.0
    obstacles = _obstacles(rng, (goal["x"], goal["y"]), int(rng.choice(3, p=[0.25, 0.5, 0.25])))
    problem: dict = {"objective": "energy" if rng.random() < 0.6 else "time"}
    if problem["objective"] == "energy":
        problem["final_time"] = r4(rng.uniform(1.2, 3.0) * math.hypot(goal["x"], goal["y"]) / u1max)
    problem["intervals"] = int(rng.integers(60, 101))
    return {
        "name": f"rob-s{seed}-{index:03d}",
        "vehicle": {"model": "truck", "wheelbase": d},
        "bounds": {"u1": [-u1max, u1max], "u2": [-u2max, u2max], "phi": [-phimax, phimax]},
        "obstacles": obstacles,
        "initial": {"x": 0.0, "y": 0.0, "theta": theta0, "phi": 0.0},
        "final": goal,
        "problem": problem,
    }


def _obstacles(rng: np.random.Generator, goal: tuple[float, float], count: int) -> list[dict]:
    """``count`` discs near the segment from the origin to ``goal``, none covering either end."""
    g = np.array(goal)
    length = float(np.linalg.norm(g))
    normal = np.array([-g[1], g[0]]) / length
    out = []
    for _ in range(count):
        radius, safety = rng.uniform(0.05, 0.4), round(float(rng.uniform(0.0, 0.05)), 4)
        center = rng.uniform(0.2, 0.8) * g + rng.uniform(-0.8, 0.8) * (radius + safety) * normal
        room = min(float(np.linalg.norm(center)), float(np.linalg.norm(center - g))) - safety - MARGIN
        radius = min(radius, room)
        if radius >= 0.05:
            out.append({"center": [round(float(c), 4) for c in center], "radius": round(radius, 4), "safety": safety})
    return out


def to_toml(data: dict) -> str:
    """The scenario dictionary as TOML text (the few value types ``generate`` uses)."""
    lines = [f"name = {json.dumps(data['name'])}", ""]
    for table in ("vehicle", "bounds", "initial", "final", "problem"):
        lines += [f"[{table}]", *(f"{k} = {_value(v)}" for k, v in data[table].items()), ""]
    for ob in data["obstacles"]:
        lines += ["[[obstacles]]", *(f"{k} = {_value(v)}" for k, v in ob.items()), ""]
    return "\n".join(lines)


def _value(v: object) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return repr(v)


def write_scenarios(count: int, seed: int, folder: Path) -> list[tuple[int, Path, dict]]:
    """Scenarios 0 .. count - 1 of ``seed`` written to ``folder``; (index, path, data) each."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for index in range(count):
        data = generate(seed, index)
        path = folder / f"{data['name']}.toml"
        path.write_text(to_toml(data))
        out.append((index, path, data))
    return out


# -- one solve and its classification -------------------------------------------------------------
def solve(index: int, path: Path, data: dict, out: Path, timeout: float) -> dict:
    """Run ``roundabout solve`` on one file in a subprocess; classify and re-check its outputs.

    Parameters
    ----------
    index : int
        The scenario's index (for the report).
    path : Path
        The scenario file.
    data : dict
        Its document, as ``generate`` made it.
    out : Path
        The ``--out`` folder.
    timeout : float
        Seconds before the process is killed (and counted as crashed).

    Returns
    -------
    dict
        Exit code, seconds, the summary's status, validity, objective and diagnosis, the
        ``category`` (solved, refused, crashed, silent), its ``reason`` and the ``recheck``.
    """
    rec = {"index": index, "name": data["name"], "file": str(path), "objective_name": data["problem"]["objective"],
           "obstacles": len(data["obstacles"])}  # fmt: skip
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out)],
                              capture_output=True, text=True, timeout=timeout, cwd=ROOT)  # fmt: skip
        rec.update(returncode=proc.returncode, stderr_tail=proc.stderr[-2000:])
    except subprocess.TimeoutExpired:
        rec.update(returncode=None, stderr_tail=f"timeout after {timeout:g} s")
    rec["seconds"] = time.perf_counter() - t0
    summary = _read_json(out / "summary.json")
    if summary is not None:
        rec.update(status=summary.get("status"), valid=summary.get("valid"), objective=summary.get("objective"),
                   final_time=summary.get("final_time"), has_diagnosis="diagnosis" in summary,
                   diagnosis=summary.get("diagnosis"), attempts=summary.get("attempts"))  # fmt: skip
        rec["reported_drift"] = (summary.get("reintegration") or {}).get("final_position_error")
    rec.update(classify(rec, summary is not None))
    if rec["category"] == "solved" or (rec["category"] == "silent" and (out / "trajectory.csv").exists()):
        rec["recheck"] = recheck(data, out / "trajectory.csv", summary)
        if rec["category"] == "solved" and not rec["recheck"]["passed"]:
            rec.update(category="silent", reason="re-check failed: " + ", ".join(rec["recheck"]["failed"]))
            rec["drift_only"] = rec["recheck"]["failed"] == ["reintegrated goal"]
    return rec


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def classify(rec: dict, has_summary: bool) -> dict:
    """Category and reason from the exit code, stderr and summary.json (before the re-check).

    Parameters
    ----------
    rec : dict
        ``returncode`` (None: timeout), ``stderr_tail`` and, with a summary, ``status`` and ``valid``.
    has_summary : bool
        Whether summary.json was written and parses.

    Returns
    -------
    dict
        ``category`` and ``reason``.
    """
    code = rec["returncode"]
    if code is None:
        return {"category": "crashed", "reason": rec["stderr_tail"]}
    if "Traceback (most recent call last)" in rec["stderr_tail"]:
        return {"category": "crashed", "reason": f"exit {code}, traceback: " + rec["stderr_tail"].strip()[-300:]}
    if code not in (0, 1):
        return {"category": "crashed", "reason": f"exit {code}: " + rec["stderr_tail"].strip()[-300:]}
    if not has_summary:
        return {"category": "crashed", "reason": f"exit {code} without summary.json"}
    if code == 0:
        ok = rec["valid"] is True
        return {"category": "solved" if ok else "silent", "reason": "" if ok else "exit 0 but summary valid false"}
    if rec["status"] != "optimal" or rec["valid"] is not True:
        return {"category": "refused", "reason": f"status {rec['status']}, valid {rec['valid']}"}
    return {"category": "crashed", "reason": "exit 1 with an optimal, valid summary"}


# -- the independent re-check ---------------------------------------------------------------------
def read_trajectory(path: Path) -> dict[str, np.ndarray]:
    """The columns of trajectory.csv as float arrays."""
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def truck_rhs(d: float) -> Callable[[np.ndarray, float, float], np.ndarray]:
    """x' = u1 cos th, y' = u1 sin th, th' = u1 tan(phi) / d, phi' = u2, for controls (u1, u2)."""
    return lambda s, u1, u2: np.array([u1 * math.cos(s[2]), u1 * math.sin(s[2]), u1 * math.tan(s[3]) / d, u2])


def reintegrate(traj: dict[str, np.ndarray], initial: dict, d: float) -> np.ndarray:
    """Integrate the truck under the file's controls (linear between nodes) from the initial state.

    Parameters
    ----------
    traj : dict of numpy.ndarray
        Columns t, u1, u2 of trajectory.csv.
    initial : dict
        x, y, theta, phi at t = 0.
    d : float
        Wheelbase, m.

    Returns
    -------
    numpy.ndarray
        (4, N + 1): x, y, theta, phi at the nodes, integrated interval by interval with DOP853
        (rtol 1e-10), the state carried across nodes; NaN after a failed interval.
    """
    from scipy.integrate import solve_ivp

    f, t, u1, u2 = truck_rhs(d), traj["t"], traj["u1"], traj["u2"]
    out = np.empty((4, len(t)))
    out[:, 0] = [initial[k] for k in ("x", "y", "theta", "phi")]
    for k in range(len(t) - 1):
        t0, h = t[k], t[k + 1] - t[k]

        def rhs(tt, s, k=k, t0=t0, h=h):
            w = (tt - t0) / h
            return f(s, u1[k] + w * (u1[k + 1] - u1[k]), u2[k] + w * (u2[k + 1] - u2[k]))

        sol = solve_ivp(rhs, (t0, t[k + 1]), out[:, k], method="DOP853", rtol=1e-10, atol=1e-12)
        out[:, k + 1] = sol.y[:, -1] if sol.success else np.nan
    return out


def recheck(data: dict, path: Path, summary: dict | None) -> dict:
    """The independent check of a solved scenario's trajectory.csv.

    Parameters
    ----------
    data : dict
        The scenario document.
    path : Path
        Its trajectory.csv.
    summary : dict or None
        Its summary.json (for the reported objective).

    Returns
    -------
    dict
        ``passed``, ``failed`` (names of the failed checks) and the measures: ``goal_error`` (max
        over the goal's values of |re-integrated - goal| / its tolerance x 1e-3, <= 1e-3), ``node_goal_error`` (last
        node, <= 1e-3), ``min_node_clearance`` (dist - radius - safety over nodes and obstacles,
        >= -1e-6), ``objective_mismatch`` (relative, recomputed vs reported, <= 1e-6).
    """
    if not path.exists():
        return {"passed": False, "failed": ["no trajectory.csv"]}
    traj = read_trajectory(path)
    states = reintegrate(traj, data["initial"], data["vehicle"]["wheelbase"])
    names = ("x", "y", "theta", "phi")
    goal = data["final"]
    distance = math.hypot(*(goal.get(k, math.nan) - data["initial"][k] for k in ("x", "y")))
    scale = max(1.0, distance) if math.isfinite(distance) else 1.0
    tolerance = {k: GOAL_TOL * (scale if k in ("x", "y") else 1.0) for k in goal}
    goal_error = max(abs(states[names.index(k), -1] - v) / tolerance[k] * GOAL_TOL for k, v in goal.items())
    node_goal_error = max(abs(traj[k][-1] - v) for k, v in goal.items())
    clearance = min((float(np.min(np.hypot(traj["x"] - ob["center"][0], traj["y"] - ob["center"][1])))
                     - ob["radius"] - ob["safety"] for ob in data["obstacles"]), default=math.inf)  # fmt: skip
    own = recomputed_objective(data, traj)
    reported = (summary or {}).get("objective")
    mismatch = abs(own - reported) / max(abs(own), 1e-12) if reported is not None else math.inf
    checks = {"reintegrated goal": goal_error <= GOAL_TOL, "node goal": node_goal_error <= GOAL_TOL,
              "node clearance": clearance >= -CLEARANCE_TOL, "objective": mismatch <= OBJECTIVE_RTOL}  # fmt: skip
    return {"passed": all(checks.values()), "failed": [k for k, ok in checks.items() if not ok],
            "goal_error": float(goal_error), "node_goal_error": float(node_goal_error),
            "min_node_clearance": clearance, "objective_mismatch": mismatch}  # fmt: skip


def recomputed_objective(data: dict, traj: dict[str, np.ndarray]) -> float:
    """Energy by the trapezoid rule on the nodes (uniform grid), or the final time."""
    t = traj["t"]
    if data["problem"]["objective"] == "time":
        return float(t[-1])
    L = (traj["u1"] ** 2 + traj["u2"] ** 2) / 2
    return float(np.sum((L[:-1] + L[1:]) / 2 * np.diff(t)))


# -- the Reeds-Shepp bound --------------------------------------------------------------------------
def rs_bound(data: dict) -> float:
    """Least feasible Tf ignoring obstacles and the steering rate: RS length / u1max."""
    from model.search.paths import reeds_shepp_time

    d, phimax = data["vehicle"]["wheelbase"], data["bounds"]["phi"][1]
    ini, fin = data["initial"], data["final"]
    start, goal = (ini["x"], ini["y"], ini["theta"]), (fin["x"], fin["y"], fin["theta"])
    return reeds_shepp_time(start, goal, d / math.tan(phimax), data["bounds"]["u1"][1])


def rs_check(rec: dict, data: dict) -> None:
    """Time problems: Tf >= the bound; energy: is the given Tf below it (infeasible)?"""
    bound = rs_bound(data)
    rec["rs_time"] = bound
    if data["problem"]["objective"] == "energy":
        rec["tf"] = data["problem"]["final_time"]
        rec["rs_infeasible"] = rec["tf"] < bound
    elif answered(rec):
        rec["rs_ratio"] = rec["final_time"] / bound
        rec["rs_violated"] = rec["final_time"] < bound * (1 - 1e-9)


# -- the peer -----------------------------------------------------------------------------------------
def answered(rec: dict) -> bool:
    """Solved, or silent only by the re-integrated goal (the trapezoid rule's own error): a valid answer."""
    return rec["category"] == "solved" or bool(rec.get("drift_only"))


def pick_subset(records: list[dict], size: int) -> list[dict]:
    """The scenarios compared with the peer.

    Parameters
    ----------
    records : list of dict
        Every scenario's record.
    size : int
        How many to pick.

    Returns
    -------
    list of dict
        Refused scenarios (the first ones, up to half of ``size``, more if too few were answered),
        then answered ones spread evenly over the indices; in index order.
    """
    refused = [r for r in records if r["category"] == "refused"]
    solved = [r for r in records if answered(r)]
    take = refused[: max(size // 2, size - len(solved))]
    rest = size - len(take)
    if rest > 0 and solved:
        at = np.unique(np.linspace(0, len(solved) - 1, min(rest, len(solved))).round().astype(int))
        take += [solved[i] for i in at]
    return sorted(take, key=lambda r: r["index"])


def run_peer(rec: dict, timeout: float) -> dict:
    """The peer's JSON line for one scenario (or why there is none)."""
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, str(PEER), rec["file"]], capture_output=True, text=True,
                              timeout=timeout, cwd=ROOT)  # fmt: skip
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:g} s", "seconds": time.perf_counter() - t0}
    lines = proc.stdout.strip().splitlines()
    try:
        return json.loads(lines[-1])
    except (IndexError, ValueError):
        return {"error": f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}", "seconds": time.perf_counter() - t0}


def compare(rec: dict, peer: dict) -> dict:
    """One row of the peer comparison.

    Parameters
    ----------
    rec : dict
        The project's record (``solve``).
    peer : dict
        The peer's JSON line (``multistart_peer.py``), or ``{"error": ...}``.

    Returns
    -------
    dict
        Project objective (None unless ``answered``), peer best, ``gap`` = (project - peer) /
        |peer|, the peer's minimum time (energy), and ``flag``: "project infeasible, peer
        solved", "within 0.1 % or better", "worse by > 0.1 %", "both infeasible" or "peer found
        nothing".
    """
    best = peer.get("best")
    mine = rec["objective"] if answered(rec) else None
    theirs = best["objective"] if best else None
    row = {"index": rec["index"], "name": rec["name"], "objective_name": rec["objective_name"],
           "category": rec["category"], "project": mine, "peer": theirs, "peer_start": best["label"] if best else None,
           "peer_seconds": peer.get("seconds"), "peer_feasible_starts": peer.get("feasible_starts"),
           "peer_error": peer.get("error"), "gap": None, "tf": rec.get("tf"),
           "peer_min_time": (peer.get("min_time") or {}).get("objective"), "rs_time": rec.get("rs_time"),
           "peer_starts": [{k: s.get(k) for k in ("label", "objective", "feasible", "status")}
                           for s in peer.get("starts", [])]}  # fmt: skip
    if mine is None:
        row["flag"] = "project infeasible, peer solved" if theirs is not None else "both infeasible"
    elif theirs is None:
        row["flag"] = "peer found nothing"
    else:
        on_n = objective_on_grid(rec)  # the peer solves on N: compare on N where the answer was refined on 2N
        row["on_n"] = on_n if on_n is not None and on_n != mine else None
        row["gap"] = ((on_n if on_n is not None else mine) - theirs) / abs(theirs)
        row["flag"] = "within 0.1 % or better" if row["gap"] <= GAP_TOL else "worse by > 0.1 %"
    if rec["objective_name"] == "time" and theirs is not None:
        row["peer_below_rs"] = theirs < rec["rs_time"] * (1 - 1e-9)
    return row


def objective_on_grid(rec: dict) -> float | None:
    """The least objective of a validated start on the scenario's own N (not a re-solve on 2N for accuracy)."""
    values = [a["objective"] for a in rec.get("attempts") or []
              if a.get("valid") is True and "for accuracy" not in str(a.get("route", ""))]  # fmt: skip
    return min(values) if values else None


# -- the report --------------------------------------------------------------------------------------
def markdown_counts(records: list[dict]) -> str:
    count = Counter(r["category"] for r in records)
    diag = sum(1 for r in records if r["category"] == "refused" and r.get("has_diagnosis"))
    lines = ["| outcome | scenarios |", "|---|---|"]
    lines += [f"| {c} | {count.get(c, 0)} |" for c in CATEGORIES]
    drift = sum(1 for r in records if r.get("drift_only"))
    lines += [
        f"| refused with a `diagnosis` | {diag} |",
        f"| silent only by the re-integrated goal (> {GOAL_TOL:g}) | {drift} |",
        f"| total | {len(records)} |",
    ]
    return "\n".join(lines)


def markdown_by_kind(records: list[dict]) -> str:
    """Counts per objective and obstacle count."""
    lines = ["| objective | obstacles | " + " | ".join(CATEGORIES) + " |", "|---|---|" + "---|" * len(CATEGORIES)]
    for kind in ("energy", "time"):
        for k in (0, 1, 2):
            rows = [r for r in records if r["objective_name"] == kind and r["obstacles"] == k]
            c = Counter(r["category"] for r in rows)
            lines.append(f"| {kind} | {k} | " + " | ".join(str(c.get(x, 0)) for x in CATEGORIES) + " |")
    return "\n".join(lines)


def markdown_times(records: list[dict]) -> str:
    lines = ["| outcome | n | median s | max s |", "|---|---|---|---|"]
    for label, rows in [("all", records), *[(c, [r for r in records if r["category"] == c]) for c in CATEGORIES]]:
        secs = [r["seconds"] for r in rows]
        if secs:
            lines.append(f"| {label} | {len(secs)} | {statistics.median(secs):.2f} | {max(secs):.2f} |")
    return "\n".join(lines)


GAP_BINS = (("better by > 0.1 %", -math.inf, -GAP_TOL), ("within +-0.1 %", -GAP_TOL, GAP_TOL),
            ("worse 0.1-1 %", GAP_TOL, 1e-2), ("worse 1-10 %", 1e-2, 0.1), ("worse > 10 %", 0.1, math.inf))  # fmt: skip


def markdown_peer(rows: list[dict]) -> str:
    lines = [
        "| # | name | objective | project (on N where refined on 2N) | peer | gap (on N) | peer start | peer s "
        "| Tf / peer min time | flag |",
        "|---" * 10 + "|",
    ]
    for r in rows:
        fmt = lambda v: "-" if v is None else f"{v:.6g}"  # noqa: E731
        gap = "-" if r["gap"] is None else f"{100 * r['gap']:+.3f} %"
        mine = fmt(r["project"]) + ("" if r.get("on_n") is None else f" (on N: {fmt(r['on_n'])})")
        lines.append(f"| {r['index']} | {r['name']} | {r['objective_name']} | {mine} | "
                     f"{fmt(r['peer'])} | {gap} | {r['peer_start'] or one_line(r['peer_error'] or '-')} | "
                     f"{fmt(r['peer_seconds'])} | {_tf_vs_min(r)} | {r['flag']} |")  # fmt: skip
    flags = Counter(r["flag"] for r in rows)
    lines += ["", "| flag | scenarios |", "|---|---|", *[f"| {k} | {v} |" for k, v in sorted(flags.items())]]
    gaps = [r["gap"] for r in rows if r["gap"] is not None]
    lines += ["", "| gap (project - peer) / peer | scenarios |", "|---|---|"]
    lines += [f"| {label} | {sum(lo <= g < hi for g in gaps)} |" for label, lo, hi in GAP_BINS]
    return "\n".join(lines)


def _tf_vs_min(row: dict) -> str:
    """Energy: the requested Tf beside the least time the peer reached (Tf below it: infeasible, likely)."""
    if row["tf"] is None or row["peer_min_time"] is None:
        return "-"
    return f"{row['tf']:.4g} / {row['peer_min_time']:.4g}"


def markdown_failures(records: list[dict]) -> str:
    lines = []
    for cat in ("crashed", "silent"):
        for r in (r for r in records if r["category"] == cat):
            extra = r.get("recheck", {})
            lines.append(f"- {cat}: #{r['index']} {r['name']} (exit {r['returncode']}, {r['seconds']:.1f} s): "
                         f"{one_line(r['reason'])}" + (f"; re-check {_short(extra)}" if extra else ""))  # fmt: skip
    return "\n".join(lines) or "none"


def one_line(text: str, limit: int = 300) -> str:
    """The last ``limit`` characters of ``text`` on one line, safe in a Markdown table."""
    return " ".join(text.split())[-limit:].replace("|", "/")


def _short(check: dict) -> str:
    keys = ("goal_error", "node_goal_error", "min_node_clearance", "objective_mismatch")
    return ", ".join(f"{k} {check[k]:.3g}" for k in keys if k in check)


def markdown_cases(rows: list[dict], records: list[dict]) -> str:
    """The scenarios the project refused but the peer solved, and those it solved worse by > 0.1 %."""
    by_index = {r["index"]: r for r in records}
    lines = []
    for r in rows:
        rec = by_index[r["index"]]
        if r["flag"] == "project infeasible, peer solved":
            why = (rec.get("diagnosis") or {}).get("message") or rec["reason"]
            lines.append(f"- refused, peer solved: #{r['index']} {r['name']} ({r['objective_name']}, "
                         f"{rec['obstacles']} obstacles): peer {r['peer']:.6g} from '{r['peer_start']}'; "
                         f"project: {one_line(why)}")  # fmt: skip
        elif r["flag"] == "worse by > 0.1 %":
            lines.append(f"- worse: #{r['index']} {r['name']} ({r['objective_name']}, {rec['obstacles']} obstacles): "
                         f"project {r['project']:.6g}, peer {r['peer']:.6g} ({100 * r['gap']:+.2f} %) "
                         f"from '{r['peer_start']}'" + _on_n(r))  # fmt: skip
    return "\n".join(lines) or "none"


def _on_n(row: dict) -> str:
    """Where the answer was refined on 2N for accuracy, the objective on N that was compared."""
    if row.get("on_n") is None:
        return ""
    return f" (compared on N: {row['on_n']:.6g}; the answer, refined on 2N for accuracy: {row['project']:.6g})"


def markdown_rs(records: list[dict], peers: list[dict]) -> str:
    time_rows = [r for r in records if "rs_ratio" in r]
    free = [r for r in time_rows if r["obstacles"] == 0]
    energy = [r for r in records if "rs_infeasible" in r]
    lines = [f"- time problems solved: {len(time_rows)} ({len(free)} obstacle-free); "
             f"Tf below the Reeds-Shepp bound: {sum(r['rs_violated'] for r in time_rows)}"]  # fmt: skip
    if time_rows:
        ratios = [r["rs_ratio"] for r in time_rows]
        lines.append(f"- Tf / RS bound: min {min(ratios):.3f}, median {statistics.median(ratios):.3f}")
    infeasible = [r for r in energy if r["rs_infeasible"]]
    peer_below = [r for r in peers if r.get("peer_below_rs")]
    lines.append(f"- peer time optima below the RS bound: {len(peer_below)}")
    lines.append(f"- energy problems with Tf below the RS bound (provably infeasible): {len(infeasible)}, of which "
                 f"refused {sum(r['category'] == 'refused' for r in infeasible)}; solved anyway (impossible): "
                 f"{sum(r['category'] == 'solved' for r in infeasible)}")  # fmt: skip
    return "\n".join(lines)


# -- main -------------------------------------------------------------------------------------------
def tree_state() -> dict:
    """HEAD and the uncommitted changes of the solve code (read-only git): what a run measured."""

    def git(*args: str) -> str:
        cmd = ["git", "--no-optional-locks", *args]
        return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT).stdout.strip()

    return {"head": git("rev-parse", "HEAD"), "changes": git("status", "--porcelain", "--", "model").splitlines()}


def reused_peers(records: list[dict], args: argparse.Namespace) -> list[dict]:
    """The comparison rows against an earlier run's peer results (same scenarios: checked by name)."""
    old = json.loads(args.peers.read_text())
    if (old["count"], old["seed"]) != (args.count, args.seed):
        raise SystemExit(f"--peers {args.peers}: made with count {old['count']}, seed {old['seed']}")
    by_index = {row["index"]: row for row in old["peer"]}
    rows = []
    for rec in records:
        row = by_index.get(rec["index"])
        if row is None:
            continue
        if row["name"] != rec["name"]:
            raise SystemExit(f"--peers {args.peers}: scenario {rec['index']} is {row['name']}, not {rec['name']}")
        best = {"objective": row["peer"], "label": row["peer_start"]} if row["peer"] is not None else None
        peer = {"best": best, "seconds": row["peer_seconds"], "feasible_starts": row["peer_feasible_starts"],
                "error": row["peer_error"], "min_time": {"objective": row["peer_min_time"]},
                "starts": row["peer_starts"]}  # fmt: skip
        rows.append(compare(rec, peer))
    return rows


def run_all(items: list[tuple[int, Path, dict]], outdir: Path, jobs: int, timeout: float) -> list[dict]:
    """``solve`` and ``rs_check`` every scenario, ``jobs`` at a time; one progress line each on stderr."""

    def one(item: tuple[int, Path, dict]) -> dict:
        index, path, data = item
        rec = solve(index, path, data, outdir / data["name"], timeout)
        rs_check(rec, data)
        print(f"  #{index:03d} {data['name']}: {rec['category']} ({rec['seconds']:.1f} s) {rec['reason']}"[:200],
              file=sys.stderr, flush=True)  # fmt: skip
        return rec

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(one, items))


def run_peers(records: list[dict], size: int, jobs: int, timeout: float) -> list[dict]:
    """The peer on ``pick_subset(records, size)``, ``jobs`` at a time; one ``compare`` row each."""

    def one(rec: dict) -> dict:
        row = compare(rec, run_peer(rec, timeout))
        print(f"  peer #{rec['index']:03d}: {row['flag']}", file=sys.stderr, flush=True)
        return row

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(one, pick_subset(records, size)))


def solve_or_reuse(args: argparse.Namespace, base: Path) -> tuple[list[dict], float, dict]:
    """Records, solve wall seconds and tree state: of a new run under ``base``, or of ``args.records``."""
    if args.records:
        earlier = json.loads(args.records.read_text())
        args.count, args.seed = earlier["count"], earlier["seed"]
        return earlier["records"], earlier["solve_wall_seconds"], earlier.get("tree") or tree_state()
    tree, t0 = tree_state(), time.perf_counter()
    items = write_scenarios(args.count, args.seed, base / "scenarios")
    records = run_all(items, base / "out", args.jobs, args.timeout)
    return records, time.perf_counter() - t0, tree


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=200, help="scenarios 0 .. count - 1 (default 200)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1, help="solves (and peers) at a time")
    ap.add_argument("--subset", type=int, default=20, help="scenarios compared with the peer (0: none)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per roundabout solve")
    ap.add_argument("--peer-timeout", type=float, default=900.0, help="seconds per peer multi-start")
    ap.add_argument("--json", type=Path, help="write every record here")
    ap.add_argument("--keep", type=Path, help="keep scenario files and outputs in this folder (default: a temp one)")
    ap.add_argument("--records", type=Path, help="reuse the solve records of an earlier --json run made with --keep "
                    "(its scenario files must still exist): only the peer runs")  # fmt: skip
    ap.add_argument("--peers", type=Path, help="reuse the peer results of an earlier --json run of the same count "
                    "and seed (the peer does not run the project's code): only the project solves")  # fmt: skip
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="robustness-") as tmp:
        records, solve_wall, tree = solve_or_reuse(args, args.keep or Path(tmp))
        t0 = time.perf_counter()
        if args.peers:
            peers, peer_wall = reused_peers(records, args), json.loads(args.peers.read_text())["peer_wall_seconds"]
        else:
            peers = run_peers(records, args.subset, args.jobs, args.peer_timeout) if args.subset > 0 else []
            peer_wall = time.perf_counter() - t0
    report = "\n\n".join([
        f"## Robustness: {args.count} scenarios, seed {args.seed}, {args.jobs} job(s); "
        f"solves {solve_wall:.0f} s, peer {peer_wall:.0f} s wall"
        + (f" (the peer's results reused from {args.peers.name}: same code and scenarios)" if args.peers else "")
        + f"; HEAD {tree['head'][:7]}"
        + (f" + uncommitted {', '.join(c.split()[-1] for c in tree['changes'])}" if tree["changes"] else ""),
        markdown_counts(records), markdown_by_kind(records), markdown_times(records),
        "### Crashes and silent failures\n\n" + markdown_failures(records),
        "### Reeds-Shepp bound\n\n" + markdown_rs(records, peers),
        "### Peer comparison\n\n" + (markdown_peer(peers) if peers else "not run"),
        "### Refused but the peer solved; worse than the peer\n\n" + markdown_cases(peers, records),
    ])  # fmt: skip
    print(report)
    if args.json:
        args.json.write_text(json.dumps({"count": args.count, "seed": args.seed, "jobs": args.jobs, "tree": tree,
                                         "solve_wall_seconds": solve_wall, "peer_wall_seconds": peer_wall,
                                         "records": records, "peer": peers}, indent=1, default=str))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
