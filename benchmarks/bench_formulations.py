"""Bodies on a road: the NLP formulations compared on road scenarios (issue 11, item 3).

For every scenario (the two of ``workflows/roads``, the two road examples and the ones written
below) and every formulation of ``model.direct.bodies.FORMULATIONS`` the default solve
``ocp.solve(intervals=N)`` runs at the scenario's N, ``--repeats`` times (interleaved; the
seconds are the minimum, the answer the first run's). Reported: status and the exact validation,
the objective, the exact node clearance of the rectangles (how far the body stays from the edge
it is pressed against: what the formulation gives away), the objective's excess over the best
valid formulation, Ipopt's iterations (best start) and the seconds of the whole solve; then the
scenarios one formulation refuses where another solves. Writes ``benchmarks/formulations.md``.

Run: ``python -m benchmarks.bench_formulations [--repeats 2] [--only NAME ...] [--out PATH]``.
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import platform
import subprocess
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

from model.direct.bodies import DEFAULT_FORMULATION, FORMULATIONS
from model.direct.solution import Solution
from model.problem.scenario import parse_scenario

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "formulations.md"
SAME_AS = {"examples/roundabout-truck.toml": "workflows/roads/truck-straight-on.toml"}  # identical problems


@dataclass
class Case:
    """One scenario: its name, where it comes from, its document and N."""

    name: str
    source: str
    doc: dict
    intervals: int


def _load(rel: str) -> dict:
    return tomllib.loads((ROOT / rel).read_text())


def file_cases() -> list[Case]:
    """The road scenarios of the pipeline and the road examples (an identical problem once)."""
    out = []
    for rel in ("workflows/roads/truck-straight-on.toml", "workflows/roads/semitrailer-left-turn.toml",
                "examples/roundabout-truck.toml", "examples/roundabout-semitrailer.toml"):  # fmt: skip
        if rel in SAME_AS:
            continue
        doc = _load(rel)
        out.append(Case(doc["name"], rel, doc, int(doc["problem"].get("intervals", 100))))
    return out


def wb40_left_turn() -> Case:
    """An AASHTO WB-40 semitrailer turns left through a 45 m roundabout with a 2 m apron."""
    from model.studies.roads import cell_document

    doc = cell_document(_load("workflows/roads/semitrailer-left-turn.toml"), "WB-40", 45.0, 2.0, 100)
    return Case("wb40-left-45m", "inline: WB-40, ICD 45 m, apron 2 m, exit 3", doc, 100)


def su30_right_turn_left_traffic() -> Case:
    """An SU-30 turns right (third exit, clockwise circulation) under left-hand traffic."""
    doc = copy.deepcopy(_load("workflows/roads/truck-straight-on.toml"))
    doc["name"] = "su30-right-turn-left-traffic"
    doc["vehicle"] = {"preset": "SU-30"}
    doc["bounds"].pop("phi")
    doc["roundabout"].update(traffic="left", apron_use="all")
    doc["route"]["exit"] = 3
    return Case(doc["name"], "inline: SU-30, left-hand traffic, exit 3 (a right turn)", doc, 100)


def truck_tight_ring() -> Case:
    """The 8 m truck turns right through a 28 m roundabout with a 4.5 m ring, no apron, 3 m lanes."""
    doc = copy.deepcopy(_load("workflows/roads/truck-straight-on.toml"))
    doc["name"] = "truck-tight-ring"
    rb = doc["roundabout"]
    rb.update(inscribed_diameter=28.0, circulatory_width=4.5, apron_width=0.0)
    for leg in rb["legs"]:
        leg.update(lane_width=3.0, entry_radius=8.0, exit_radius=10.0)
    doc["route"]["exit"] = 1
    return Case(doc["name"], "inline: truck 8 x 2.5 m, ICD 28 m, ring 4.5 m, lanes 3.0 m, exit 1", doc, 100)


def truck_narrow_lanes() -> Case:
    """The 8 m x 2.5 m truck straight on with 2.7 m lanes: its 2.75 m cover discs do not fit in them."""
    doc = copy.deepcopy(_load("workflows/roads/truck-straight-on.toml"))
    doc["name"] = "truck-narrow-lanes"
    for leg in doc["roundabout"]["legs"]:
        leg["lane_width"] = 2.7
    return Case(doc["name"], "inline: truck 8 x 2.5 m, lanes 2.7 m, exit 2", doc, 100)


def all_cases() -> list[Case]:
    """Every scenario of the benchmark."""
    inline = [wb40_left_turn(), su30_right_turn_left_traffic(), truck_tight_ring(), truck_narrow_lanes()]
    return file_cases() + inline


def timed_solve(case: Case, formulation: str) -> tuple[Solution, float]:
    """The default solve ``ocp.solve(intervals=N)`` of ``case`` with ``formulation`` and its seconds."""
    ocp = parse_scenario(copy.deepcopy(case.doc)).ocp
    t0 = time.perf_counter()
    sol = ocp.solve(intervals=case.intervals, formulation=formulation)
    return sol, time.perf_counter() - t0


def solve_once(case: Case, formulation: str) -> dict:
    """One default solve of ``case`` with ``formulation``: the measures of the table."""
    sol, seconds = timed_solve(case, formulation)
    measures = sol.validation.get("measures", {})
    return {
        "status": sol.status,
        "valid": bool(sol.ok),
        "objective": sol.objective,
        "clearance": measures.get("min_clearance"),
        "dense": measures.get("min_clearance_dense"),
        "iterations": sol.iterations,
        "solved_n": sol.intervals,
        "seconds": seconds,
        "starts": len(sol.attempts or []),
    }


def run(cases: list[Case], repeats: int, log=print, after_pass=None) -> dict:
    """Every case x formulation, ``repeats`` interleaved passes; the first pass's answer, the least seconds.

    ``after_pass(results, passes)`` is called after each pass (the report is written each time).
    """
    results: dict = {}
    for rep in range(repeats):
        for case in cases:
            for form in FORMULATIONS:
                r = solve_once(case, form)
                key = (case.name, form)
                if key not in results:
                    results[key] = r | {"times": [r["seconds"]], "objectives": [r["objective"]]}
                else:
                    results[key]["times"].append(r["seconds"])
                    results[key]["objectives"].append(r["objective"])
                log(f"[{rep + 1}/{repeats}] {case.name} {form}: {r['status']} valid={r['valid']} "
                    f"obj={_fmt(r['objective'], 6)} clear={_fmt(r['clearance'], 4)} it={r['iterations']} "
                    f"{r['seconds']:.1f} s")  # fmt: skip
        for r in results.values():
            r["seconds"] = min(r["times"])
        if after_pass is not None:
            after_pass(results, rep + 1)
    return results


def _fmt(value, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{value:.{digits}g}"


def refusals(cases: list[Case], results: dict) -> dict[tuple[str, str], list[str]]:
    """(a, b) -> the scenarios where formulation a gives no valid answer and b does."""
    out = {}
    for a in FORMULATIONS:
        for b in FORMULATIONS:
            if a != b:
                out[(a, b)] = [c.name for c in cases if not results[c.name, a]["valid"] and results[c.name, b]["valid"]]
    return out


def table(cases: list[Case], results: dict) -> list[str]:
    """The markdown table: one row per scenario and formulation."""
    lines = [
        "| scenario | N (answer's N) | formulation | status | valid | objective | excess over best valid | "
        "exact node clearance (m) | dense clearance (m) | Ipopt iterations | seconds (min) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for case in cases:
        valid = [results[case.name, f]["objective"] for f in FORMULATIONS if results[case.name, f]["valid"]]
        best = min(valid) if valid else None
        for form in FORMULATIONS:
            r = results[case.name, form]
            excess = f"{r['objective'] - best:+.4f}" if r["valid"] and best is not None else "-"
            lines.append(
                f"| {case.name} | {case.intervals} ({r['solved_n']}) | {form} | {r['status']} | "
                f"{'yes' if r['valid'] else 'no'} | "
                f"{_fmt(r['objective'], 7)} | {excess} | {_fmt(r['clearance'], 3)} | {_fmt(r['dense'], 3)} | "
                f"{r['iterations']} | {r['seconds']:.1f} |"
            )
    return lines


def machine() -> dict[str, str]:
    """nproc, the CPU model and the load average."""
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor())  # fmt: skip
    load = subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()
    return {"nproc": str(os.cpu_count()), "cpu": cpu, "load": load}


def report(cases: list[Case], results: dict, repeats: int, before: dict, after: dict) -> str:
    """The markdown report."""
    lines = [
        "# Bodies on a road: NLP formulations compared",
        "",
        "Written by `python -m benchmarks.bench_formulations` (issue 11, item 3; docs/bodies-formulation.md).",
        f"Default formulation: `{DEFAULT_FORMULATION}`. Each cell is the default solve `ocp.solve(intervals=N)` "
        f"(multi-start, screening where N is large, exact validation); seconds are the least of {repeats} "
        "interleaved runs of the whole solve, the other columns the first run's.",
        "",
        f"Machine: {before['nproc']} cores, {before['cpu']}. Load before: `{before['load']}`; "
        f"after: `{after['load']}` (the cores are shared with other runs: seconds are noisy).",
        "",
        "Scenarios:",
        "",
    ]
    lines += [f"- `{c.name}` ({c.source}), N = {c.intervals}" for c in cases]
    lines += ["- `examples/roundabout-truck.toml` is the problem of `workflows/roads/truck-straight-on.toml` "
              "(the files differ only in name): solved once.", ""]  # fmt: skip
    lines += table(cases, results)
    lines += ["", "Exact node clearance: the least signed distance of the exact rectangles to the exact corridor "
              "edge at the nodes (>= 0 inside); for a body pressed against an edge it is what the formulation "
              "gives away. Dense: the same on 4 linearly interpolated sub-steps per interval (reported, not judged). "
              "The answer's N differs from N where the goal-accuracy rule (model.search.accuracy) solved again on 2N.",
              "", "## Refusals", ""]  # fmt: skip
    for (a, b), names in refusals(cases, results).items():
        lines.append(f"- `{a}` has no valid answer where `{b}` solves: {len(names)}" + (
            f" ({', '.join(names)})" if names else ""))  # fmt: skip
    drift = [f"{c.name}/{f}" for c in cases for f in FORMULATIONS
             if len({_fmt(o, 12) for o in results[c.name, f]["objectives"]}) > 1]  # fmt: skip
    lines += ["", "Repeated runs gave the same objective" + (f" except: {', '.join(drift)}." if drift else ".")]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and write its report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--only", nargs="*", help="scenario names to run (default: all)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    cases = [c for c in all_cases() if not args.only or c.name in args.only]
    before = machine()

    def write(results: dict, passes: int) -> None:
        args.out.write_text(report(cases, results, passes, before, machine()))

    run(cases, args.repeats, log=lambda s: print(s, flush=True), after_pass=write)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
