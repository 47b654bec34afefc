"""The paper's section on road scenarios: a table read from the results, and the figures."""

from __future__ import annotations

import argparse
import csv
import json
import os
from pathlib import Path

import numpy as np

from model.plotting.figures import ENERGY_UNIT
from model.plotting.roads import KMH, ROLE_PANELS, driving_label, steering_changes
from model.problem.ocp import OCP
from model.problem.scenario import load_scenario
from model.studies.roads import (
    DESIGN_SUFFIX,
    OPERATIONAL_SUFFIX,
    presets_cited,
    reference_preset,
    road_limits_cell,
    road_limits_note,
)


def read(scenario: Path, results: Path) -> tuple[OCP, dict, dict[str, np.ndarray]]:
    """The problem, its summary.json and the node columns of its trajectory.csv (empty for a failure)."""
    ocp = load_scenario(scenario).ocp
    s = json.loads((results / scenario.stem / "summary.json").read_text())
    with (results / scenario.stem / "trajectory.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    return ocp, s, {k: np.array([float(r[k]) for r in rows]) for k in (rows[0] if rows else {})}


def changes(ocp: OCP, cols: dict[str, np.ndarray]) -> int | None:
    """How often u2 changes sign (None without a trajectory)."""
    return steering_changes(ocp, cols) if "u2" in cols else None


def at_top_speed(ocp: OCP, cols: dict[str, np.ndarray]) -> float:
    """The share of the nodes (%) where u1 is within 1 % of its upper bound."""
    top = ocp.bounds["u1"][1]
    return 100.0 * float(np.mean(cols["u1"] >= top - 0.01 * abs(top)))


def driving(scenario: Path, ocp: OCP, math: bool = True) -> str:
    """How the road drives: at its preset's operational limits (the bound of v read from the problem), or as
    ``driving_label`` says (time-optimal, or at a design speed)."""
    preset_name, operational, _ = reference_preset(scenario)
    if not operational:
        return driving_label(ocp, math)
    top = ocp.bounds[ocp.vehicle.roles.speed][1] * KMH
    return f"time-optimal at the {preset_name}'s operational limits (speed at most {top:.0f} km/h)"


def lateral(s: dict, key: str) -> float | None:
    return (s.get("lateral_acceleration") or {}).get(key)


def fixed(value: float | None) -> str:
    """Three decimals (a bound of 2 m/s^2 reads 2.000 / 2.002), a dash for a missing value."""
    return "–" if value is None else f"{value:.3f}"


def objective_cell(scenario: Path, ocp: OCP) -> str:
    """The objective in a few words (``driving`` gives the whole of it, in the text and the captions)."""
    if reference_preset(scenario)[1]:
        return "min. time, operational limits"
    weight = float(getattr(ocp.cost, "steering_weight", 0.0) or 0.0)
    if weight or ocp.bounds.get("lateral_acceleration") is not None:
        return f"min. $T_f + {weight:g} \\int u_2^2 dt$, design speed" if weight else "min. time, design speed"
    return "min. time"


def setting_row(scenario: Path, results: Path) -> str:
    """The road's vehicle, route, objective and limits: one row of the setting table."""
    ocp, s, _ = read(scenario, results)
    bodies = " + ".join(f"{b.length:.2f} x {b.width:.2f}" for b in ocp.bodies.values())
    route = f"exit {ocp.road.route.exit} of {len(ocp.road.roundabout.legs)}"
    return (
        f"| {ocp.name} | {ocp.vehicle.model} | {bodies} | {route} | {objective_cell(scenario, ocp)} "
        f"| {road_limits_cell(scenario, s)} |"
    )


def metre(value: float | None) -> str:
    """A clearance to the millimetre, a dash for a missing value."""
    return "–" if value is None else f"{value:.3f}"


def result_row(scenario: Path, results: Path) -> str:
    """The road's solve: one row of the results table."""
    ocp, s, cols = read(scenario, results)
    count = changes(ocp, cols)
    ok = "valid" if s.get("valid") else f"FAILED ({(s.get('diagnosis') or {}).get('message', s.get('status'))})"
    return (
        f"| {ocp.name} | {fixed2(s.get('final_time'))} | {energy(ocp, s)} | {s.get('exit_taken')} "
        f"| {metre(s.get('min_clearance'))} | {metre(s.get('min_clearance_dense'))} "
        f"| {fixed(lateral(s, 'max_abs_nodes'))} | {fixed(lateral(s, 'max_abs_dense'))} "
        f"| {'–' if count is None else count} | {s.get('iterations')} | {ok} |"
    )


def fixed2(value: float | None) -> str:
    """A time to the hundredth of a second, a dash for a missing value."""
    return "–" if value is None else f"{value:.2f}"


def energy(ocp: OCP, s: dict) -> str:
    """The energy; with longitudinal dynamics it integrates other controls (a or j for u1), and says which."""
    if s.get("energy") is None:
        return "–"
    value = format(s["energy"], "#.4g")  # four significant digits, trailing zeros kept
    return value if ocp.vehicle.roles.acceleration is None else f"{value} ({', '.join(ocp.vehicle.controls)})"


def tables(scenarios: list[Path], results: Path) -> list[str]:
    """The setting table and the results table, each with its caption."""
    traffic = sorted({load_scenario(s).ocp.road.roundabout.traffic for s in scenarios})
    return [
        f"Table: The road scenarios: the vehicle, its bodies' length x width (m; tractor + trailer), the route"
        f" ({' and '.join(traffic)}-hand traffic), the objective and the limits (m/s$^2$): *held* at the preset's"
        " operational limits with the lateral acceleration a_lat and the acceleration a reached, or *none* (the"
        " kinematic model) with the largest a_lat against the preset's allowed one.",
        "",
        "| scenario | vehicle | bodies (m) | route | objective | limits (m/s$^2$) |",
        "|---|---|---|---|---|---|",
        *(setting_row(s, results) for s in scenarios),
        "",
        f"Table: The road scenarios solved: final time, energy ({ENERGY_UNIT}; for the operational rows of the"
        " controls named, not comparable), the exit taken, the smallest clearance at the nodes and between them"
        " (m, negative: an encroachment), the largest absolute lateral acceleration at the nodes and between them"
        " (m/s$^2$), the sign changes of the steering rate $u_2$, Ipopt's iterations [@ipopt] and the result.",
        "",
        "| scenario | Tf (s) | energy | exit taken | clearance nodes (m) | clearance between (m) "
        "| max abs. a_lat nodes (m/s$^2$) | between (m/s$^2$) | $u_2$ sign changes | iterations | result |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        *(result_row(s, results) for s in scenarios),
        "",
    ]


def held_presets(scenarios: list[Path]) -> list[str]:
    """The presets whose operational limits a road is solved at, in the order of the roads."""
    names = [reference_preset(p)[0] for p in scenarios if reference_preset(p)[1]]
    return list(dict.fromkeys(n for n in names if n))


def limited(scenarios: list[Path], results: Path) -> list[str]:
    """One sentence per road at operational limits beside the same route without them, every number read."""
    by_stem = {p.stem: p for p in scenarios}
    lines = []
    for stem, path in by_stem.items():
        base = by_stem.get(stem.removesuffix(OPERATIONAL_SUFFIX)) if stem.endswith(OPERATIONAL_SUFFIX) else None
        if base is None:
            continue
        (free, f, _), (held, h, _) = read(base, results), read(path, results)
        if not (f.get("valid") and h.get("valid")):
            continue
        lon = h.get("longitudinal") or {}
        lines.append(
            f"- {held.name} ({road_limits_note(path, h)}): $T_f$ = {h['final_time']:.2f} s, $a$ in "
            f"[{lon['min_acceleration']:.2f}, {lon['max_acceleration']:.2f}] m/s$^2$ at the nodes "
            f"([{lon['min_acceleration_dense']:.2f}, {lon['max_acceleration_dense']:.2f}] between them), the largest "
            f"absolute $a_{{lat}}$ {lateral(h, 'max_abs_dense'):.3f} m/s$^2$ between the nodes; {free.name} "
            f"without the limits: $T_f$ = {f['final_time']:.2f} s at a largest $a_{{lat}}$ of "
            f"{lateral(f, 'max_abs_nodes'):.2f} m/s$^2$."
        )
    if lines:
        lines = [
            "The same routes at the operational limits of the presets ("
            + presets_cited(held_presets(scenarios))
            + "; `[vehicle] operational = true`, docs/dynamics-format.md: the speed the state $v$, the "
            "acceleration and jerk bounded, the lateral acceleration and steering rate the preset's; the rigid "
            "truck of the operational rows is a preset, not the time-optimal rows' truck):",
            "",
            *lines,
            "",
        ]
    return lines


def comparison(scenarios: list[Path], results: Path) -> list[str]:
    """One sentence per design-speed road beside its time-optimal one, every number from the results."""
    by_stem = {p.stem: p for p in scenarios}
    lines = []
    for stem, path in by_stem.items():
        base = by_stem.get(stem.removesuffix(DESIGN_SUFFIX)) if stem.endswith(DESIGN_SUFFIX) else None
        if base is None:
            continue
        (fast, f, fc), (slow, d, dc) = read(base, results), read(path, results)
        if not (f.get("valid") and d.get("valid")):
            continue
        lines.append(
            f"- {fast.name}: time-optimal, $u_1$ is at its bound of {fast.bounds['u1'][1] * KMH:.0f} km/h on "
            f"{at_top_speed(fast, fc):.0f} % of the nodes and $u_2$ changes sign {changes(fast, fc)} times: "
            f"$T_f$ = {f['final_time']:.2f} s with a largest lateral "
            f"acceleration of {lateral(f, 'max_abs_nodes'):.2f} m/s$^2$. {slow.name} ({driving_label(slow)}): "
            f"$T_f$ = {d['final_time']:.2f} s (objective {d['objective']:.2f}), largest absolute $a_{{lat}}$ "
            f"{lateral(d, 'max_abs_nodes'):.3f} m/s$^2$ at the nodes and {lateral(d, 'max_abs_dense'):.3f} between "
            f"them (the re-integrated controls), $u_2$ changes sign {changes(slow, dc)} times."
        )
    if lines:
        lines = [
            "The time-optimal solves drive as fast as the bounds allow, with bang-bang steering rates; the "
            "design-speed solves of the same routes bound $u_1$ to the design speed (forward only), the signed "
            "lateral acceleration $a_{lat} = u_1^2 \\tan\\phi / d$ of the (tractor's) rear axle at every node and "
            "interval midpoint, and add the steering weight to the final time:",
            "",
            *lines,
            "",
        ]
    return lines


def panels_text(ocp) -> str:
    """The road figure's time panels in words (only those it draws for this vehicle)."""
    r = ocp.vehicle.roles
    names = [f"{ROLE_PANELS[role][0]} {name}" for role, name in (("speed", r.speed), ("acceleration", r.acceleration),
                                                                 ("jerk", r.jerk)) if name]  # fmt: skip
    names += ["steering rate u2", "steering angle phi"]
    if ocp.vehicle.lateral_acceleration is not None:
        names.append("lateral acceleration")
    if "articulation" in ocp.vehicle.outputs():
        names.append("articulation angle")
    return ", ".join(names[:-1]) + " and " + names[-1]


SUPPLEMENTARY_SECTION = "S9"
SUPPLEMENTARY_TITLE = "Road figures without operational limits"


def split_figures(scenarios: list[Path], supplementary: bool) -> tuple[list[Path], list[Path]]:
    """(main part, supplementary): the runs at operational limits keep their figure in the main part, the others'
    go to the supplementary material (all in the main part without one, or when no run is at the limits)."""
    limited = [s for s in scenarios if s.stem.endswith(OPERATIONAL_SUFFIX)]
    if not supplementary or not limited:
        return list(scenarios), []
    return limited, [s for s in scenarios if s not in limited]


def road_figure(s: Path, results: Path) -> list[str]:
    """A road's figure with its caption (its plan to scale and its time panels)."""
    ocp = load_scenario(s).ocp
    return [
        f"![{s.stem}: the plan to scale (curbs, hatched truck apron, central island, centre and "
        "give-way lines), each body's swept path outlined, the bodies along the path, the axle tracks; "
        f"right: {panels_text(ocp)} over time, their bounds dashed; "
        f"{driving(s, ocp, math=False)}; {note_of(s, results)}]"
        f"(results/figures/roads/{s.stem}.png)",
        "",
    ]


PAPER_DIR = "results/paper"  # the paper's folder: its links are relative to it


def animation(gif: Path, note: str = "") -> list[str]:
    """The paragraph linking the animated GIF (its first frame would repeat the road's figure); ``note``: its
    limits note."""
    return [
        f"An animation of `{gif.stem}` ([{gif.name}]({Path(os.path.relpath(gif, PAPER_DIR)).as_posix()}), "
        f"`{gif.as_posix()}` in the results) shows the "
        "vehicle driving its optimal trajectory, each body's swept path growing behind it and the rear axle's "
        "path ahead dotted" + (f"; {note}" if note else "") + ".",
        "",
    ]


def note_of(scenario: Path, results: Path) -> str:
    """The road's limits note from its summary.json."""
    return road_limits_note(scenario, json.loads((results / scenario.stem / "summary.json").read_text()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", type=Path, nargs="+", required=True)
    ap.add_argument("--results", type=Path, required=True)
    ap.add_argument("--animation", type=Path, help="a GIF of one road (results/figures/roads/<road>.gif)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--supplementary", type=Path, help="the fragment that takes the figures of the runs without "
                    "operational limits (the main part keeps those at the limits)")  # fmt: skip
    args = ap.parse_args()
    lines = [
        "## Real roundabouts and vehicle bodies",
        "",
        "Roundabouts with a ring, an apron, legs with entry and exit lanes and curb fillets "
        "(docs/roundabout-format.md); the vehicle's body is a rectangle (for a semitrailer, two), kept in the "
        "route's corridor by equal cover discs in the NLP and checked as exact rectangles against the exact "
        "corridor at every node. Clearances are the smallest distance from a body to the edge of its allowed "
        'region (negative: an encroachment); "between nodes" is measured on linearly interpolated states.',
        "",
        f"A road `<name>{OPERATIONAL_SUFFIX}` drives its route at the operational limits of its preset (the design "
        "vehicles' acceleration, braking, jerk, steering rate and allowed lateral acceleration, each with its source: "
        "docs/dynamics-format.md); the others are the kinematic model **without operational limits** (the speed a "
        "control that may jump), kept beside them as what they are: the *limits* column says, for every row, "
        "what it was held to and how far its lateral acceleration goes beyond what the preset allows.",
        "",
        *tables(args.scenarios, args.results),
        *comparison(args.scenarios, args.results),
        *limited(args.scenarios, args.results),
    ]
    main_part, others = split_figures(args.scenarios, args.supplementary is not None)
    for s in main_part:
        lines += road_figure(s, args.results)
    if others:
        names = ", ".join(f"`{s.stem}`" for s in others)
        lines += [f"The figures of {names} (without operational limits, or at a design speed) are in the "
                  f"supplementary material ({SUPPLEMENTARY_SECTION}).", ""]  # fmt: skip
        supplementary = [f"## {SUPPLEMENTARY_TITLE}", "",
                         "The road runs of the section on real roundabouts that are not at operational limits: the "
                         "kinematic model (the speed a control), time-optimal or at a design speed, each labelled "
                         "with its lateral acceleration against what its preset allows.", ""]  # fmt: skip
        for s in others:
            supplementary += road_figure(s, args.results)
        args.supplementary.parent.mkdir(parents=True, exist_ok=True)
        args.supplementary.write_text("\n".join(supplementary))
    elif args.supplementary is not None:
        args.supplementary.parent.mkdir(parents=True, exist_ok=True)
        args.supplementary.write_text(f"## {SUPPLEMENTARY_TITLE}\n\nEvery road run is at operational limits; "
                                      "its figure is in the main part.\n")  # fmt: skip
    if args.animation:
        animated = {s.stem: s for s in args.scenarios}.get(args.animation.stem)
        lines += animation(args.animation, note_of(animated, args.results) if animated else "")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))


if __name__ == "__main__":
    main()
