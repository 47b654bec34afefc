"""Road study (c): the energy-time trade-off on a real roundabout (the paper's energy- vs time-optimal comparison).

The scenario's minimum time T_min first, then the energy-optimal problem at fixed final times
ratio x T_min, each started from the previous solution (the first from the time-optimal one).
Every solve is validated with the exact rectangles in the exact corridor; a failed solve is a
row marked failed and is neither plotted nor counted as a point of the trade-off.

The trade-off is that of the seed paper's model (the speed u1 a control, J = 1/2 int u1^2 + u2^2 dt): its rows
are the kinematic model without operational limits, and each says so beside its largest lateral acceleration and
the preset's allowed one (model.studies.roads.limits_note). Beside them, the same turn's minimum time at the
preset's operational limits (model.studies.roads.operational_document; ``--no-operational-reference``: not solved).
"""

from __future__ import annotations

import argparse
import copy
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
from studies_common import fmt, parser, table, write_json, write_text

from model.plotting.figures import ENERGY_UNIT, save
from model.plotting.studies import path_spread, tradeoff_figure
from model.problem.scenario import load_scenario, parse_scenario
from model.studies.roads import (
    apron_used,
    limits_cell,
    limits_note,
    operational_document,
    operational_text,
    preset_citation,
    reference_preset,
    swept_width,
)
from model.studies.sweeps import as_energy


def record(sol, ratio: float | None, objective: str) -> dict:
    measures = sol.validation.get("measures", {})
    cols = sol.columns
    return {
        "objective": objective,
        "ratio": ratio,
        "final_time": sol.final_time,
        "status": sol.status,
        "valid": bool(sol.ok),
        "energy": sol.energy,
        "iterations": sol.iterations,
        "solve_seconds": sol.solve_seconds,
        "max_speed": float(np.max(np.abs(cols["u1"]))),
        "mean_speed": float(np.trapezoid(np.abs(cols["u1"]), cols["t"]) / cols["t"][-1]),
        "max_steering_rate": float(np.max(np.abs(cols["u2"]))),
        "path_length": float(np.trapezoid(np.abs(cols["u1"]), cols["t"])),
        "speed_share": float(np.trapezoid(0.5 * cols["u1"] ** 2, cols["t"]) / sol.energy) if sol.energy else None,
        "min_clearance": measures.get("min_clearance"),
        "min_clearance_dense": measures.get("min_clearance_dense"),
        "max_abs_lateral_acceleration": (measures.get("lateral_acceleration") or {}).get("max_abs_nodes"),
        "apron_used_m": apron_used(sol.ocp, cols) if sol.ok else None,
        "swept_width_m": swept_width(sol.ocp, cols) if sol.ok else None,
        "diagnosis": (sol.diagnosis or {}).get("message") if not sol.ok else None,
    }


def operational_reference(scenario: Path, intervals: int) -> dict | None:
    """The scenario's minimum time at its preset's operational limits (None without a preset): Tf, the largest
    lateral acceleration and the acceleration's range at the nodes, validity, wall seconds."""
    doc = tomllib.loads(scenario.read_text())
    preset_name = doc.get("vehicle", {}).get("preset")
    if not preset_name:
        return None
    doc = operational_document(copy.deepcopy(doc), preset_name)
    sol = parse_scenario(doc, path=scenario).ocp.solve(intervals=intervals)
    measures = sol.validation.get("measures", {})
    lon = measures.get("longitudinal") or {}
    return {"preset": preset_name, "valid": bool(sol.ok), "status": sol.status, "final_time": sol.final_time,
            "intervals": sol.intervals, "solve_seconds": sol.solve_seconds,
            "max_abs_lateral_acceleration": (measures.get("lateral_acceleration") or {}).get("max_abs_nodes"),
            "acceleration": [lon.get("min_acceleration"), lon.get("max_acceleration")],
            "initial_speed": doc["initial"]["v"], "speed_bound": doc["bounds"].get("v"),
            "diagnosis": (sol.diagnosis or {}).get("message") if not sol.ok else None}  # fmt: skip


def reference_lines(ref: dict | None, tmin: dict) -> list[str]:
    """The paragraph on the operational minimum time beside the rows without limits (nothing without one)."""
    if ref is None:
        return []
    head = (f"Every row above is the seed paper's kinematic model **without operational limits** (the speed u1 a "
            f"control that may jump; J needs it as a control), labelled in its *limits* column. At the preset's "
            f"operational limits ({operational_text(ref['preset'])}; v in [{ref['speed_bound'][0]:g}, "
            f"{ref['speed_bound'][1]:g}] m/s, the scenario's bound of u1) the same turn's minimum time")  # fmt: skip
    if not ref["valid"]:
        return [f"{head} FAILED: {ref['diagnosis'] or ref['status']}.", ""]
    lo, hi = ref["acceleration"]
    return [f"{head} is {fmt(ref['final_time'], 5)} s (N = {ref['intervals']}; reached: max lateral acceleration "
            f"{ref['max_abs_lateral_acceleration']:.2f} m/s², a in [{lo:.2f}, {hi:.2f}] m/s²), against T_min = "
            f"{fmt(tmin['final_time'], 5)} s without them.", ""]  # fmt: skip


def figure(ocp, rows: list[dict], trajectories: dict, out: Path, formats: list[str]) -> None:
    """The trade-off figure (model.plotting.studies.tradeoff_figure)."""
    save(tradeoff_figure(ocp, rows, trajectories), out / "tradeoff", formats)


def length_range(rows: list[dict]) -> str:
    """The rear-axle path lengths of ``rows`` in words: one value if they agree to 5 digits, else the range."""
    lo, hi = (fmt(f(r["path_length"] for r in rows), 5) for f in (min, max))
    return f"is {lo} m in every solve (to 5 digits)" if lo == hi else f"stays between {lo} and {hi} m"


def findings(tmin: dict, ok: list[dict], failed: list[dict], spread: float | None) -> str:
    """The trade-off in words: the energy saved, monotonicity, and why (the same path, driven slower)."""
    jt, last, unit = tmin["energy"], ok[-1], f"({ENERGY_UNIT})"
    mono = all(b["energy"] < a["energy"] for a, b in zip(ok[:-1], ok[1:], strict=False))
    apart = "" if spread is None else f" and every path lies within {spread:.2g} m of the time-optimal one (Hausdorff)"
    return (
        f"The time-optimal manoeuvre takes T_min = {fmt(tmin['final_time'], 5)} s and spends J = {fmt(jt, 5)} {unit};"
        f" at {fmt(ok[0]['ratio'], 3)} T_min the energy-optimal one spends {fmt(ok[0]['energy'], 5)} {unit}"
        f", {fmt(100 * (1 - ok[0]['energy'] / jt), 3)} % less; at {fmt(last['ratio'], 3)} T_min"
        f" {fmt(last['energy'], 5)} {unit}, {fmt(100 * (1 - last['energy'] / jt), 3)} % less. J decreases"
        f" {'monotonically' if mono else 'NOT monotonically'} with Tf over the points computed"
        + (f"; {len(failed)} solve(s) failed and are left out." if failed else ".")
        + f" The rear-axle path length {length_range([tmin, *ok])}{apart}, so the figure's paths coincide; the"
        f" speed profiles differ. The speed term 1/2 int u1^2 makes"
        f" {fmt(100 * min(r['speed_share'] for r in [tmin, *ok]), 4)} % or more of J, so J is close to its bound"
        " P^2 / (2 Tf) for a path of length P (Cauchy-Schwarz): J / (P^2 / (2 Tf)) = "
        + ", ".join(f"{fmt(r['energy'] / (r['path_length'] ** 2 / (2 * r['final_time'])), 4)}" for r in ok)
        + " at the fixed final times: slowing down, not a different path, is what saves the energy."
    )


# the tables' number formats: times to 0.01 s, J to 4 significant digits, speeds to 0.01 m/s, lengths to 1 mm
FORMATS = {"ratio": ".3g", "final_time": ".2f", "energy": "#.4g", "max_speed": ".2f", "mean_speed": ".2f",
           "speed_share": ".4f", "path_length": ".2f", "apron_used_m": ".3f", "swept_width_m": ".3f",
           "min_clearance": ".3f"}  # fmt: skip


def shown_rows(rows: list[dict], preset: str | None) -> list[dict]:
    """The solves as the tables print them (``FORMATS``), with their status and limits cell."""
    out = []
    for r in rows:
        cells = {k: format(v, FORMATS[k]) if k in FORMATS and isinstance(v, float) else v for k, v in r.items()}
        status = "valid" if r["valid"] else f"FAILED: {r['diagnosis'] or r['status']}"
        lateral = limits_cell(preset, False, r.get("max_abs_lateral_acceleration")) if preset else None
        out.append(cells | {"ratio": cells["ratio"] or "1", "status": status, "limits": lateral})
    return out


def row_limits(rows: list[dict], preset: str | None) -> list[str]:
    """Each row's limits note in full (``limits_note``: the table's limits cell in words); none without a preset."""
    if not preset:
        return []
    items = [f"- {r['objective']} at {r['ratio'] or 1:g} T_min: "
             f"{limits_note(preset, False, r.get('max_abs_lateral_acceleration'))}." for r in rows]  # fmt: skip
    return ["The limits of each row:", "", *items, ""]


def solve_tables(rows: list[dict], preset: str | None) -> list[str]:
    """The solves in two captioned tables: time and energy; the path, the apron, the clearance and the limits."""
    shown = shown_rows(rows, preset)
    first = {"objective": "objective", "ratio": "Tf / T_min", "final_time": "Tf (s)", "energy": f"J ({ENERGY_UNIT})",
             "max_speed": "max speed (m/s)", "mean_speed": "mean speed (m/s)", "speed_share": "share of J from u1",
             "iterations": "iterations", "status": "status"}  # fmt: skip
    second = {"objective": "objective", "ratio": "Tf / T_min", "path_length": "path (m)",
              "apron_used_m": "apron used (m)", "swept_width_m": "swept width (m)", "min_clearance": "clearance (m)",
              **({"limits": "limits (m/s²)"} if preset else {})}  # fmt: skip
    return [
        f"Table: The minimum-time solve and the energy-optimal solves at fixed multiples of its final time: Tf (s),"
        f" the energy J = ½∫(u1² + u2²) dt ({ENERGY_UNIT}), the largest and mean speed (m/s), the share of J"
        " from the speed term, Ipopt's iterations [@ipopt] and the validation.",
        "",
        table(shown, first),
        "",
        "Table: The same solves on the roundabout: the rear-axle path length, how far the bodies reach onto the"
        " apron, the swept width in the ring and the smallest clearance (m)"
        + (
            f"; limits: the kinematic model (*none*) with its largest lateral acceleration a_lat against the"
            f" {preset}'s allowed one (m/s²)."
            if preset
            else "."
        ),
        "",
        table(shown, second),
        "",
    ]


def section(ocp, rows: list[dict], fig: Path, intervals: int, spread: float | None = None,
            preset: str | None = None, reference: dict | None = None) -> str:  # fmt: skip
    """The section; ``preset``: whose limits each row is set beside; ``reference``: ``operational_reference``."""
    tmin = next(r for r in rows if r["objective"] == "time")
    en = [r for r in rows if r["objective"] == "energy"]
    ok = [r for r in en if r["valid"]]
    failed = [r for r in en if not r["valid"]]
    lines = [
        "## Energy against time on a real roundabout",
        "",
        f"The seed paper [@seed] compares an energy-optimal with a time-optimal trajectory around a disc. Here the"
        f" same comparison on a real roundabout: *{ocp.title}*"
        + f" ({f'the preset {preset_citation(preset)}; ' if preset else ''}workflows/scenarios/roads/{ocp.name}.toml;"
        " forward"
        f" driving only, the steering limit of the preset, N = {intervals}). First the minimum time T_min, then"
        " the energy-optimal problem at fixed final times, each started from the previous solution; every solve"
        " validated with the exact rectangles in the exact corridor.",
        "",
    ]
    if not tmin["valid"]:
        lines += [f"The minimum-time problem FAILED: {tmin['diagnosis'] or tmin['status']}; no trade-off is computed.",
                  ""]  # fmt: skip
        return "\n".join(lines)
    lines += solve_tables(rows, preset) + row_limits(rows, preset)
    lines += reference_lines(reference, tmin)
    if ok:
        lines += [findings(tmin, ok, failed, spread), ""]
    lines += [
        f"![The kinematic model without operational limits (each row's limits above): energy against the final time;"
        f" the rear-axle paths on the roundabout to scale (they coincide); the speed"
        f" and the steering rate against the normalised time t / Tf, where the solves differ]({fig})",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--scenario", type=Path, required=True)
    ap.add_argument("--ratios", type=float, nargs="+", default=[1.1, 1.25, 1.5, 2.0])
    ap.add_argument("--intervals", type=int, default=None)
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    ap.add_argument(
        "--operational-reference",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also solve the minimum time at the preset's operational limits (default)",
    )
    args = ap.parse_args()
    sc = load_scenario(args.scenario)
    ocp, n = sc.ocp, args.intervals or sc.intervals
    sol = ocp.solve(intervals=n)
    rows, trajectories = [record(sol, None, "time")], {}
    if sol.ok:
        trajectories["time"] = {k: np.asarray(v) for k, v in sol.columns.items()}
        guess = sol.trajectory
        for ratio in args.ratios:
            tf = ratio * sol.final_time
            esol = as_energy(ocp, tf).solve(intervals=n, guess=guess)
            rows.append(record(esol, ratio, "energy"))
            if esol.ok:
                guess = esol.trajectory
                trajectories[f"energy, {ratio:g} T_min"] = {k: np.asarray(v) for k, v in esol.columns.items()}
    reference = operational_reference(args.scenario, n) if args.operational_reference else None
    preset = reference_preset(args.scenario)[0]
    args.out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(args.out / "tradeoff.csv", index=False)
    spread = path_spread(trajectories, ocp.vehicle.position)
    write_json(args.out / "tradeoff.json", {"scenario": str(args.scenario), "intervals": n, "rows": rows,
                                            "path_spread_m": spread, "operational_reference": reference})  # fmt: skip
    figure(ocp, rows, trajectories, args.out, args.formats)
    write_text(args.section, section(ocp, rows, args.out / "tradeoff.png", n, spread, preset, reference))


if __name__ == "__main__":
    main()
