"""The truck in traffic, one cell: a vehicle through SUMO traffic of one rate, one driver, K seeded runs.

The cell's scenario is the template (workflows/scenarios/traffic/<vehicle>.toml) with ``--rate``
veh/h entering from every other leg (model.traffic.study.cell_document); ``roundabout traffic``'s
runs (model.traffic.run.run_traffic) go to ``--keep``; the cell's JSON holds each run's metrics and
gap acceptance and SUMO's cars' at their entries (model.traffic.study.run_record), the wall and CPU
seconds of the runs. A run that fails (no arrival, a collision, a road
violation) is recorded as failed, never dropped.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from studies_common import write_json  # noqa: E402

from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.run import run_traffic  # noqa: E402
from model.traffic.study import cell_document, conflicting_demand, parse_cell, run_record  # noqa: E402
from model.traffic.sumo import find_sumo  # noqa: E402


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process and its finished children (SUMO, netconvert)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def run_cell(template: Path, cell: str, runs: int, seed: int, keep: Path) -> dict:
    vehicle, rate, driver = parse_cell(cell)
    doc = cell_document(tomllib.loads(template.read_text()), rate, seed)
    scenario = parse_scenario(doc, default_name=cell)
    if keep.exists():
        shutil.rmtree(keep)
    keep.mkdir(parents=True)
    start, cpu = time.perf_counter(), cpu_seconds()
    summary = run_traffic(scenario, find_sumo(), keep, driver, runs)
    seconds, cpu = time.perf_counter() - start, cpu_seconds() - cpu
    folders = [keep] if runs == 1 else [keep / f"run-{k}" for k in range(runs)]
    records = [run_record(scenario, f) for f in folders if (f / "traffic.csv").exists()]
    return {"cell": cell, "vehicle": vehicle, "rate": rate, "driver": driver, "seed": seed, "template": str(template),
            "demand_q": conflicting_demand(scenario), "summary": summary, "runs": records, "seconds": seconds,
            "cpu_seconds": cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument("--cell", required=True, help="e.g. truck_q600_autopilot (model.traffic.study.cell_name)")
    ap.add_argument("--runs", type=int, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--keep", type=Path, required=True, help="folder for the runs' files")
    ap.add_argument("--out", type=Path, required=True, help="the cell's JSON file")
    args = ap.parse_args()
    write_json(args.out, run_cell(args.template, args.cell, args.runs, args.seed, args.keep))


if __name__ == "__main__":
    main()
