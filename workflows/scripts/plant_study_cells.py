"""Plant study (issue 43, item 5), one manoeuvre: a vehicle's route planned kinematically at rising lateral
acceleration and driven on the dynamic plant.

For each level L of ``--levels`` (m/s^2) the template (workflows/scenarios/plant-study/<vehicle>.toml) gets
``bounds.lateral_acceleration = [-L, L]``, ``route.exit = --exit`` and ``problem.intervals = --intervals``
(model.studies.plant_gap.cell_scenario); the plan is the default solve's minimum time, driven by the tracking
controller on the kinematic and on the single-track plant (model.studies.plant_gap.run_cell). The levels run in
one process (the imports paid once). Writes ``--out``: a JSON list of records, one per level (a plan that did
not validate is recorded with its status and no closed-loop numbers). A bad level or template key: one line,
exit 2, nothing written.
"""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from studies_common import run_and_leave, write_json  # noqa: E402

from model.errors import InputError  # noqa: E402
from model.studies.plant_gap import cell_scenario, run_cell  # noqa: E402


def run_manoeuvre(template: Path, vehicle: str, exit: int, levels: list[float], intervals: int,
                  time_limit: float | None) -> list[dict]:  # fmt: skip
    """One record per level, in the order given; every scenario is checked before the first solve."""
    document = tomllib.loads(template.read_text())
    scenarios = [cell_scenario(document, level, exit=exit, intervals=intervals, name=f"{vehicle}-exit{exit}-{level:g}")
                 for level in levels]  # fmt: skip
    labels = {"vehicle": vehicle, "preset": document.get("vehicle", {}).get("preset")}
    records = []
    for scenario in scenarios:
        started = time.process_time()
        records.append(run_cell(scenario, time_limit=time_limit, clock="cpu", labels=labels))
        print(f"{scenario.ocp.name}: {records[-1]['status']}, {time.process_time() - started:.1f} s CPU",
              file=sys.stderr, flush=True)  # fmt: skip
    return records


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument("--vehicle", required=True, help="the template's name in the study (its file stem)")
    ap.add_argument("--exit", type=int, required=True, help="route.exit")
    ap.add_argument("--levels", type=float, nargs="+", required=True, help="bounds of the lateral acceleration, m/s^2")
    ap.add_argument("--intervals", type=int, required=True)
    ap.add_argument("--time-limit", type=float, default=None, help="CPU seconds for each level's plan search")
    ap.add_argument("--out", type=Path, required=True, help="the manoeuvre's JSON file")
    args = ap.parse_args()
    try:
        records = run_manoeuvre(args.template, args.vehicle, args.exit, args.levels, args.intervals, args.time_limit)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    write_json(args.out, records)


if __name__ == "__main__":
    run_and_leave(main)
