"""Road suite: every exit of 3-, 4- and 5-leg roundabouts, rigid truck and semitrailer, both traffic sides (issue 11).

Twelve routes, built here as scenario documents (nothing is read from or written to workflows/):
an SU-30 through every exit of a three-leg (T) roundabout under right-hand traffic, an EU 16.5 m
semitrailer through every exit of a four-leg one under left-hand traffic, and every exit of a
five-leg one with legs at non-uniform angles (0, 70, 145, 215, 290 degrees), odd exits the SU-30
under left-hand traffic, even exits the semitrailer under right-hand traffic. Exit k of k legs is
the U-turn. Each route is solved by the project's default solve ``ocp.solve(intervals=N)`` (starts,
screening, accuracy refinement, exact validation, minimal-violation diagnosis) with the default
body formulation, with "discs" (the conservative reference) and with "corners". Reported per
route and formulation: the exit taken, status, exact validation, objective, node and dense
clearance of the exact rectangles, the diagnosis of a refusal, seconds; then the counts and the
comparisons against "discs". An exception is recorded, never fatal. Writes
``benchmarks/road-suite.md`` (after every solve, so a partial run leaves a partial report).

Run: ``python -m benchmarks.bench_road_suite [--only NAME ...] [--jobs 1] [--intervals 60] [--out PATH]``.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from benchmarks.bench_formulations import Case, machine, timed_solve
from model.direct import bodies

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "road-suite.md"
RIGID, SEMI = "SU-30", "EU-semitrailer"
LAYOUTS = {3: (180.0, 270.0, 0.0), 4: (180.0, 270.0, 0.0, 90.0), 5: (0.0, 70.0, 145.0, 215.0, 290.0)}  # degrees
ICD, RING, APRON, LANE = 44.0, 6.0, 2.0, 4.0  # m
ENTRY_RADIUS, EXIT_RADIUS, DISTANCE = 15.0, 20.0, 30.0  # m
REFERENCE = "discs"  # the simple conservative formulation every other one is compared with
RELATIVE = 1e-6  # an objective above the reference's by more than this fraction is worse
SHORT = {RIGID: "su30", SEMI: "semi"}


def routes() -> list[tuple[str, int, str, int]]:
    """(preset, legs, traffic, exit) of the twelve routes."""
    out = [(RIGID, 3, "right", e) for e in range(1, 4)]
    out += [(SEMI, 4, "left", e) for e in range(1, 5)]
    out += [(RIGID, 5, "left", e) if e % 2 else (SEMI, 5, "right", e) for e in range(1, 6)]
    return out


def road_document(preset: str, legs: int, traffic: str, exit_: int, intervals: int) -> dict:
    """The scenario document of one route: entry from leg 0, ``exit_``-th exit, minimum time."""
    articulated = preset == SEMI
    bounds = {"u1": [-10.0, 10.0], "u2": [-0.5, 0.5]} | ({"articulation": [-1.2, 1.2]} if articulated else {})
    leg = {"lane_width": LANE, "entry_radius": ENTRY_RADIUS, "exit_radius": EXIT_RADIUS}
    return {
        "name": f"{SHORT[preset]}-{legs}legs-{traffic}-exit{exit_}",
        "vehicle": {"preset": preset},  # the preset's steering limit
        "bounds": bounds,
        "roundabout": {
            "center": [0.0, 0.0],
            "inscribed_diameter": ICD,
            "circulatory_width": RING,
            "apron_width": APRON,
            "apron_use": "trailer" if articulated else "all",
            "traffic": traffic,
            "legs": [{"angle": a} | leg for a in LAYOUTS[legs]],
        },
        "route": {"enter": 0, "exit": exit_, "start_distance": DISTANCE, "goal_distance": DISTANCE},
        "problem": {"objective": "time", "intervals": intervals},
    }


def all_cases(intervals: int) -> list[Case]:
    """Every route of the suite as a benchmark case."""
    out = []
    for preset, legs, traffic, exit_ in routes():
        doc = road_document(preset, legs, traffic, exit_, intervals)
        source = f"{preset}, {legs} legs at {'/'.join(f'{a:g}' for a in LAYOUTS[legs])} deg, {traffic}, exit {exit_}"
        out.append(Case(doc["name"], source, doc, intervals))
    return out


def formulations() -> tuple[str, ...]:
    """The default formulation, the reference "discs" and "corners", once each."""
    return tuple(dict.fromkeys((bodies.DEFAULT_FORMULATION, REFERENCE, "corners")))


def solve_cell(case: Case, formulation: str) -> dict:
    """One default solve: what the table reports; an exception becomes ``error``, never propagates."""
    t0 = time.perf_counter()
    try:
        sol, seconds = timed_solve(case, formulation)
        summary = sol.summary()
    except Exception as exc:  # a crash is a result of the suite
        return {"status": "crashed", "valid": False, "error": f"{type(exc).__name__}: {exc}",
                "seconds": time.perf_counter() - t0}  # fmt: skip
    diagnosis = summary.get("diagnosis") or {}
    return {
        "status": summary["status"],
        "valid": bool(sol.ok),
        "objective": summary["objective"],
        "exit_taken": summary.get("exit_taken"),
        "clearance": summary["min_clearance"],
        "dense": summary["min_clearance_dense"],
        "solved_n": sol.intervals,
        "diagnosis_kind": diagnosis.get("kind"),
        "diagnosis": diagnosis.get("message"),
        "seconds": seconds,
    }


def cells(cases: list[Case], forms: tuple[str, ...], jobs: int) -> Iterator[tuple[Case, str, dict]]:
    """Every case x formulation, in order (``jobs`` = 1) or as ``jobs`` worker processes finish."""
    pairs = [(c, f) for c in cases for f in forms]
    if jobs <= 1:
        for case, form in pairs:
            yield case, form, solve_cell(case, form)
        return
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = {pool.submit(solve_cell, c, f): (c, f) for c, f in pairs}
        for fut in as_completed(futures):
            case, form = futures[fut]
            try:
                result = fut.result()
            except Exception as exc:  # a dead worker process
                result = {"status": "crashed", "valid": False, "error": f"{type(exc).__name__}: {exc}", "seconds": 0.0}
            yield case, form, result


def _fmt(value, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{value:.{digits}g}"


def _cell_text(text: str | None) -> str:
    return "-" if not text else text.replace("|", "/").replace("\n", " ")


def _versus(r: dict, ref: dict | None) -> str:
    """The objective's relative difference to the reference's, both valid."""
    if ref is None or not (r["valid"] and ref["valid"]):
        return "-"
    return f"{(r['objective'] - ref['objective']) / abs(ref['objective']):+.2e}"


def table(cases: list[Case], forms: tuple[str, ...], results: dict) -> list[str]:
    """The markdown table: one row per route and formulation solved so far."""
    lines = [
        "| route | vehicle | legs | traffic | exit | formulation | exit_taken | status | valid | objective (s) | "
        f"vs {REFERENCE} | node clearance (m) | dense clearance (m) | N (answer's) | diagnosis | seconds |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for case in cases:
        rb, route = case.doc["roundabout"], case.doc["route"]
        for form in forms:
            r = results.get((case.name, form))
            if r is None:
                continue
            lines.append(
                f"| {case.name} | {case.doc['vehicle']['preset']} | {len(rb['legs'])} | {rb['traffic']} | "
                f"{route['exit']} | {form} | {_fmt(r.get('exit_taken'))} | {r['status']} | "
                f"{'yes' if r['valid'] else 'no'} | {_fmt(r.get('objective'), 7)} | "
                f"{_versus(r, results.get((case.name, REFERENCE)))} | {_fmt(r.get('clearance'), 3)} | "
                f"{_fmt(r.get('dense'), 3)} | {case.intervals} ({_fmt(r.get('solved_n'))}) | "
                f"{_cell_text(r.get('error') or (None if r['valid'] else r.get('diagnosis')))} | {r['seconds']:.1f} |"
            )
    return lines


def counts(results: dict) -> dict[str, list[str]]:
    """Cells (``route/formulation``) solved and validated, refused with and without a diagnosis, crashed."""
    out: dict[str, list[str]] = {"solved and validated": [], "refused with a diagnosis": [],
                                 "refused without a diagnosis": [], "crashed": []}  # fmt: skip
    for (name, form), r in results.items():
        if "error" in r:
            key = "crashed"
        elif r["valid"]:
            key = "solved and validated"
        else:
            key = "refused with a diagnosis" if r.get("diagnosis") else "refused without a diagnosis"
        out[key].append(f"{name}/{form}")
    return out


def comparisons(cases: list[Case], forms: tuple[str, ...], results: dict) -> list[str]:
    """Each formulation against the reference: refused where the reference solves; a worse objective."""
    lines = []
    for form in forms:
        if form == REFERENCE:
            continue
        label = f"`{form}`" + (" (the default)" if form == bodies.DEFAULT_FORMULATION else "")
        pairs = [(c.name, results[c.name, form], results[c.name, REFERENCE]) for c in cases
                 if (c.name, form) in results and (c.name, REFERENCE) in results]  # fmt: skip
        refused = [n for n, r, ref in pairs if ref["valid"] and not r["valid"]]
        worse = [n for n, r, ref in pairs if r["valid"] and ref["valid"]
                 and r["objective"] - ref["objective"] > RELATIVE * abs(ref["objective"])]  # fmt: skip
        better = [n for n, r, ref in pairs if r["valid"] and not ref["valid"]]
        lines += [
            f"- {label} refused where `{REFERENCE}` solves: {len(refused)}" + _names(refused),
            f"- {label} objective worse than `{REFERENCE}`'s by more than {RELATIVE:g} relative: {len(worse)}"
            + _names(worse),
            f"- {label} solves where `{REFERENCE}` is refused: {len(better)}" + _names(better),
        ]
    if bodies.DEFAULT_FORMULATION == REFERENCE:
        lines.append(f"- The default formulation is `{REFERENCE}` itself: its comparisons with `{REFERENCE}` are "
                     "0 by construction (one solve serves both columns).")  # fmt: skip
    return lines


def _names(names: list[str]) -> str:
    return f" ({', '.join(names)})" if names else ""


def exit_mismatches(cases: list[Case], results: dict) -> list[str]:
    """Cells whose trajectory leaves by another exit than the route's (or by none)."""
    want = {c.name: c.doc["route"]["exit"] for c in cases}
    return [f"{n}/{f} ({_fmt(r.get('exit_taken'))})" for (n, f), r in results.items()
            if "error" not in r and r.get("exit_taken") != want[n]]  # fmt: skip


def model_version() -> str:
    """The commit the model code comes from, and the files of model/ changed in the working tree."""
    git = ["git", "-C", str(ROOT)]
    head = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False)
    dirty = subprocess.run([*git, "status", "--porcelain", "--", "model"], capture_output=True, text=True, check=False)
    changed = [line[3:] for line in dirty.stdout.splitlines()]
    return f"commit {head.stdout.strip() or '?'}" + (
        f", uncommitted changes in {', '.join(changed)}" if changed else ""
    )


def report(cases: list[Case], forms: tuple[str, ...], results: dict, before: dict, after: dict, wall: float) -> str:
    """The markdown report of the cells solved so far."""
    done = len(results) == len(cases) * len(forms)
    span = f"Whole run: {wall / 60:.1f} min." if done else f"Partial report: {len(results)} cells, {wall / 60:.1f} min."
    lines = [
        "# Road suite: every exit of 3-, 4- and 5-leg roundabouts, rigid truck and semitrailer",
        "",
        "Written by `python -m benchmarks.bench_road_suite` (issue 11). Each cell is the default solve "
        "`parse_scenario(doc).ocp.solve(intervals=N)` (multi-start, screening, goal-accuracy refinement, exact "
        "validation, minimal-violation diagnosis) of one route with one body formulation (`solve(..., "
        f"formulation=...)`). Default formulation: `{bodies.DEFAULT_FORMULATION}`; reference: `{REFERENCE}`.",
        "",
        f"Roundabout: ICD {ICD:g} m, ring {RING:g} m, apron {APRON:g} m (the SU-30 may use it, the semitrailer's "
        f"trailer only), lanes {LANE:g} m, curb fillets {ENTRY_RADIUS:g} / {EXIT_RADIUS:g} m (entry / exit), "
        f"entry from leg 0, start and goal {DISTANCE:g} m beyond the outer curb; minimum time, u1 in [-10, 10] m/s, "
        "u2 in [-0.5, 0.5] rad/s, the preset's steering limit, articulation in [-1.2, 1.2] rad. Leg angles (degrees): "
        + "; ".join(f"{k} legs {', '.join(f'{a:g}' for a in v)}" for k, v in LAYOUTS.items())
        + f". Vehicles: `{RIGID}` (AASHTO single unit), `{SEMI}` (EU 96/53/EC 16.5 m).",
        "",
        f"Machine: {before['nproc']} cores, {before['cpu']}. Load before: `{before['load']}`; after: "
        f"`{after['load']}` (the cores are shared with other runs: seconds are noisy). {span} "
        f"Model code at the start: {before['model']}.",
        "",
    ]
    lines += table(cases, forms, results)
    lines += [
        "",
        "exit_taken: the exit the solved trajectory leaves by (`summary.json`). valid: Ipopt converged and the exact "
        "rectangles lie in the exact corridor at every node (and every other check of the validation passed). "
        f"vs {REFERENCE}: (objective - {REFERENCE}'s) / {REFERENCE}'s, both valid. Node clearance: least signed "
        "distance of the exact rectangles to the corridor edge at the nodes; dense: the same on 4 interpolated "
        "sub-steps per interval (< 0: the worst encroachment between nodes; reported, not judged). N (answer's): "
        "the answer's N differs where the goal-accuracy rule solved again on 2N. Diagnosis: the one-line message "
        "of a refused cell, or the exception of a crashed one.",
        "",
        "## Counts",
        "",
    ]
    for key, names in counts(results).items():
        lines.append(f"- {key}: {len(names)}" + (_names(names) if key != "solved and validated" else ""))
    bad = exit_mismatches(cases, results)
    lines += [f"- exit_taken differs from the route's exit: {len(bad)}" + _names(bad), "", "## Against `discs`", ""]
    lines += comparisons(cases, forms, results)
    return "\n".join(lines) + "\n"


def run(cases: list[Case], jobs: int, log: Callable[[str], None], write: Callable[[dict], None]) -> dict:
    """Every cell; the report is written after each."""
    results: dict = {}
    for case, form, r in cells(cases, formulations(), jobs):
        results[case.name, form] = r
        log(f"[{len(results)}] {case.name} {form}: {r['status']} valid={r['valid']} exit={r.get('exit_taken')} "
            f"obj={_fmt(r.get('objective'), 7)} dense={_fmt(r.get('dense'), 3)} {r['seconds']:.1f} s "
            f"{r.get('error') or r.get('diagnosis') or ''}")  # fmt: skip
        write(results)
    return results


def main(argv: list[str] | None = None) -> None:
    """Run the suite and write its report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", help="route names to run (default: all)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--intervals", type=int, default=60, help="N of every solve (default 60)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    cases = [c for c in all_cases(args.intervals) if not args.only or c.name in args.only]
    forms, before, t0 = formulations(), machine() | {"model": model_version()}, time.perf_counter()

    def write(results: dict) -> None:
        args.out.write_text(report(cases, forms, results, before, machine(), time.perf_counter() - t0))

    run(cases, args.jobs, log=lambda s: print(s, flush=True), write=write)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
