"""The paper's section "MPC versus the Pontryagin optimum" from the closed-loop study's row.json files.

Every number of the section comes from the rows (workflows/scripts/closed_loop_runs.py): which
settings were run, one table per geometry, two figures (final position error against the
disturbance level per controller; the closed-loop paths under the level-1 disturbance on the
scene) and findings computed from the numbers.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from model.plotting.figures import ENERGY_UNIT, PALETTE, apply_style, save  # noqa: E402

CONTROLLERS = ("open-loop", "tracking", "mpc")
COLORS = {"open-loop": PALETTE[3], "tracking": PALETTE[2], "mpc": PALETTE[0]}
# two tables per geometry, one value per cell: header -> how to write the cell from a row
ACCURACY = {
    "level": lambda r: f"{r['level']:g}",
    "controller": lambda r: r["controller"],
    "runs": lambda r: str(r["numbers"]["runs"]),
    "reached": lambda r: f"{r['numbers']['reach_rate']:.0%}",
    "position error mean (m)": lambda r: fmt(r["numbers"].get("position_error_mean")),
    "worst (m)": lambda r: fmt(r["numbers"].get("position_error_worst")),
    "heading error mean (rad)": lambda r: fmt(r["numbers"].get("heading_error_mean")),
    "worst (rad)": lambda r: fmt(r["numbers"].get("heading_error_worst")),
    "within position tol.": lambda r: criterion(r, "position"),
    "within heading tol.": lambda r: criterion(r, "heading"),
    "no failed step": lambda r: criterion(r, "steps"),
}
EFFORT = {
    "level": lambda r: f"{r['level']:g}",
    "controller": lambda r: r["controller"],
    "energy / optimum mean": lambda r: fmt(r["numbers"].get("energy_ratio_mean"), 4),
    "worst": lambda r: fmt(r["numbers"].get("energy_ratio_worst"), 4),
    "objective / optimum mean": lambda r: fmt(r["numbers"].get("objective_ratio_mean"), 4),
    "objective worst": lambda r: fmt(r["numbers"].get("objective_ratio_worst"), 4),
    "runs with clearance < 0": lambda r: fmt(r["numbers"]["violations"]),
    "min clearance (m)": lambda r: fmt(r["numbers"]["min_clearance"], 3),
    "step mean (ms)": lambda r: milliseconds(r["numbers"]["step_seconds_mean"]),
    "step max (ms)": lambda r: milliseconds(r["numbers"]["step_seconds_max"]),
    "realtime factor": lambda r: fmt(r["numbers"]["realtime_factor"], 2),
    "failed steps": lambda r: str(r["numbers"]["failed_steps"]),
}


def fmt(x, digits: int = 3) -> str:
    """A number for a table: significant digits, '-' for missing."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return str(x) if isinstance(x, int) else f"{x:.{digits}g}"


def milliseconds(seconds: float | None) -> str:
    """A step time in milliseconds: whole ones from 10 ms, else 2 significant digits; '-' for missing."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    value = 1e3 * seconds
    return f"{value:.0f}" if value >= 10 else f"{value:.2g}"


def criterion(row: dict, part: str) -> str:
    """How many of the runs meet one part of the goal criterion (position, heading, steps): '2 of 3'."""
    c = row.get("criteria")
    if not c or c.get(part) is None:
        return "-"
    return f"{c[part]} of {c['runs']}"


def run_summaries(folder: Path) -> list[dict]:
    """The setting's runs: runs.csv (several runs), else the one run's summary.json; [] if neither exists."""
    if (folder / "runs.csv").exists():
        return pd.read_csv(folder / "runs.csv").to_dict("records")
    return [json.loads((folder / "summary.json").read_text())] if (folder / "summary.json").exists() else []


def criteria(row: dict) -> dict | None:
    """Per part of the goal criterion (position tolerance, heading tolerance, no failed step), the runs meeting it."""
    tol, runs = row.get("goal_tolerance") or {}, run_summaries(Path(row["dir"]))
    if not runs or tol.get("position") is None:
        return None

    def count(ok) -> int:
        return sum(1 for r in runs if ok(r))

    heading = "theta" in (tol.get("angle_states") or [])
    return {
        "runs": len(runs),
        "position": count(lambda r: r["final_position_error"] <= tol["position"]),
        "heading": count(lambda r: r["final_heading_error"] <= tol["angle"]) if heading else None,
        "steps": count(lambda r: int(r["failed_steps"]) == 0),
    }


def load_rows(paths: Sequence[Path]) -> list[dict]:
    """Each row.json with its folder (``dir``) and its runs' ``criteria``; rows whose optimum failed keep
    ``numbers`` None."""
    rows = []
    for p in paths:
        row = json.loads(Path(p).read_text())
        row["dir"] = str(Path(p).parent)
        row["criteria"] = criteria(row) if row.get("numbers") else None
        rows.append(row)
    return rows


def geometries(rows: list[dict]) -> list[str]:
    """The geometries in the order they first appear."""
    return list(dict.fromkeys(r["geometry"] for r in rows))


def of(rows: list[dict], geometry: str) -> list[dict]:
    """A geometry's rows sorted by level, then controller."""
    order = {c: i for i, c in enumerate(CONTROLLERS)}
    mine = [r for r in rows if r["geometry"] == geometry]
    return sorted(mine, key=lambda r: (r["level"], order.get(r["controller"], 9)))


def find(rows: list[dict], geometry: str, level: float, controller: str) -> dict | None:
    for r in rows:
        if (r["geometry"], r["level"], r["controller"]) == (geometry, level, controller) and r["numbers"]:
            return r
    return None


def disturbance_text(d: dict) -> str:
    """A level-1 disturbance in words (from the row's disturbance)."""
    parts = [
        f"speed gain {d['speed_gain']:g}",
        f"steering bias {d['steering_bias']:g} rad",
        f"drift ({d['drift'][0]:g}, {d['drift'][1]:g}) m/s",
    ]
    parts += [f"true {k} {v:g} m" for k, v in d["wheelbase"].items()]
    parts += [f"delay {d['delay']:g} s", f"position noise {d['noise']:g} m (heading {d['noise'] / 10:g} rad)"]
    return ", ".join(parts)


def settings_text(rows: list[dict], study: str) -> list[str]:
    """Which settings were run, read from the rows."""
    lines = [
        f"Study grid **{study}** (config `closed_loop_study`; the heavier grid: "
        "`snakemake -c2 --config closed_loop_study=full`); settings run:",
        "",
    ]
    for g in geometries(rows):
        mine = of(rows, g)
        first = mine[0]
        levels = ", ".join(f"{lv:g}" for lv in sorted({r["level"] for r in mine}))
        ctrls = ", ".join(dict.fromkeys(r["controller"] for r in mine))
        runs = sorted({r["numbers"]["runs"] for r in mine if r["numbers"]})
        weights = f", weights {first['weights']}" if first.get("weights") else ""
        lines.append(
            f"- **{g}** ({first['title']}; {first['objective']}{weights}; sample time {first['sample_time']:g} s, "
            f"MPC horizon {first['horizon']}): levels {levels}; controllers {ctrls}; runs per setting "
            f"{', '.join(map(str, runs))}. Level 1: {disturbance_text(first['level1_disturbance'])}."
        )
    return [*lines, ""]


def columns(first: dict) -> dict:
    """The effort table's columns: the objective's ratio only when it is not the plain energy (weights, time)."""
    plain = first["objective"] == "energy" and not first.get("weights")
    return {k: v for k, v in EFFORT.items() if not (plain and k.startswith("objective"))}


def head(geometry: str, first: dict) -> str:
    """The line above a geometry's table: the optimum, the goal tolerance, what clearance is measured to."""
    opt, tol = first["optimum"], first.get("goal_tolerance") or {}
    cert = "certified (PMP)" if opt.get("certified") else "not certified"
    keep_out = (
        f"; clearance to the keep-out circle (obstacle radius + safety margin {fmt(first['safety'])} m: "
        "a negative clearance above minus the margin is inside the margin, not a collision)"
        if first.get("safety") is not None
        else ""
    )
    return (
        f"**{geometry}**: {first['title']}. Open-loop optimum: objective {fmt(opt['objective'], 6)}, energy "
        f"{fmt(opt['energy'], 6)} ({ENERGY_UNIT}), Tf {fmt(opt['final_time'], 4)} s, {cert}; {goal_text(tol)}"
        f"{keep_out}."
    )


def goal_text(tol: dict) -> str:
    """The goal criterion of the *reached* column, from the row's goal tolerance."""
    angles = tol.get("angle_states")
    names = " and ".join({"theta": "heading θ", "phi": "steering φ"}.get(a, a) for a in angles) if angles else "angle"
    return (
        f"a run *reached* the goal if its final position error is at most {fmt(tol.get('position'), 3)} m AND its"
        f" final {names} error at most {fmt(tol.get('angle'), 2)} rad, with no failed controller step (both tolerances"
        " are drawn in the error figure)"
    )


def pipe_table(rows: list[dict], cols: dict) -> list[str]:
    """A pipe table: one row per closed-loop setting, one cell per column."""
    head_ = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    return head_ + ["| " + " | ".join(cell(r) for cell in cols.values()) + " |" for r in rows]


def table(rows: list[dict], geometry: str) -> list[str]:
    """A geometry's head line and its two captioned tables: accuracy, then cost and computing effort."""
    mine = [r for r in of(rows, geometry) if r["numbers"]]
    first = (mine or of(rows, geometry))[0]
    lines = [
        head(geometry, first),
        "",
        f"Table: {geometry}, accuracy: per disturbance level and controller, the runs, the share that reached the"
        " goal, the final position error (m) and heading error (rad), mean and worst over the runs, and how many"
        " runs meet each part of the goal criterion.",
        "",
        *pipe_table(mine, ACCURACY),
        "",
        f"Table: {geometry}, cost and effort: the energy (and, for a weighted objective, the objective) of the"
        " applied controls over the open-loop optimum's, mean and worst; the runs whose clearance went below zero"
        " and the smallest clearance (m); one controller call's wall-clock time (ms), mean and largest; the"
        " realtime factor (largest step over the sample time) and the failed steps.",
        "",
        *pipe_table(mine, columns(first)),
    ]
    failed = [r for r in of(rows, geometry) if not r["numbers"]]
    lines += [f"\n(level {r['level']:g}, {r['controller']}: the open-loop solve failed)" for r in failed]
    return [*lines, ""]


def errors_figure(rows: list[dict], stem: Path, formats: Sequence[str]) -> None:
    """Final position and heading error per disturbance level (model.plotting.closed_loop.errors_figure)."""
    from model.plotting.closed_loop import errors_figure as draw_errors

    save(draw_errors(rows, COLORS), stem, formats)


def path_level(rows: list[dict], geometry: str) -> float | None:
    """The level drawn in the path figure: 1 if run, else the largest."""
    levels = sorted({r["level"] for r in of(rows, geometry) if r["numbers"]})
    return 1.0 if 1.0 in levels else (levels[-1] if levels else None)


def scene(scenario: Path | None):
    """The geometry's problem (its obstacles or road are drawn); None if the scenario file is missing."""
    if scenario is None or not scenario.exists():
        return None
    from model.problem.scenario import load_scenario

    return load_scenario(scenario).ocp


def path_panel(rows: list[dict], geometry: str, scenario_dir: Path | None) -> dict:
    """The optimum and each controller's first run at the path level, read from the runs' folders."""
    level = path_level(rows, geometry)
    panel = {"title": f"{geometry}, level {fmt(level)} (first run)", "optimum": None, "runs": {},
             "ocp": scene(scenario_dir / f"{geometry}.toml" if scenario_dir else None)}  # fmt: skip
    for c in CONTROLLERS:
        r = find(rows, geometry, level, c) if level is not None else None
        if r is None or not (Path(r["dir"]) / "closed_loop.csv").exists():
            continue
        optimum = Path(r["dir"]) / "optimum" / "trajectory.csv"
        if panel["optimum"] is None and optimum.exists():
            panel["optimum"] = pd.read_csv(optimum)
        panel["runs"][c] = pd.read_csv(Path(r["dir"]) / "closed_loop.csv")
    return panel


def paths_figure(rows: list[dict], scenario_dir: Path | None, stem: Path, formats: Sequence[str]) -> None:
    """Reference optimum and each controller's first run at level 1, on the scene, one panel per geometry
    (model.plotting.closed_loop.paths_figure)."""
    from model.plotting.closed_loop import paths_figure as draw_paths

    shown = [g for g in geometries(rows) if len({r["controller"] for r in of(rows, g)}) > 1] or geometries(rows)
    save(draw_paths([path_panel(rows, g, scenario_dir) for g in shown], COLORS), stem, formats)


def ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b else None


def closeness(g: str, top: float, ol: dict, tr: dict | None, mpc: dict) -> str:
    """MPC's and tracking's final position error against the open-loop replay's, and MPC's reach rate."""
    n_ol, n_mpc = ol["numbers"], mpc["numbers"]
    k = ratio(n_ol["position_error_mean"], n_mpc["position_error_mean"])
    t = ratio(n_ol["position_error_mean"], tr["numbers"]["position_error_mean"]) if tr else None
    worst = ratio(n_mpc["position_error_worst"], n_ol["position_error_worst"])
    return (
        f"On **{g}** at level {top:g}, MPC ends {fmt(k, 3)} times closer to the goal than the open-loop "
        f"replay on average (tracking: {fmt(t, 3)} times; MPC's worst run ends at {fmt(worst, 2)} of the "
        f"open loop's worst error), reaching the goal in {n_mpc['reach_rate']:.0%} of the runs (open loop "
        f"{n_ol['reach_rate']:.0%}, tracking {tr['numbers']['reach_rate'] if tr else 0:.0%})."
    )


def compute(g: str, rows: list[dict]) -> str:
    """MPC's realtime factor and failed steps over the geometry."""
    mine = [r for r in of(rows, g) if r["controller"] == "mpc" and r["numbers"]]
    if not mine:
        return ""
    failed = sum(r["numbers"]["failed_steps"] for r in mine)
    steps = sum(r["numbers"].get("steps") or 0 for r in mine)
    return (
        f"MPC's worst realtime factor on **{g}** is {fmt(max(r['numbers']['realtime_factor'] for r in mine), 2)} "
        f"(sample {mine[0]['sample_time']:g} s); {failed} of its {steps} steps failed or hit the wall-time budget of"
        " Ipopt [@ipopt] and followed the previous plan (a failed step counts as not reaching the goal)."
    )


def findings(rows: list[dict]) -> list[str]:
    """Sentences computed from the numbers: closeness against open loop, undisturbed energy, real time."""
    out = []
    for g in geometries(rows):
        top = max((r["level"] for r in of(rows, g) if r["numbers"]), default=None)
        ol, tr, mpc = (find(rows, g, top, c) for c in CONTROLLERS)
        if ol and mpc:
            out.append(closeness(g, top, ol, tr, mpc))
        out += undisturbed(rows, g)
        out.append(compute(g, rows))
    return [s for s in out if s]


WHY = "the held controls and the MPC's own horizon grid differ from the optimum's N nodes"


def undisturbed(rows: list[dict], geometry: str) -> list[str]:
    """The level-0 energy of MPC against the optimum (the 1 % criterion), with the hold's own share."""
    mpc, ol = find(rows, geometry, 0.0, "mpc"), find(rows, geometry, 0.0, "open-loop")
    if not mpc:
        return []
    e = mpc["numbers"]["energy_ratio_mean"] - 1
    verdict = "within" if abs(e) <= 0.01 else "not within"
    hold = (f"; the open-loop replay of the same optimum under the {mpc['sample_time']:g} s zero-order hold "
            f"alone is at {100 * (ol['numbers']['energy_ratio_mean'] - 1):+.2f} %") if ol else ""  # fmt: skip
    why = "" if abs(e) <= 0.01 else f" ({WHY})"
    return [
        f"Undisturbed (**{geometry}**, level 0), MPC's energy is {100 * e:+.2f} % of the optimum's, "
        f"{verdict} 1 %{hold}{why}; final position error {fmt(mpc['numbers']['position_error_mean'])} m."
    ]


def section(rows: list[dict], study: str, figures: Path | None) -> str:
    lines = [
        "## MPC versus the Pontryagin optimum (closed loop)",
        "",
        "The plant differs from the model (docs/closed-loop-format.md: speed gain, steering bias, drift, "
        "true wheelbase, actuator delay, seeded measurement noise); three controllers drive it: the "
        "optimum's controls replayed (open loop), a time-varying LQR tracking the optimal trajectory, and "
        "NMPC re-solving the scenario's own OCP with Ipopt [@ipopt] from the measured state at every sample, "
        "warm-started. A "
        "level scales the geometry's level-1 disturbance (0: the model itself). Energies are the "
        f"unweighted ½∫(u1² + u2²) dt ({ENERGY_UNIT}) of the applied controls against that of the open-loop "
        "optimum; clearances are over the samples; step times are wall-clock seconds of one controller "
        "call (realtime factor: the worst step over the sample time). Written by "
        "workflows/scripts/closed_loop_section.py from results/closed-loop.",
        "",
        *settings_text(rows, study),
    ]
    for g in geometries(rows):
        lines += table(rows, g)
    lines += ["**Findings.** " + " ".join(findings(rows)), ""]
    if figures is not None:
        lines += [
            f"![Final position error (top) and final heading error (bottom) at each disturbance level, one marker per"
            f" controller (the mean over the runs, a bar up to the worst run; log scale; the levels are separate"
            f" experiments, not joined); each goal tolerance dashed: a run reaches the goal only below both (and with"
            f" no failed step)]({(figures / 'errors.png').as_posix()})",
            "",
            f"![Closed-loop paths under the level-1 disturbance (first run) on the scene: the open-loop "
            f"optimum (reference) and the three controllers]({(figures / 'paths.png').as_posix()})",
            "",
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=Path, nargs="+", required=True)
    ap.add_argument("--scenario-dir", type=Path, help="the geometries' TOML files (for the scene)")
    ap.add_argument("--study", default="small")
    ap.add_argument("--figures", type=Path, help="folder of errors.* and paths.* (none: no figures)")
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    rows = load_rows(args.rows)
    if args.figures is not None:
        apply_style()
        errors_figure(rows, args.figures / "errors", args.formats)
        paths_figure(rows, args.scenario_dir, args.figures / "paths", args.formats)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(section(rows, args.study, args.figures))


if __name__ == "__main__":
    main()
