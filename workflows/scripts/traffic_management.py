"""Roundabout management on everyone's delay (issue 45, point 5): benchmarks/traffic-management.md.

Run by the rule ``traffic_management`` (workflows/rules/traffic.smk) on demand, never by the default
build: ``snakemake -c2 --config traffic_study=management -- benchmarks/traffic-management.md``. From the
cells' JSON files of that grid (workflows/scripts/traffic_cell.py) and their runs' folders: per cell
the truck's delay, the others' delay (their SUMO time loss less the same seeds' without the truck),
everyone's delay (the sum; mean ± 95 % CI over the seeds, Student's t), arrivals, collisions, the least
distance, the vehicles held (distinct ids given a speed in commands.csv) and the runs in which a speed
was set; per seed everyone's delay of each driver (the drivers share the seeds: the pairs are the
comparison), and each managed driver's mean paired difference against the yielding autopilot.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from studies_common import table, write_text  # noqa: E402
from traffic_benchmark import commit  # noqa: E402
from traffic_table import mean_ci, pm  # noqa: E402

from model.traffic.study import everyone_delay, others_delay  # noqa: E402

BASELINE = "autopilot"  # the yielding autopilot, against which the managed drivers are set

CELL_COLUMNS = {
    "vehicle": "vehicle", "rate": "flow entering per other leg (veh/h)", "driver": "driver",
    "arrived": "arrived (runs / runs)", "collided": "with a collision (runs / runs)",
    "min_distance": "least distance to another vehicle (m)", "held": "vehicles held (count, all runs)",
    "commanded": "runs with a speed set (runs / runs)",
}  # fmt: skip
DELAY_COLUMNS = {
    "vehicle": "vehicle", "rate": "flow entering per other leg (veh/h)", "driver": "driver",
    "truck": "truck's delay, mean (s)", "others": "others' delay, mean (s)",
    "everyone": "everyone's delay, mean ± 95 % CI (s)", "difference": "everyone's minus the autopilot's, mean (s)",
}  # fmt: skip


REASONS = {"asked": "asked (s)", "no vehicle to hold": "no vehicle to hold (s)",
           "a blocker cannot be held": "a blocker cannot be held (s)",
           "holding would not clear the way": "holding would not clear the way (s)",
           "the hold costs more than the time lost": "hold costs more than the time lost (s)"}  # fmt: skip


REASON_COLUMNS = {"vehicle": "vehicle", "rate": "flow entering per other leg (veh/h)", "driver": "driver",
                  **REASONS, "entry_wait": "stood before the line (s)"}  # fmt: skip


def held(folder: Path) -> int | None:
    """Distinct vehicles given a speed (not -1) in ``folder/sumo/commands.csv``; None without the file."""
    path = folder / "sumo" / "commands.csv"
    if not path.exists():
        return None
    with path.open() as f:
        return len({r["id"] for r in csv.DictReader(f) if float(r["speed"]) >= 0.0})


def run_folders(runs_root: Path | None, cell: dict) -> list[Path]:
    """The cell's run folders under ``runs_root`` (one per seed), none without it."""
    if runs_root is None:
        return []
    base = runs_root / cell["cell"]
    return [base] if len(cell["runs"]) == 1 else [base / f"run-{k}" for k in range(len(cell["runs"]))]


def by_seed(cell: dict) -> dict[int, float]:
    """Seed -> everyone's delay of the cell's runs."""
    return {r["seed"]: e for r in cell["runs"] if (e := everyone_delay(r)) is not None}


def cell_row(cell: dict, baseline: dict | None, runs_root: Path | None) -> dict:
    """One cell as a row of both tables (texts for the Markdown)."""
    runs, n = cell["runs"], len(cell["runs"])
    counts = [h for f in run_folders(runs_root, cell) if (h := held(f)) is not None]
    mine = by_seed(cell)
    theirs = by_seed(baseline) if baseline else {}
    paired = [mine[s] - theirs[s] for s in sorted(mine) if s in theirs]
    distances = [r["min_distance"] for r in runs if r.get("min_distance") is not None]
    truck = [r["delay"] for r in runs if r.get("delay") is not None]
    others = [o for r in runs if (o := others_delay(r)) is not None]
    return {
        "vehicle": cell["vehicle"], "rate": cell["rate"], "driver": cell["driver"],
        "arrived": f"{sum(bool(r['arrived']) for r in runs)}/{n}",
        "collided": f"{sum((r.get('collisions') or 0) > 0 for r in runs)}/{n}",
        "min_distance": min(distances, default=None), "held": sum(counts) if counts else "-",
        "commanded": f"{sum(c > 0 for c in counts)}/{n}" if counts else "-",
        "truck": float(np.mean(truck)) if truck else None, "others": float(np.mean(others)) if others else None,
        "everyone": pm(*mean_ci(list(mine.values())), len(mine)),
        "difference": round(float(np.mean(paired)), 6) + 0.0 if paired else None,  # 1e-9 s is no difference
    }  # fmt: skip


def reason_row(cell: dict) -> dict:
    """The seconds the cell's trucks waited before their line, summed over the runs, by what the request said."""
    template = Path(cell["template"]) if Path(cell["template"]).is_absolute() else ROOT / cell["template"]
    step = tomllib.loads(template.read_text())["traffic"].get("step", 0.1)
    row = {"vehicle": cell["vehicle"], "rate": cell["rate"], "driver": cell["driver"]}
    for r in cell["runs"]:
        for reason, steps in (r.get("management") or {}).items():
            row[reason] = row.get(reason, 0.0) + steps * step
    return row | {"entry_wait": sum(r.get("entry_wait") or 0.0 for r in cell["runs"])}


def seed_rows(cells: list[dict]) -> tuple[list[dict], dict[str, str]]:
    """Per vehicle, rate and seed: everyone's delay of each driver (s); and the table's columns."""
    drivers = sorted({c["driver"] for c in cells}, key=lambda d: (d != BASELINE, d))
    rows: dict[tuple, dict] = {}
    for c in cells:
        for seed, value in by_seed(c).items():
            key = (c["vehicle"], c["rate"], seed)
            rows.setdefault(key, {"vehicle": c["vehicle"], "rate": c["rate"], "seed": seed})[c["driver"]] = value
    columns = {"vehicle": "vehicle", "rate": "flow entering per other leg (veh/h)", "seed": "seed"}
    return [rows[k] for k in sorted(rows)], columns | {d: f"{d}: everyone's delay (s)" for d in drivers}


def document(study: str, cells: list[dict], runs_root: Path | None) -> str:
    """The benchmark page: its header (grid, command, commit, CPU) and the tables."""
    cells = sorted(cells, key=lambda c: (c["vehicle"], c["rate"], c["driver"] != BASELINE, c["driver"]))
    base = {(c["vehicle"], c["rate"]): c for c in cells if c["driver"] == BASELINE}
    rows = [cell_row(c, base.get((c["vehicle"], c["rate"])), runs_root) for c in cells]
    per_seed, seed_columns = seed_rows(cells)
    reasons = [reason_row(c) for c in cells if c["driver"] == "cooperative"]
    runs = sum(len(c["runs"]) for c in cells)
    cpu = sum(c.get("cpu_seconds", 0.0) for c in cells)
    return f"""# Roundabout management on everyone's delay: grid "{study}" (issue 45, point 5)

Generated by `snakemake -c2 --config traffic_study={study} -- benchmarks/traffic-management.md`
(workflows/rules/traffic.smk, rule `traffic_management`; the grid is `traffic_studies.{study}` in
workflows/config.yaml) at commit {commit()}: {len(cells)} cells, {runs} runs, {cpu:.0f} s of the cells' CPU.
The drivers on the same seeds: `autopilot` (the yielding autopilot), `cooperative` (its priority request,
model/traffic/cooperative.py) and `reservation` (first come, first served, model/traffic/reservation.py).
Everyone's delay per run: the truck's delay plus the others' delay, the others' summed SUMO time loss less
the same vehicles' loss in the same seed's traffic replayed without the truck (model.traffic.study).

Table: Safety and the management's reach per vehicle, flow and driver (exact rectangles; held: vehicles given a
speed by the management).

{table(rows, CELL_COLUMNS)}

Table: Delays per vehicle, flow and driver (s), and everyone's delay against the yielding autopilot's on the same
seeds (mean of the per-seed differences; negative: the driver lowers it).

{table(rows, DELAY_COLUMNS)}

Table: Why the cooperative driver asked or did not (seconds the truck waited before its line with its rate below the
plan's pace, summed over the runs, by the first rule that refused the request; stood: its entry wait, summed).

{table(reasons, REASON_COLUMNS)}

Table: Everyone's delay per seed (s): the drivers on the same SUMO seed.

{table(per_seed, seed_columns)}
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--study", required=True)
    ap.add_argument("--cells", type=Path, nargs="+", required=True)
    ap.add_argument("--runs-root", type=Path, help="the cells' run folders (<root>/<cell>/run-k/sumo/commands.csv)")
    ap.add_argument("--md", type=Path, required=True)
    args = ap.parse_args()
    cells = [json.loads(p.read_text()) for p in args.cells]
    write_text(args.md, document(args.study, cells, args.runs_root))


if __name__ == "__main__":
    main()
