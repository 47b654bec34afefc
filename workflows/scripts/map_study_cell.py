"""Map study, one cell: a design vehicle drives one movement of a real roundabout, with or without the apron.

The cell's scenario is the template (workflows/scenarios/maps/kackertstrasse.toml) with the preset,
the movement's route and the apron set (model.studies.maps.cell_document), at the preset's operational limits
unless ``--no-operational`` (model.studies.roads.operational_document). Solves the minimum time
(the map corridor strips, model.search.maps) and records what a designer reads
(model.studies.maps.cell_measures); a cell that fails only between the nodes is solved again on
2N (model.studies.maps.solve_cell). A failed solve, or a movement where no start or goal pose of the
vehicle fits the corridor, is written as failed with its diagnosis; it is never a solution.
An unknown preset or movement, or a bad cell name: one line, exit 2, nothing written.
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
from model.problem.maps import map_of  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.studies.maps import (  # noqa: E402
    apron_use,
    cell_document,
    cell_measures,
    find_movement,
    parse_cell,
    solve_cell,
)
from model.vehicles import operational_limits, preset  # noqa: E402


def limits_record(preset_name: str) -> dict:
    """The preset's operational limits as a JSON record (``model.vehicles.operational_limits``)."""
    lim = operational_limits(preset_name)
    return {"acceleration": list(lim.acceleration), "jerk": list(lim.jerk), "speed": lim.speed,
            "steering_rate": lim.steering_rate, "lateral_acceleration": lim.lateral_acceleration,
            "rollover_threshold": lim.rollover_threshold, "crawl_speed": lim.crawl_speed}  # fmt: skip


def run_cell(template: Path, cell: str, intervals: int, operational: bool = True) -> dict:
    """The cell's record: its route keys, and the solve's measures or why it was not solved; ``operational``:
    at the preset's operational limits (``limits`` the preset's, None without)."""
    started = time.perf_counter()
    preset_name, movement, apron = parse_cell(cell)
    preset(preset_name)  # an unknown preset is bad input
    base = tomllib.loads(template.read_text())
    lanelet_map = map_of(base, template.parent)
    found = find_movement(lanelet_map, movement)  # a movement not in the map is bad input
    record = {"cell": cell, "preset": preset_name, "movement": movement, "entry": found.entry, "exit": found.exit,
              "apron": apron, "apron_use": apron_use(preset_name) if apron else "none", "intervals": intervals,
              "template": str(template), "operational": operational,
              "limits": limits_record(preset_name) if operational else None}  # fmt: skip
    try:
        doc = cell_document(base, lanelet_map, preset_name, movement, apron, intervals, operational)
    except InputError as err:  # no start or goal pose of this vehicle fits the corridor: a result, not bad input
        return record | {"status": "not posed", "valid": False, "diagnosis": {"kind": "poses", "message": str(err)},
                         "seconds": time.perf_counter() - started}  # fmt: skip
    record["route"] = doc["route"]
    ocp = parse_scenario(doc, path=template).ocp
    record["speed_bound"] = list(ocp.bounds.get(ocp.vehicle.roles.speed, ()))
    record["initial_speed"] = ocp.initial.get(ocp.vehicle.roles.speed)
    sol, tried = solve_cell(ocp, intervals)
    return record | cell_measures(ocp, sol) | {"intervals_solved": sol.intervals, "tried": tried,
                                               "seconds": time.perf_counter() - started}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument("--cell", required=True, help="e.g. SU-30_90-102_apron (model.studies.maps.cell_name)")
    ap.add_argument("--intervals", type=int, required=True)
    ap.add_argument("--operational", action=argparse.BooleanOptionalAction, default=True,
                    help="the preset's operational limits (default; --no-operational: the kinematic model, the "
                         "speed a control)")  # fmt: skip
    ap.add_argument("--out", type=Path, required=True, help="the cell's JSON file")
    args = ap.parse_args()
    try:
        record = run_cell(args.template, args.cell, args.intervals, args.operational)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    write_json(args.out, record)


if __name__ == "__main__":
    run_and_leave(main)
