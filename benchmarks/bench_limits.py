"""Answers at the limits (issue 22): the tight road scenarios of ``benchmarks/limits/`` as whole processes.

Each scenario file is solved by ``roundabout solve FILE --out DIR --time-limit 120`` (default
search, the file's N) in its own process; recorded per scenario: the wall time of the process,
its exit code, status, validation, objective, N solved on, the diagnosis of a refusal (kind and
message) and the search's record (stopped by the time limit, steps skipped), with the machine
and its load (``uptime``) before and after each run. Appends a section to ``benchmarks/limits.md``
(``--label`` names it, e.g. "before" or "after"), so the file holds the before/after record.

Run: ``python -m benchmarks.bench_limits [--label NAME] [--only NAME ...] [--time-limit 120] [--out PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.bench_formulations import machine

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "benchmarks" / "limits"
OUT = ROOT / "benchmarks" / "limits.md"
TIME_LIMIT = 120.0  # s, the issue's "within 120 s"


def uptime() -> str:
    """The load average part of ``uptime``."""
    text = subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()
    return text.split("load average:")[-1].strip()


def run_one(path: Path, time_limit: float) -> dict:
    """One ``roundabout solve`` process on ``path``: wall time, exit code and what summary.json says."""
    load_before = uptime()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        cmd = [sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out),
               "--time-limit", f"{time_limit:g}"]  # fmt: skip
        began = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=os.environ.copy())
        wall = time.perf_counter() - began
        summary_path = out / "summary.json"
        summary = json.loads(summary_path.read_text()) if summary_path.exists() else {}
    diagnosis = summary.get("diagnosis") or {}
    search = summary.get("search") or {}
    return {
        "name": path.stem,
        "wall_s": wall,
        "exit": proc.returncode,
        "status": summary.get("status"),
        "valid": summary.get("valid"),
        "objective": summary.get("objective"),
        "intervals": summary.get("intervals"),
        "min_clearance": summary.get("min_clearance"),
        "min_clearance_dense": summary.get("min_clearance_dense"),
        "diagnosis": f"{diagnosis.get('kind', '')}: {diagnosis.get('message', '')}"[:400] if diagnosis else "",
        "stopped": search.get("stopped_by_time_limit"),
        "steps_skipped": ", ".join(search.get("steps_skipped", [])),
        "progress": [line for line in proc.stderr.splitlines()
                     if line.strip() and not line.strip().startswith(("...", "Ipopt iteration"))][-16:],
        "load": f"{load_before} -> {uptime()}",
    }


def fmt(value, spec: str = ".6g") -> str:
    """A table cell: numbers formatted, None as a dash."""
    if value is None:
        return "-"
    return format(value, spec) if isinstance(value, float) else str(value)


def section(label: str, rows: list[dict], time_limit: float) -> str:
    """The markdown section of one run of the benchmark."""
    info = machine()
    lines = [f"## {label} ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})", "",
             f"Machine: {info['nproc']} cores, {info['cpu']}; shared with other sessions. "
             f"`roundabout solve FILE --time-limit {time_limit:g}` (default search, each file's N), one process each.",
             "", "| scenario | wall s | exit | status | valid | objective | N | clearance (nodes / dense) m "
             "| stopped | diagnosis | load (1/5/15 min, before -> after) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        clearance = f"{fmt(r['min_clearance'], '.3f')} / {fmt(r['min_clearance_dense'], '.3f')}"
        lines.append(f"| {r['name']} | {r['wall_s']:.1f} | {r['exit']} | {fmt(r['status'])} | {fmt(r['valid'])} | "
                     f"{fmt(r['objective'])} | {fmt(r['intervals'])} | {clearance} | {fmt(r['stopped'])} | "
                     f"{r['diagnosis'].replace('|', '/') or '-'} | {r['load']} |")  # fmt: skip
    lines += ["", "Last progress lines per scenario:", ""]
    for r in rows:
        lines += [f"- {r['name']}:", "", "```", *r["progress"], "```", ""]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    """Run the scenarios and append the section to the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", default="run")
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--time-limit", type=float, default=TIME_LIMIT)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    paths = sorted(SCENARIOS.glob("*.toml"))
    if args.only:
        paths = [p for p in paths if p.stem in args.only]
    rows = []
    for path in paths:
        row = run_one(path, args.time_limit)
        rows.append(row)
        print(f"{row['name']}: {row['wall_s']:.1f} s, exit {row['exit']}, {row['status']}, valid {row['valid']}, "
              f"objective {row['objective']}, {row['diagnosis'][:160]}", flush=True)  # fmt: skip
    if not args.out.exists():
        args.out.write_text("# Answers at the limits: tight road scenarios within 120 s (issue 22)\n\n"
                            "Written by `python -m benchmarks.bench_limits`; scenarios in `benchmarks/limits/`.\n\n")
    with args.out.open("a") as fh:
        fh.write(section(args.label, rows, args.time_limit))


if __name__ == "__main__":
    main()
