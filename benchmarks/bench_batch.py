"""Time to quality on small problems, as whole processes: `roundabout solve`, the batch mode, the peer.

Usage: python benchmarks/bench_batch.py [--count 12] [--seed 0] [--paper | --no-paper]
       [--timeout 400] [--json PATH] [--out PATH] [--keep DIR]

The scenarios: the paper's (every file of ``workflows/scenarios/*.toml``, the pipeline's) and the
first ``--count`` robustness scenarios of ``--seed`` (``benchmarks/bench_robustness.py``'s
generator, written to a temporary folder). One at a time (no two processes at once), each run
from this file's repository root with ``sys.executable``:

- single: ``-m model.cli solve FILE --out DIR`` per scenario (the default search, its default
  time limit), wall time around the process;
- batch: one ``-m model.cli solve FILE1 FILE2 ... --out DIR`` process over all of them; a
  scenario's time is from its ``[i of n]`` progress line to the next one (the last: to the end of
  the process; the first: from the start of the process, so it carries the imports);
- peer: ``benchmarks/multistart_peer.py FILE`` (the independent thorough multi-start in plain
  CasADi Opti, its default 20 starts) per scenario.

The objective compared is the project's least validated objective on the scenario's own N (as
bench_robustness compares it: not an accuracy re-solve on 2N) against the peer's best feasible
one; "agrees" is within 0.1 % of the peer or better, counted over the scenarios both solve. The
targets of issue 22: median single <= 1.0 x the peer's median, median batch <= 0.5 x.
Prints a Markdown report (machine, load, commit, the table, the medians); ``--json`` keeps every
record.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:  # imported as benchmarks.bench_batch
    from benchmarks.bench_robustness import GAP_TOL, objective_on_grid, write_scenarios
except ImportError:  # run as a script: benchmarks/ itself is sys.path[0]
    from bench_robustness import GAP_TOL, objective_on_grid, write_scenarios

ROOT = Path(__file__).resolve().parents[1]
PEER = ROOT / "benchmarks" / "multistart_peer.py"
PAPER = sorted((ROOT / "workflows" / "scenarios").glob("*.toml"))
SOLVE = [sys.executable, "-m", "model.cli", "solve"]
SINGLE_TARGET, BATCH_TARGET = 1.0, 0.5  # x the peer's median time


def children_cpu() -> float:
    """CPU seconds (user + system) of this process's finished children so far (their own children included)."""
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def process_cpu(pid: int) -> float | None:
    """CPU seconds of a running process and its reaped children (/proc/PID/stat utime + stime + cutime + cstime)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return None
    return sum(int(f) for f in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def timed(cmd: list[str], timeout: float) -> tuple[float, float, subprocess.CompletedProcess | None]:
    """(wall seconds, CPU seconds, the completed process or None on a timeout) of ``cmd`` run from the root."""
    t0, c0 = time.perf_counter(), children_cpu()
    try:
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        proc = None
    return time.perf_counter() - t0, children_cpu() - c0, proc


def project_result(folder: Path) -> dict:
    """Status, validity, objective and the objective on the scenario's own N of a solve's folder."""
    path = folder / "summary.json"
    if not path.exists():
        return {"valid": False, "objective": None, "objective_on_n": None, "status": "no summary.json"}
    summary = json.loads(path.read_text())
    valid = bool(summary.get("valid"))
    on_n = objective_on_grid({"attempts": summary.get("attempts")}) if valid else None
    return {"valid": valid, "status": summary.get("status"), "objective": summary.get("objective"),
            "objective_on_n": on_n if on_n is not None else (summary.get("objective") if valid else None)}  # fmt: skip


def run_single(path: Path, out: Path, timeout: float) -> dict:
    """One `roundabout solve` process."""
    seconds, cpu, proc = timed([*SOLVE, str(path), "--out", str(out), "--quiet"], timeout)
    return {"seconds": seconds, "cpu": cpu, "returncode": None if proc is None else proc.returncode,
            **project_result(out)}  # fmt: skip


def run_batch(paths: list[Path], names: list[str], out: Path) -> tuple[float, list[dict]]:
    """One batch process over ``paths``: its wall time and one record per scenario (wall and CPU time from its
    progress line to the next one)."""
    marks: list[tuple[float, float | None]] = []
    t0, c0 = time.perf_counter(), children_cpu()
    proc = subprocess.Popen([*SOLVE, *map(str, paths), "--out", str(out)], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert proc.stderr is not None
    for line in proc.stderr:
        if line.startswith("[") and " of " in line.split("]")[0]:
            marks.append((time.perf_counter(), process_cpu(proc.pid)))
    proc.wait()
    total, cpu = time.perf_counter() - t0, children_cpu() - c0
    ends = [m for m in marks[1:]] + [(t0 + total, cpu)]
    starts = [(t0, 0.0)] + marks[1:]
    records = []
    for i, name in enumerate(names):
        wall = ends[i][0] - starts[i][0] if i < len(marks) else None
        used = ends[i][1] - starts[i][1] if i < len(marks) and None not in (ends[i][1], starts[i][1]) else None
        records.append({"seconds": wall, "cpu": used, "returncode": proc.returncode, **project_result(out / name)})
    return total, records


def run_peer(path: Path, timeout: float) -> dict:
    """One peer process: wall time and its best feasible objective (None: none found)."""
    seconds, cpu, proc = timed([sys.executable, str(PEER), str(path)], timeout)
    best = None
    if proc is not None:
        lines = proc.stdout.strip().splitlines()
        try:
            best = json.loads(lines[-1]).get("best")
        except (IndexError, ValueError):
            best = None
    return {"seconds": seconds, "cpu": cpu, "objective": best["objective"] if best else None,
            "start": best["label"] if best else None}  # fmt: skip


def scenarios(args: argparse.Namespace, folder: Path) -> list[tuple[str, str, Path]]:
    """(set, name, file) of every scenario benchmarked."""
    items = [("paper", p.stem, p) for p in PAPER] if args.paper else []
    items += [("robustness", path.stem, path) for _, path, _ in write_scenarios(args.count, args.seed, folder)]
    return items


def gap(mine: float | None, theirs: float | None) -> float | None:
    """(project - peer) / |peer|, or None where either found nothing."""
    return None if mine is None or theirs is None else (mine - theirs) / abs(theirs)


def machine() -> str:
    """CPU model, core count and Python."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def commit() -> str:
    """The checkout's commit (with '+changes' if the tree differs from it)."""
    def git(*a: str) -> str:
        return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, check=False).stdout.strip()

    head = git("rev-parse", "--short", "HEAD")
    if not head:
        return "unknown (not a git checkout)"
    return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def _s(value: float | None, fmt: str = ".2f") -> str:
    return "-" if value is None else format(value, fmt)


def _o(value: float | None) -> str:
    return "-" if value is None else f"{value:.6g}"


def markdown(rows: list[dict], meta: dict) -> str:
    """The report: one row per scenario, then the medians, the ratios and the agreement count."""
    lines = [
        f"## Time to quality: {len(rows)} scenarios ({meta['sets']}), whole processes, one at a time",
        "",
        f"{meta['machine']}; load average {meta['load_before']} before, {meta['load_after']} after; commit "
        f"{meta['commit']}; batch process {meta['batch_seconds']:.1f} s in all, singles {meta['single_total']:.1f} s, "
        f"peers {meta['peer_total']:.1f} s.",
        "",
        "Seconds are wall / CPU (user + system, children included) of the processes.",
        "",
        "| set | scenario | single s | batch s | peer s | single / peer (CPU) | objective (on N) | batch objective "
        "| peer objective | gap to peer | agrees |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ratio = r["single"]["cpu"] / r["peer"]["cpu"] if r["peer"]["cpu"] else None
        agree = "-" if r["gap"] is None else ("yes" if r["gap"] <= GAP_TOL else "no")
        mine = _o(r["single"]["objective_on_n"]) if r["single"]["valid"] else f"failed ({r['single']['status']})"
        times = " | ".join(f"{_s(r[k]['seconds'])} / {_s(r[k]['cpu'])}" for k in ("single", "batch", "peer"))
        gap = _s(None if r["gap"] is None else 100 * r["gap"], "+.3f")
        lines.append(f"| {r['set']} | {r['name']} | {times} | {_s(ratio)} | {mine} "
                     f"| {_o(r['batch']['objective_on_n'])} | {_o(r['peer']['objective'])} | {gap} % "
                     f"| {agree} |")  # fmt: skip
    s = meta["summary"]
    lines += [
        "",
        "| median per scenario | wall s | x the peer's | CPU s | x the peer's | target |",
        "|---|---|---|---|---|---|",
    ]
    for key, label, target in (("single", "`roundabout solve` per scenario", f"<= {SINGLE_TARGET}"),
                               ("batch", "batch (one process)", f"<= {BATCH_TARGET}"),
                               ("peer", "peer (`multistart_peer.py`)", "")):  # fmt: skip
        wall, cpu = s["median"][key], s["median_cpu"][key]
        lines.append(f"| {label} | {wall:.2f} | {wall / s['median']['peer']:.2f} | {cpu:.2f} | "
                     f"{cpu / s['median_cpu']['peer']:.2f} | {target} |")  # fmt: skip
    lines += [
        "",
        f"Both solve {s['both']} scenarios; the project's objective is within 0.1 % of the peer's or better in "
        f"{s['agree']} of them ({100 * s['agree'] / max(1, s['both']):.0f} %; target 95 %). The batch's objectives "
        f"equal the single solves' in {s['batch_same']} of {len(rows)}. Solved and validated: single "
        f"{s['single_ok']}, batch {s['batch_ok']}, peer found a feasible answer {s['peer_ok']}.",
    ]
    return "\n".join(lines)


def summarise(rows: list[dict]) -> dict:
    """Medians of wall and CPU seconds per scenario and the agreement counts."""

    def median(kind: str, key: str) -> float:
        return statistics.median(r[kind][key] for r in rows if r[kind][key] is not None)

    both = [r for r in rows if r["gap"] is not None]
    return {"median": {k: median(k, "seconds") for k in ("single", "batch", "peer")},
            "median_cpu": {k: median(k, "cpu") for k in ("single", "batch", "peer")},
            "both": len(both), "agree": sum(r["gap"] <= GAP_TOL for r in both),
            "batch_same": sum(r["batch"]["objective"] == r["single"]["objective"] for r in rows),
            "single_ok": sum(r["single"]["valid"] for r in rows), "batch_ok": sum(r["batch"]["valid"] for r in rows),
            "peer_ok": sum(r["peer"]["objective"] is not None for r in rows)}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12, help="robustness scenarios 0 .. count - 1 (default 12)")
    ap.add_argument("--seed", type=int, default=0, help="the robustness generator's seed (default 0)")
    ap.add_argument("--paper", action=argparse.BooleanOptionalAction, default=True,
                    help="the paper's scenarios, workflows/scenarios/*.toml (default on)")  # fmt: skip
    ap.add_argument("--timeout", type=float, default=400.0,
                    help="seconds per single or peer process (the batch has none)")  # fmt: skip
    ap.add_argument("--json", type=Path, help="write every record here")
    ap.add_argument("--out", type=Path, help="write the Markdown report here too")
    ap.add_argument("--keep", type=Path, help="keep the scenario files and every output folder here (default: temp)")
    args = ap.parse_args(argv)
    load_before = " ".join(f"{x:.2f}" for x in os.getloadavg())
    with tempfile.TemporaryDirectory(prefix="bench-batch-") as scratch:
        tmp = args.keep or Path(scratch)
        items = scenarios(args, Path(tmp) / "scenarios")
        if not items:
            raise SystemExit("no scenarios: --count 0 and --no-paper")
        rows = []
        for i, (group, name, path) in enumerate(items, 1):
            single = run_single(path, Path(tmp) / "single" / f"{group}-{name}", args.timeout)
            peer = run_peer(path, args.timeout)
            mine = single["objective_on_n"] if single["valid"] else None
            rows.append({"set": group, "name": name, "file": str(path), "single": single, "peer": peer,
                         "gap": gap(mine, peer["objective"])})  # fmt: skip
            print(f"[{i}/{len(items)}] {group} {name}: single {single['seconds']:.2f} s ({single['cpu']:.2f} CPU), "
                  f"peer {peer['seconds']:.2f} s ({peer['cpu']:.2f} CPU)", file=sys.stderr, flush=True)  # fmt: skip
        files, names = [Path(r["file"]) for r in rows], [r["name"] for r in rows]
        batch_seconds, batch = run_batch(files, names, Path(tmp) / "batch")
        for row, rec in zip(rows, batch, strict=True):
            row["batch"] = rec
    meta = {"sets": ", ".join(dict.fromkeys(r["set"] for r in rows)), "machine": machine(), "commit": commit(),
            "load_before": load_before, "load_after": " ".join(f"{x:.2f}" for x in os.getloadavg()),
            "batch_seconds": batch_seconds, "single_total": sum(r["single"]["seconds"] for r in rows),
            "peer_total": sum(r["peer"]["seconds"] for r in rows), "summary": summarise(rows)}  # fmt: skip
    report = markdown(rows, meta)
    print(report)
    if args.out:
        args.out.write_text(report + "\n")
    if args.json:
        args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
