"""Whole-process benchmark: `roundabout solve` against a one-file CasADi Opti script.

Usage: python benchmarks/bench_process.py [--scenario FILE ...] [--intervals N ...]
       [--repeat R] [--warmup W] [--json PATH]

For each scenario and N, the two processes run alternately, R times each, after W
untimed warm-up runs of each (they compile .pyc files and fill the page cache):

- roundabout: ``sys.executable -m model.cli solve SCENARIO --out TMPDIR --intervals N``,
  i.e. the console script's code without its launcher (a pyenv shim alone costs tens
  of ms). The working directory is this file's repository root, and ``-m`` puts it
  first on sys.path, so its ``model`` is the one timed (a worktree snapshot, say). It
  runs all its starts (both passes for pass = "auto"), certifies and writes its files;
- Opti: ``sys.executable benchmarks/opti_script.py SCENARIO --intervals N`` with the
  start (pass, guess route, Tf scale) of the attempt the roundabout run kept, read from
  its summary.json, so both report the same local minimum: one Ipopt solve.

Wall time is time.perf_counter() around subprocess.run. The table gives medians (with
min-max), their ratio, both objectives and their relative difference (a warning if it
exceeds OBJECTIVE_RTOL), and the number of Ipopt solves of the roundabout run; a second
table sets the time each process reports for its own work (roundabout's solve_seconds:
all starts, validation and certificate; the Opti script's main()) against the process
time, the rest being interpreter start-up, imports and shutdown. Baselines are the
`python -c pass`, `import casadi` and `import <the project's solve module>` processes.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OPTI_SCRIPT = ROOT / "benchmarks" / "opti_script.py"
SCENARIOS = [ROOT / "examples" / "format-example.toml", ROOT / "workflows" / "scenarios" / "time-s1.toml"]
# The project's solve path (model/ is being split into subpackages: whichever this tree has).
SOLVE_MODULE = "model.search.multistart"
OBJECTIVE_RTOL = 1e-6  # the two objectives must agree to this (relative)
BASELINES = {label: label for label in ("pass", "import casadi", f"import {SOLVE_MODULE}")}


def run(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess]:
    """Run ``cmd`` from the repository root; (wall seconds, completed process)."""
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
    return time.perf_counter() - start, proc


def roundabout(scenario: Path, n: int, tmp: Path) -> dict:
    """One `roundabout solve` process: wall seconds and its summary.json."""
    out = Path(tempfile.mkdtemp(dir=tmp))
    seconds, proc = run([sys.executable, "-m", "model.cli", "solve", str(scenario), "--out", str(out),
                         "--intervals", str(n)])  # fmt: skip
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"roundabout solve failed ({proc.returncode}):\n{proc.stderr}")
    summary = json.loads((out / "summary.json").read_text())
    return {"seconds": seconds, "returncode": proc.returncode, "summary": summary}


def opti(scenario: Path, n: int, start: dict) -> dict:
    """One opti_script.py process from ``start``: wall seconds and its JSON line."""
    cmd = [sys.executable, str(OPTI_SCRIPT), str(scenario), "--intervals", str(n), "--pass", start["pass"],
           "--route", start["route"], "--tf-scale", str(start["tf_guess_scale"])]  # fmt: skip
    seconds, proc = run(cmd)
    if not proc.stdout.strip():
        raise RuntimeError(f"opti_script.py failed ({proc.returncode}):\n{proc.stderr}")
    return {"seconds": seconds, "returncode": proc.returncode, "result": json.loads(proc.stdout.splitlines()[-1])}


def kept_start(summary: dict) -> dict:
    """The attempt whose result roundabout kept: its pass, closest objective, among the starts the Opti
    script can make (the arc and line guesses; not the Reeds-Shepp, smooth-route or refined ones)."""
    done = [a for a in summary["attempts"] if a["objective"] is not None and a.get("route") in ("arc", "line")
            and a.get("tf_guess_scale") is not None]  # fmt: skip
    if not done:  # every start was screened on a coarse grid: the first default start, cold, at N
        return {"pass": summary.get("pass") or "none", "route": "arc", "tf_guess_scale": 1.0, "objective": None}
    same = [a for a in done if a["pass"] == summary["pass"]] or done
    return min(same, key=lambda a: abs(a["objective"] - summary["objective"]))


def compare(scenario: Path, n: int, repeat: int, warmup: int, tmp: Path) -> dict:
    """Alternate the two processes ``repeat`` times after ``warmup`` untimed runs of each."""
    first = roundabout(scenario, n, tmp)
    start = kept_start(first["summary"])
    for _ in range(warmup - 1):
        roundabout(scenario, n, tmp)
    for _ in range(warmup):
        opti(scenario, n, start)
    ours, peer = [], []
    for _ in range(repeat):
        ours.append(roundabout(scenario, n, tmp))
        peer.append(opti(scenario, n, start))
    return summarise(scenario, n, start, ours, peer)


def summarise(scenario: Path, n: int, start: dict, ours: list[dict], peer: list[dict]) -> dict:
    """Medians, objectives and counts of one (scenario, N) comparison."""
    t_ours, t_peer = [r["seconds"] for r in ours], [r["seconds"] for r in peer]
    summary, result = ours[-1]["summary"], peer[-1]["result"]
    obj_ours, obj_peer = summary["objective"], result["objective"]
    diff = abs(obj_ours - obj_peer) / max(abs(obj_ours), 1e-12)
    if diff > OBJECTIVE_RTOL:
        print(f"# WARNING {scenario.name} N = {n}: objectives differ by {diff:.1e} (relative)", file=sys.stderr)
    return {
        "scenario": scenario.name,
        "N": n,
        "start": {k: start[k] for k in ("pass", "route", "tf_guess_scale")},
        "roundabout": {
            "median": statistics.median(t_ours),
            "samples": t_ours,
            "objective": obj_ours,
            "status": summary["status"],
            "ipopt_solves": len(summary["attempts"]),
            "iterations": summary["iterations"],
            "timings": summary.get("timings", {}),
            "inside_median": statistics.median(r["summary"]["solve_seconds"] for r in ours),
        },
        "opti": {
            "median": statistics.median(t_peer),
            "samples": t_peer,
            **result,
            "inside_median": statistics.median(r["result"]["wall_seconds"] for r in peer),
        },
        "ratio": statistics.median(t_ours) / statistics.median(t_peer),
        "objective_rel_diff": diff,
        "objectives_agree": diff <= OBJECTIVE_RTOL,
    }


def baselines(repeat: int) -> dict[str, dict]:
    """Median wall seconds of tiny processes: interpreter start-up and imports."""
    out = {}
    for label, code in BASELINES.items():
        run([sys.executable, "-c", code])  # warm-up
        samples = [run([sys.executable, "-c", code])[0] for _ in range(repeat)]
        out[label] = {"median": statistics.median(samples), "samples": samples}
    return out


def machine() -> dict:
    """CPU model, core counts, OS, Python and solver versions."""
    cpu = "unknown"
    with open("/proc/cpuinfo") as fh:
        for line in fh:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    versions = {}
    for pkg in ("casadi", "cyipopt", "pyomo", "numpy", "scipy", "sympy", "pandas"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    return {
        "cpu": cpu,
        "logical_cpus": os.cpu_count(),
        "usable_cpus": len(os.sched_getaffinity(0)),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "executable": sys.executable,
        "pythonpath": os.environ.get("PYTHONPATH", ""),
        "bytecode_writing": "off (PYTHONDONTWRITEBYTECODE)" if os.environ.get("PYTHONDONTWRITEBYTECODE") else "on",
        "loadavg_start": os.getloadavg(),
        "versions": versions,
    }


def spread(r: dict) -> str:
    return f"{r['median']:.3f} ({min(r['samples']):.3f}-{max(r['samples']):.3f})"


def print_report(facts: dict, base: dict, rows: list[dict], repeat: int) -> None:
    """Machine facts, baselines and the Markdown table on stdout."""
    print(f"# {facts['cpu']}, {facts['logical_cpus']} logical CPUs ({facts['usable_cpus']} usable), "
          f"{facts['platform']}, Python {facts['python']}")  # fmt: skip
    print(f"# versions: {', '.join(f'{k} {v}' for k, v in facts['versions'].items())}")
    print(f"# PYTHONPATH={facts['pythonpath'] or '(unset)'}, .pyc writing {facts['bytecode_writing']}")
    print(f"# median of {repeat} processes, wall seconds (min-max)")
    load = ", ".join(f"{facts[k][0]:.2f}" for k in ("loadavg_start", "loadavg_end"))
    print(f"# 1-minute load average at start, end: {load} (other processes on the machine disturb the timings)")
    print("\n| baseline process | median s (min-max) |\n|---|---|")
    for label, r in base.items():
        print(f'| `python -c "{label}"` | {spread(r)} |')
    print(
        "\n| scenario | N | roundabout s | Opti script s | ratio | Ipopt solves (roundabout) | start (Opti) "
        "| objective roundabout | objective Opti | rel. diff | iterations roundabout / Opti |"
    )
    print("|" + "---|" * 11)
    for row in rows:
        ours, peer, s = row["roundabout"], row["opti"], row["start"]
        print(
            f"| {row['scenario']} | {row['N']} | {spread(ours)} | {spread(peer)} | {row['ratio']:.2f} | "
            f"{ours['ipopt_solves']} | {s['pass']} {s['route']} x{s['tf_guess_scale']:g} | "
            f"{ours['objective']:.10g} | {peer['objective']:.10g} | {row['objective_rel_diff']:.1e} | "
            f"{ours['iterations']} / {peer['iterations']} |",
            flush=True,
        )
    print("\n| scenario | N | roundabout: solve_seconds inside / process s | Opti: main() inside / process s |")
    print("|---|---|---|---|")
    for row in rows:
        ours, peer = row["roundabout"], row["opti"]
        print(
            f"| {row['scenario']} | {row['N']} | {ours['inside_median']:.3f} / {ours['median']:.3f} | "
            f"{peer['inside_median']:.3f} / {peer['median']:.3f} |"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", type=Path, nargs="+", default=SCENARIOS)
    ap.add_argument("--intervals", type=int, nargs="+", default=[100, 400])
    ap.add_argument("--repeat", type=int, default=5, help="timed processes of each kind (median)")
    ap.add_argument("--warmup", type=int, default=1, help="untimed processes of each kind first (>= 1)")
    ap.add_argument("--json", type=Path, help="also write machine facts, baselines and rows here")
    args = ap.parse_args(argv)
    facts, base, rows = machine(), baselines(args.repeat), []
    with tempfile.TemporaryDirectory(prefix="bench-process-") as tmp:
        for scenario in args.scenario:
            for n in args.intervals:
                rows.append(compare(scenario.resolve(), n, args.repeat, max(args.warmup, 1), Path(tmp)))
                print(f"# done: {scenario.name} N = {n}", file=sys.stderr, flush=True)
    facts["loadavg_end"] = os.getloadavg()
    print_report(facts, base, rows, args.repeat)
    if args.json:
        args.json.write_text(json.dumps({"machine": facts, "baselines": base, "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
