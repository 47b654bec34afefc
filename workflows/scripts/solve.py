"""Solve one scenario with `roundabout solve`; a solver failure (exit 1) is recorded, not raised.

Exit 0 of this wrapper: DIR/summary.json and DIR/trajectory.csv exist, and summary.json's
``exit_code`` says whether the solve succeeded (0) or failed (1, ``status`` says how).
Exit 2 (invalid scenario file) is passed on, so that the workflow rule fails.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

HEADER = "t,x,y,theta,phi,u1,u2\n"


def command(scenario: Path, out: Path, intervals: int | None) -> list[str]:
    exe = shutil.which("roundabout")
    cmd = [exe] if exe else [sys.executable, "-m", "model.cli"]
    cmd += ["solve", str(scenario), "--out", str(out)]
    return cmd + (["--intervals", str(intervals)] if intervals else [])


def record_failure(out: Path, scenario: Path, code: int, stderr: str) -> None:
    """Make sure a failed solve leaves a summary that says so, and a (possibly empty) trajectory."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / "summary.json"
    summary = json.loads(path.read_text()) if path.exists() else {"name": scenario.stem, "status": "error"}
    summary.update(exit_code=1, valid=bool(summary.get("valid", False)), solver_exit=code,
                   failure=stderr.strip().splitlines()[-1] if stderr.strip() else "")
    path.write_text(json.dumps(summary, indent=2) + "\n")
    if not (out / "trajectory.csv").exists():
        (out / "trajectory.csv").write_text(HEADER)


def mark_success(out: Path) -> None:
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary["exit_code"] = 0
    path.write_text(json.dumps(summary, indent=2) + "\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--intervals", type=int)
    args = ap.parse_args(argv)
    run = subprocess.run(command(args.scenario, args.out, args.intervals), capture_output=True, text=True)
    sys.stdout.write(run.stdout)
    sys.stderr.write(run.stderr)
    if run.returncode == 0:
        mark_success(args.out)
        return 0
    if run.returncode == 2:
        return 2
    record_failure(args.out, args.scenario, run.returncode, run.stderr)
    print(f"solve.py: {args.scenario.stem} FAILED (exit {run.returncode}); recorded in {args.out}/summary.json",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
