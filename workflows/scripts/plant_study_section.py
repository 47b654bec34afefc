"""Plant study (issue 43, item 5): the table, the figure and the paper's section from the manoeuvres' records.

Reads the JSON lists of workflows/scripts/plant_study_cells.py (one record per manoeuvre and level:
model.studies.plant_gap.RECORD_KEYS) and writes ``--out``/table.csv (every record, units in the column names),
table.md, plant-gap.png/.pdf (the largest lateral deviation from the plan and the clearance lost against the
plan's largest lateral acceleration, both vehicles) and the section ``--section``, whose every number is read
from the records: the trend of each manoeuvre and the level at which the plan stops being safe
(model.studies.plant_gap.first_unsafe).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
from pathlib import Path

from studies_common import fmt, table, write_text

from model.plotting.figures import save
from model.plotting.studies import plant_gap_figure
from model.studies.plant_gap import RECORD_KEYS, first_unsafe

COLUMNS = {
    "vehicle": "vehicle",
    "manoeuvre": "manoeuvre",
    "lateral_acceleration_bound_mps2": "bound a_lat (m/s²)",
    "status": "plan",
    "intervals": "N",
    "final_time_s": "Tf (s)",
    "plan_max_speed_mps": "plan v max (m/s)",
    "plan_max_lateral_acceleration_mps2": "plan a_lat max (m/s²)",
    "plan_min_clearance_m": "plan clearance (m)",
    "kinematic_min_clearance_m": "kinematic plant clearance (m)",
    "plant_min_clearance_m": "dynamic plant clearance (m)",
    "clearance_lost_m": "clearance lost (m)",
    "kinematic_max_lateral_deviation_m": "kinematic plant deviation (m)",
    "plant_max_lateral_deviation_m": "dynamic plant deviation (m)",
    "plant_max_side_slip_rad": "side slip (rad)",
    "plant_max_lateral_acceleration_mps2": "plant a_lat max (m/s²)",
    "plant_max_friction_use": "friction use (-)",
    "plant_final_position_error_m": "goal error (m)",
    "safe": "safe",
}
TITLES = {"truck": "rigid truck", "semitrailer": "tractor-semitrailer"}
MARKERS = {"truck": "o", "semitrailer": "s"}
TABLE_DIGITS = 3  # significant digits of the table


def read_records(paths: list[Path]) -> list[dict]:
    """Every record of the manoeuvres' files, by vehicle, manoeuvre and level."""
    records = [r for p in paths for r in json.loads(Path(p).read_text())]
    order = {name: i for i, name in enumerate(TITLES)}  # the rigid truck first, then the semitrailer, then others
    return sorted(records, key=lambda r: (order.get(r["vehicle"], len(order)), r["vehicle"], r["exit"],
                                          r["lateral_acceleration_bound_mps2"]))  # fmt: skip


def csv_text(records: list[dict]) -> str:
    """The records as CSV: the labels, then ``RECORD_KEYS`` (units in the names)."""
    names = ["preset", *RECORD_KEYS]
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=names, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(records)
    return out.getvalue()


def label(r: dict) -> str:
    """A manoeuvre's name in the figure and the text: the vehicle and its preset, the manoeuvre."""
    return f"{vehicle_name(r)}, {r['manoeuvre']}"


def vehicle_name(r: dict) -> str:
    """The vehicle as the text names it: its kind and preset."""
    return f"{TITLES.get(r['vehicle'], r['vehicle'])} {r.get('preset')}"


def figure(records: list[dict], stem: Path, formats: list[str]) -> None:
    """Two panels against the plan's largest lateral acceleration: deviation from the plan, clearance lost
    (model.plotting.studies.plant_gap_figure)."""
    shown = [(label(g[0]), MARKERS.get(key[0], "^"), g) for key, g in groups(records).items()]
    save(plant_gap_figure(shown), stem, formats)


def groups(records: list[dict]) -> dict[tuple[str, int], list[dict]]:
    """The records by manoeuvre (vehicle, exit), each in rising level."""
    out: dict[tuple[str, int], list[dict]] = {}
    for r in records:
        out.setdefault((r["vehicle"], r["exit"]), []).append(r)
    return out


def value(r: dict, key: str, digits: int = 3) -> str:
    """A record's number as the text prints it."""
    return fmt(r[key], digits)


def trend(group: list[dict]) -> str:
    """One sentence: a manoeuvre's deviation and clearance lost from its lowest to its highest validated level."""
    done = [r for r in group if r["plan_valid"] and r["clearance_lost_m"] is not None]
    failed = [r for r in group if not r["plan_valid"]]
    note = "" if not failed else " (no validated plan at " + ", ".join(
        f"{value(r, 'lateral_acceleration_bound_mps2')} m/s²: {r['status']}" for r in failed) + ")"  # fmt: skip
    if not done:
        return f"For the {label(group[0])} no level gave a validated plan{note}."
    lo, hi = done[0], done[-1]
    bound, speed = "lateral_acceleration_bound_mps2", "plan_max_speed_mps"
    deviation, lost = "plant_max_lateral_deviation_m", "clearance_lost_m"
    kinematic = max(r["kinematic_max_lateral_deviation_m"] for r in done)
    slip, friction = max(r["plant_max_side_slip_rad"] for r in done), max(r["plant_max_friction_use"] for r in done)
    return (
        f"For the {label(lo)}, from a bound of {value(lo, bound)} to {value(hi, bound)} m/s² (the plan's top speed "
        f"{value(lo, speed)} to {value(hi, speed)} m/s), the dynamic plant's largest lateral deviation from the plan "
        f"grows from {value(lo, deviation, 2)} to {value(hi, deviation, 2)} m (the kinematic plant's at most "
        f"{fmt(kinematic, 2)} m under the same controller) and the clearance lost from {value(lo, lost, 2)} to "
        f"{value(hi, lost, 2)} m, with side slip up to {fmt(slip, 2)} rad and friction use up to {fmt(friction, 2)}; "
        f"at the highest level the plant's lateral acceleration reaches "
        f"{value(hi, 'plant_max_lateral_acceleration_mps2')} m/s² where the plan's is "
        f"{value(hi, 'plan_max_lateral_acceleration_mps2')}{note}."
    )


def verdict(group: list[dict], unsafe: dict | None) -> str:
    """One sentence: where the manoeuvre's kinematic plan stops being safe on the dynamic plant."""
    done = [r for r in group if r["plan_valid"] and r["clearance_lost_m"] is not None]
    bound = "lateral_acceleration_bound_mps2"
    if not done:
        return ""
    if unsafe is None:
        return (f"On the {done[0]['manoeuvre']} the {vehicle_name(done[0])} stays in its corridor on the dynamic plant "
                f"at every level up to {value(done[-1], bound)} m/s².")  # fmt: skip
    where = "already at the lowest level tested," if unsafe[bound] == done[0][bound] else "at"
    clearance = unsafe["plant_min_clearance_m"]
    why = f"its bodies leave the corridor by {fmt(-clearance, 2)} m" if clearance < 0 else "it misses the goal"
    return (
        f"On the {unsafe['manoeuvre']} the {vehicle_name(unsafe)}'s kinematic plan stops being safe {where} "
        f"{value(unsafe, bound)} m/s² (top speed "
        f"{value(unsafe, 'plan_max_speed_mps')} m/s): {why} on the dynamic plant, where the plan keeps "
        f"{value(unsafe, 'plan_min_clearance_m', 2)} m and the kinematic plant "
        f"{value(unsafe, 'kinematic_min_clearance_m', 2)} m."
    )


def caption(records: list[dict], study: str) -> str:
    """The table's caption: what its rows and columns are, their units in the headers."""
    levels = ", ".join(fmt(v, 3) for v in sorted({r["lateral_acceleration_bound_mps2"] for r in records}))
    return (
        f"Table: Every manoeuvre of the `{study}` grid, one row per vehicle, manoeuvre and bound of the lateral "
        f"acceleration ({levels} m/s²): the plan (its status, grid N, final time Tf, top speed, largest lateral "
        f"acceleration and least clearance), the least clearance and the largest lateral deviation from the plan on "
        f"the kinematic and the dynamic plant, the clearance lost, the dynamic plant's largest side slip, lateral "
        f"acceleration and friction use, its distance from the goal, and whether the plan is safe; units in the "
        f"headers, numbers to {TABLE_DIGITS} significant digits."
    )


def section(records: list[dict], study: str, figure_path: str) -> str:
    """The paper's section: what ran, the trends, where the plan stops being safe, the table, the caveats."""
    levels = sorted({r["lateral_acceleration_bound_mps2"] for r in records})
    intervals = sorted({r["intervals"] for r in records if r["intervals"] is not None})
    unsafe = first_unsafe(records)
    by = groups(records)
    body = [
        "## Where the kinematic plan holds",
        "",
        f"The time-optimal plans of the road sections come from the kinematic model. Here the same manoeuvres "
        f"({'; '.join(label(g[0]) for g in by.values())}; each vehicle at its operational limits) are planned at "
        f"rising bounds of the lateral acceleration ({', '.join(fmt(v, 3) for v in levels)} m/s²; the "
        f"`{study}` grid of `plant_study` in workflows/config.yaml, the plans solved on N = "
        f"{', '.join(str(n) for n in intervals)} after the solve's own refinement), and each plan is driven by "
        f"the tracking controller (time-varying LQR on the kinematic model) twice: on the kinematic plant, which "
        f"is what the plan promises, and on the dynamic plant (CommonRoad's single-track model [@commonroadvehicles] "
        f"for the rigid truck, "
        f"a yaw-plane tractor-semitrailer for the articulated one; docs/closed-loop-format.md). The clearance is "
        f"the bodies' least distance to the corridor's edge over the samples (exact rectangles); the clearance "
        f"lost is the kinematic plant's minus the dynamic plant's. A plan is safe when the dynamic plant keeps "
        f"its bodies in the corridor and reaches the goal.",
        "",
        *[trend(g) for g in by.values()],
        "",
        *[verdict(g, unsafe[k]) for k, g in by.items()],
        "",
        f"![Lateral deviation from the plan and clearance lost on the dynamic plant against the plan's largest "
        f"lateral acceleration]({figure_path})",
        "",
        caption(records, study),
        "",
        table(records, COLUMNS, digits=TABLE_DIGITS),
        "",
        "Caveats: the tyres are linear (no saturation: the friction use is reported, not limited) and the "
        "semitrailer's plant has no load transfer; the tractor-semitrailer plant is checked against the "
        "single-track model and the kinematic model in their limits, not against published measurements; the "
        "plant's parameters are the presets' (docs/closed-loop-format.md), not a particular vehicle's; one "
        "controller (tracking) drives every plan, and a controller that re-plans on the measured state (the MPC) "
        "may lose less.",
    ]
    return "\n".join(body)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cells", type=Path, nargs="+", required=True, help="the manoeuvres' JSON files")
    ap.add_argument("--study", required=True, help="the grid's name (small, full)")
    ap.add_argument("--out", type=Path, required=True, help="folder of table.csv, table.md and the figure")
    ap.add_argument("--figure-link", required=True, help="the figure's PNG as the paper links it")
    ap.add_argument("--formats", nargs="+", default=["png", "pdf"])
    ap.add_argument("--section", type=Path, required=True)
    args = ap.parse_args()
    records = read_records(args.cells)
    write_text(args.out / "table.csv", csv_text(records))
    write_text(args.out / "table.md", table(records, COLUMNS, digits=TABLE_DIGITS))
    figure(records, args.out / "plant-gap", args.formats)
    write_text(args.section, section(records, args.study, args.figure_link))


if __name__ == "__main__":
    main()
