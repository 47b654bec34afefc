"""The ``roundabout`` command: solve a scenario file, or print its Pontryagin system.

Exit codes of ``roundabout solve``: 0 solved and validated; 1 the solver ran and
failed (DIR/summary.json says how); 2 invalid input (one line on stderr, nothing
written).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from model.errors import InputError

EPILOG = """examples:
  roundabout solve workflows/scenarios/s2-case1.toml --out results/s2-case1
  roundabout solve my.toml --out out/ --intervals 400 --verbose
  roundabout derive workflows/scenarios/s1.toml --latex

scenario files: see docs/scenario-format.md (TOML, SI units, radians).
exit codes: 0 solved and validated, 1 solver failed (summary.json says why),
            2 invalid input (one line on stderr, nothing written)."""


STARTUP: float | None = None  # seconds from process start to the CLI's main(), set by main


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="roundabout",
        description="Optimal trajectories of truck-type vehicles around roundabouts.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    s = sub.add_parser("solve", help="solve a scenario; write DIR/summary.json and DIR/trajectory.csv")
    s.add_argument("scenario", type=Path, help="scenario file (TOML)")
    s.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    s.add_argument("--intervals", type=int, metavar="N", help="override problem.intervals")
    s.add_argument("--verbose", action="store_true", help="show Ipopt's iteration log and the time of each phase")
    s.add_argument(
        "--ipopt", action="append", default=[], metavar="KEY=VALUE",
        help="an Ipopt option, e.g. mumps_pivot_order=5 or mu_strategy=adaptive (repeatable)",
    )  # fmt: skip
    d = sub.add_parser("derive", help="print the Pontryagin system of a scenario's problem")
    d.add_argument("scenario", type=Path, help="scenario file (TOML)")
    d.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    c = sub.add_parser("check", help="validate a scenario file only (exit 0 or 2)")
    c.add_argument("scenario", type=Path, help="scenario file (TOML)")
    return p


def main(argv: list[str] | None = None) -> int:
    global STARTUP
    STARTUP = process_seconds()
    args = parser().parse_args(argv)
    t0 = time.perf_counter()
    from model.problem.scenario import load_scenario

    try:
        scenario = load_scenario(args.scenario)
        args.load_seconds = time.perf_counter() - t0
        if getattr(args, "intervals", None) is not None and args.intervals < 1:
            raise InputError("--intervals", f"must be >= 1, got {args.intervals}")
        if args.command == "solve":
            check_output_folder(args.out)
            check_size(args.intervals or scenario.intervals, scenario.ocp, "--intervals" if args.intervals else None)
        options = ipopt_options(getattr(args, "ipopt", []))
        if options:
            from model.nlp.ipopt import IpoptOptionError, check_options

            try:
                check_options(options)
            except IpoptOptionError as err:
                raise InputError("--ipopt", str(err)) from None
    except InputError as err:
        print(f"roundabout: invalid input: {err}", file=sys.stderr)
        return 2
    if args.command == "check":
        print(f"{args.scenario}: ok")
        return 0
    if args.command == "derive":
        return _derive(scenario, args.latex)
    return _solve(scenario, args, options)


# Measured peak memory of a solve (truck, 4 states + 2 controls): about 165 MB plus 70 kB per interval.
BASE_BYTES, BYTES_PER_INTERVAL_AND_VARIABLE = 165e6, 70e3 / 6


def check_output_folder(out: Path) -> None:
    """``--out`` must be a folder or not exist yet, under a folder that can be written to."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a folder")
    parent = next((p for p in (out, *out.parents) if p.exists()), Path("."))
    if not os.access(parent, os.W_OK):
        raise InputError("--out", f"cannot write under {parent}")


def check_size(intervals: int, ocp, key: str | None) -> None:
    """Refuse grids whose estimated memory exceeds what this machine has available."""
    per_node = len(ocp.vehicle.states) + len(ocp.vehicle.controls)
    need = BASE_BYTES + BYTES_PER_INTERVAL_AND_VARIABLE * per_node * intervals
    have = available_memory()
    if have is not None and need > have:
        raise InputError(
            key or "problem.intervals",
            f"N = {intervals} needs about {need / 2**30:.1f} GiB, more than the {have / 2**30:.1f} GiB available",
        )


def available_memory() -> float | None:
    """MemAvailable from /proc/meminfo in bytes (None where it cannot be read)."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def ipopt_options(pairs: list[str]) -> dict:
    """``KEY=VALUE`` strings as Ipopt options (numbers where they parse as numbers)."""
    options = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key.strip() or not text.strip():
            raise InputError("--ipopt", f"expected KEY=VALUE, got {pair!r}")
        value: int | float | str = text.strip()
        for kind in (int, float):
            try:
                value = kind(text)
                break
            except ValueError:
                continue
        options[key.strip()] = value
    return options


def _solve(scenario, args, options: dict) -> int:
    intervals = args.intervals or scenario.intervals
    print(f"{scenario.ocp.name}: solving with N = {intervals} ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    from model.problem.methods import DEFAULT_SOLVE, load_method

    method = load_method(DEFAULT_SOLVE)
    t1 = time.perf_counter()
    sol = scenario.ocp.solve(
        intervals=intervals,
        method=method,
        verbose=args.verbose,
        options=options,
        progress=lambda line: print("  " + line, file=sys.stderr, flush=True),
    )
    t2 = time.perf_counter()
    sol.write(args.out)
    if args.verbose:
        phases = {"scenario (sympy, parse)": args.load_seconds, "solver imports": t1 - t0,
                  **sol.timings.get("all_starts", {}), "write": time.perf_counter() - t2}  # fmt: skip
        print(phase_report(phases), file=sys.stderr)
    line = (
        f"{scenario.ocp.name}: {sol.status}, objective {sol.objective:.10g}, Tf {sol.final_time:.6g} s, "
        f"energy {sol.energy:.6g}, {sol.iterations} iterations, {sol.solve_seconds:.2f} s"
    )
    if sol.ok:
        print(line)
        return 0
    failed = [k for k, c in sol.validation.get("checks", {}).items() if not c["passed"]]
    reason = sol.status if sol.status != "optimal" else "validation failed: " + ", ".join(failed)
    print(f"{line}\nroundabout: FAILED ({reason}); see {args.out / 'summary.json'}", file=sys.stderr)
    return 1


def process_seconds() -> float | None:
    """Seconds since this process started (Linux /proc; None elsewhere)."""
    try:
        start_ticks = float(Path("/proc/self/stat").read_text().rpartition(")")[2].split()[19])
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        return uptime - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def phase_report(phases: dict[str, float]) -> str:
    """One line per phase of the process, from its start (interpreter and imports) to the write."""
    lines = ["phases (s):"]
    if STARTUP is not None:
        lines.append(f"  {'python start + cli imports':28s} {STARTUP:8.3f}")
    lines += [f"  {name.replace('_', ' '):28s} {sec:8.3f}" for name, sec in phases.items()]
    total = process_seconds()
    if total is not None:
        lines.append(f"  {'process so far':28s} {total:8.3f}")
    return "\n".join(lines)


def _derive(scenario, latex: bool) -> int:
    from derivations.pmp import render_pmp

    print(render_pmp(scenario.ocp, fmt="latex" if latex else "text"))
    return 0


def run() -> None:
    """The console script: ``main``, then leave without tearing the interpreter down.

    Everything is written and flushed by then; freeing Pyomo's and CasADi's objects and
    modules one by one at exit would only add about 0.2 s to every solve process.
    """
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    run()
