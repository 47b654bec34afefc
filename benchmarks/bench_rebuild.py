"""Benchmark: the full `snakemake -c2` rebuild in a fresh clone of the committed tree.

Usage: python benchmarks/bench_rebuild.py [--cores 2] [--keep DIR]

Clones HEAD into a temporary folder (uncommitted changes are not included), runs
snakemake there from nothing, and reports the wall time, the number of jobs and
whether a second dry run has nothing left to do.
"""

from __future__ import annotations

import argparse
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--keep", type=Path, help="clone here and keep it (default: a temporary folder)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        where = args.keep or Path(tmp) / "clone"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(where)], check=True)
        t0 = time.perf_counter()
        run = subprocess.run(["snakemake", f"-c{args.cores}"], cwd=where, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
        done = re.findall(r"(\d+) of (\d+) steps \(100%\) done", run.stderr)
        again = subprocess.run(["snakemake", "-n"], cwd=where, capture_output=True, text=True)
    print(f"# {platform.node()} {platform.machine()}, python {platform.python_version()}, -c{args.cores}")
    if run.returncode != 0:
        print(f"snakemake failed (exit {run.returncode}):\n{run.stderr[-2000:]}")
        return 1
    jobs = done[-1][1] if done else "?"
    print(f"full rebuild: {seconds:.1f} s, {jobs} jobs; second dry run: "
          f"{'nothing to do' if 'Nothing to be done' in again.stdout + again.stderr else 'work left'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
