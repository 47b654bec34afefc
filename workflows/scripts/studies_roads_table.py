"""Road study (b): the table of design vehicles x roundabout sizes, from the cells' JSON files.

Writes table.csv, the figure (minimum time and swept width against the ICD; failed cells marked
as failed, never drawn as solutions) and the paper section, which states the grid that was run.
"""

from __future__ import annotations

import inspect
import json
import tomllib
from pathlib import Path

import pandas as pd
from studies_common import fmt, parser, plt, table, write_text
from studies_common import limits_paragraph as common_limits_paragraph

from model.plotting.figures import ENERGY_UNIT, save
from model.studies.roads import limits_cell, limits_note, presets_cited, swept_width


def load(cells: list[Path]) -> list[dict]:
    return [json.loads(p.read_text()) for p in cells]


def why(d: dict) -> str | None:
    """A refusal's diagnosis in a few words, saying whether it is a proof or evidence (a local solve's)."""
    if d.get("kind") == "proven bound":
        return f"proof: {d.get('message')}"
    if d.get("kind") == "time limit":
        limit = f"time limit ({d.get('time_limit_s'):g} s{' of CPU' if d.get('clock') == 'cpu' else ''})"
        before = why(d["before_the_limit"]) if d.get("before_the_limit") else None
        return f"{limit}; before it, {before}" if before else f"{limit}, no evidence yet"
    if d.get("body") and d.get("edge") and d.get("encroachment_m") is not None:  # what must give way, by how much
        return (f"evidence (minimal violation, a local solve): the {d['body']} crosses the {d['edge']} by "
                f"{d['encroachment_m']:.2f} m")  # fmt: skip
    return d.get("message")


def flat(c: dict) -> dict:
    t, e, m = c["time"], c.get("energy") or {}, c.get("measures") or {}
    d = {} if t["valid"] else (t.get("diagnosis") or {})
    diag = why(d) if d else None
    return {
        "preset": c["preset"],
        "icd": c["icd"],
        "apron": c["apron"],
        "apron_use": c["apron_use"],
        "intervals": c["intervals"],
        "feasible": bool(t["valid"]),
        "t_min": t["final_time"] if t["valid"] else None,
        "energy_tf": e.get("final_time_set"),
        "energy": e.get("energy") if e.get("valid") else None,
        "energy_status": None if not e else ("valid" if e.get("valid") else f"FAILED: {e.get('status')}"),
        "apron_used_m": m.get("apron_used_m"),
        "swept_width_m": m.get("swept_width_m"),
        "min_clearance": t.get("min_clearance") if t["valid"] else None,
        "diagnosis": diag,
        "diagnosis_body": (t.get("diagnosis") or {}).get("body") if not t["valid"] else None,
        "diagnosis_edge": (t.get("diagnosis") or {}).get("edge") if not t["valid"] else None,
        "diagnosis_m": (t.get("diagnosis") or {}).get("encroachment_m") if not t["valid"] else None,
        "seconds": c.get("seconds"),
        "cpu_seconds": c.get("cpu_seconds"),
        "time_limited": d.get("kind") == "time limit",
        "time_limit": c.get("time_limit"),
        "energy_seconds": e.get("solve_seconds"),
        "energy_time_limit": c.get("energy_time_limit"),
        "operational": bool(c.get("operational", False)),
        "speed_bound": c.get("speed_bound"),
        "initial_speed": c.get("initial_speed"),
        "max_abs_lateral_acceleration": t.get("max_abs_lateral_acceleration") if t["valid"] else None,
        "limits": limits_of(c),
        "min_acceleration": t.get("min_acceleration") if t["valid"] else None,
        "max_acceleration": t.get("max_acceleration") if t["valid"] else None,
    }


def limits_of(c: dict) -> str:
    """The cell's limits in a table cell (model.studies.roads.limits_cell): held to the preset's or not, and
    what it reached (the section's limits paragraph states each preset's limits)."""
    t = c["time"]
    operational = bool(c.get("operational"))
    if not t["valid"]:
        return limits_cell(c["preset"], operational, None)
    return limits_cell(c["preset"], operational, t.get("max_abs_lateral_acceleration"),
                       (t.get("min_acceleration"), t.get("max_acceleration")))  # fmt: skip


def energy_header(df: pd.DataFrame, ratio: float) -> str:
    """The energy column's header; the caption says what J integrates (``energy_words``)."""
    return f"J at {ratio:g} T_min"


def energy_words(df: pd.DataFrame) -> str:
    """What J integrates: u1 and u2 without the limits; at them the jerk j for u1."""
    if not df.operational.any():
        return f"½∫(u1² + u2²) dt, {ENERGY_UNIT}"
    if df.operational.all():
        return "½∫(j² + u2²) dt, the jerk j in m/s³ for u1"
    return f"1/2 int of each cell's controls squared ({ENERGY_UNIT}; at the limits the jerk j for u1)"


def limits_paragraph(df: pd.DataFrame) -> str:
    """How the vehicles were driven (``studies_common.limits_paragraph`` with this study's switch)."""
    return common_limits_paragraph(df, "road_studies_operational")


def outliers(df: pd.DataFrame, column: str, unit: str) -> list[str]:
    """Cells whose ``column`` is above twice that of the same vehicle and apron at the next larger ICD."""
    found = []
    for _, g in df.sort_values("icd").groupby(["preset", "apron"], sort=False):
        rows = g.to_dict("records")
        for r, nxt in zip(rows, rows[1:], strict=False):
            a, b = r.get(column), nxt.get(column)
            if a is not None and b is not None and pd.notna(a) and pd.notna(b) and a > 2 * b:
                found.append(f"{r['preset']} ICD {r['icd']:g} m apron {r['apron']:g} m: {fmt(a, 3)}{unit} against"
                             f" {fmt(b, 3)}{unit} at ICD {nxt['icd']:g} m ({slow_reason(r)})")  # fmt: skip
    return found


def slow_reason(r: dict) -> str:
    """Why a cell took long, from its record: its time limit, its energy search's share, else its search."""
    if r["time_limited"]:
        return f"refused at its time limit of {r['time_limit']:g} s, with the evidence found before it"
    energy = r.get("energy_seconds")
    if energy is not None and pd.notna(energy) and energy > 0.5 * r["seconds"]:
        budget = r.get("energy_time_limit")
        at = f" (budget {budget:g} s)" if budget is not None and pd.notna(budget) else ""
        return f"valid; {fmt(energy, 3)} s of it the energy-optimal search{at}"
    return "valid" if r["feasible"] else "refused by a converged minimal violation"


def outlier_lines(df: pd.DataFrame) -> list[str]:
    """The paragraph on cells above twice the next larger ICD's minimum time or solving time (none: one ICD)."""
    if df.icd.nunique() < 2:
        return []
    slow_tf, slow_cpu = outliers(df, "t_min", " s"), outliers(df, "cpu_seconds", " s of CPU")
    lines = [
        "Cells whose minimum time is above twice the same vehicle's at the next larger ICD (with the same apron): "
        + ("; ".join(slow_tf) if slow_tf else "none")
        + ".",
        "Cells whose solving took more than twice as long as the same vehicle's at the next larger ICD: "
        + ("; ".join(slow_cpu) if slow_cpu else "none")
        + ".",
    ]
    return lines


MARKERS = {"o": "circles", "s": "squares", "^": "triangles", "D": "diamonds"}
LINES = {"--": "dashed", "-": "solid", ":": "dotted", "-.": "dash-dotted"}
PANELS = (("t_min", "minimum time (s)", "minimum time"),
          ("swept_width_m", "swept width in the ring (m)", "swept width of the time-optimal manoeuvre"))  # fmt: skip


def apron_style(j: int, lines: bool) -> dict:
    """The j-th apron's marker (the first open, the others filled) and, where lines are drawn, its line style."""
    return {"marker": list(MARKERS)[j % len(MARKERS)], "ls": list(LINES)[j % len(LINES)] if lines else "none",
            "mfc": "white" if j == 0 else None}  # fmt: skip


def apron_words(j: int, lines: bool) -> str:
    """The j-th apron's style in words, as apron_style draws it."""
    st = apron_style(j, lines)
    line = f", {LINES[st['ls']]} line" if lines else ""
    return f"{'open' if j == 0 else 'filled'} {MARKERS[st['marker']]}{line}"


def draws_lines(df: pd.DataFrame) -> bool:
    """Lines join the points only where some vehicle and apron has valid cells at two or more ICDs."""
    return bool((df[df.feasible].groupby(["preset", "apron"]).icd.nunique() > 1).any())


def draw_group(axes, g: pd.DataFrame, x: pd.Series, color: str, style: dict, label: str) -> None:
    """One vehicle and apron: its valid cells as points, its cells without a valid trajectory as x on the axis."""
    ok = g.feasible.to_numpy(bool)
    for ax, (column, _, _) in zip(axes, PANELS, strict=True):
        ax.plot(x[ok], g[column][ok], color=color, ms=6, label=label, **style)
        if (~ok).any():
            ax.plot(x[~ok], [0.02] * int((~ok).sum()), "x", color=color, ms=8, mew=2,
                    transform=ax.get_xaxis_transform(), clip_on=False)  # fmt: skip


def figure(df: pd.DataFrame, out: Path, formats: list[str]) -> str:
    """Minimum time and swept width against the ICD (or per vehicle, for one ICD); returns the caption.

    Colour: the vehicle; marker (and line, where a line joins two ICDs): the apron. The caption is
    made from what is drawn.
    """
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    presets, aprons = list(dict.fromkeys(df.preset)), sorted(df.apron.unique())
    by_icd, lines = df.icd.nunique() > 1, draws_lines(df)
    for k, name in enumerate(presets):
        for j, apron in enumerate(aprons):
            g = df[(df.preset == name) & (df.apron == apron)].sort_values("icd")
            dodge = 0.0 if by_icd else 0.3 * (j - (len(aprons) - 1) / 2) / max(1, len(aprons) - 1)
            x = g.icd if by_icd else pd.Series(k + dodge, index=g.index)
            draw_group(axes, g, x, f"C{k}", apron_style(j, lines), f"{name}, apron {apron:g} m")
    failed = bool((~df.feasible).any())
    for k, (ax, (_, ylabel, title)) in enumerate(zip(axes, PANELS, strict=True)):
        ax.set_ylabel(ylabel)
        ax.set_title(title + (" (x on the axis: no valid trajectory)" if failed and k == 0 else ""), fontsize=9)
        if by_icd:
            ax.set_xlabel("inscribed circle diameter ICD (m)")
        else:
            ax.set_xticks(range(len(presets)), presets)
            ax.set_xlim(-0.6, len(presets) - 0.4)
            ax.set_xlabel(f"design vehicle (ICD {df.icd.iloc[0]:g} m)")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center",
               ncol=min(6, len(aprons) * len(presets)), fontsize=7)  # fmt: skip
    save(fig, out / "table", formats)
    return caption(df, aprons, by_icd, lines, failed)


def caption(df: pd.DataFrame, aprons: list[float], by_icd: bool, lines: bool, failed: bool) -> str:
    """What the figure draws, in words."""
    where = (
        "against the inscribed circle diameter (ICD)" if by_icd else f"per design vehicle at ICD {df.icd.iloc[0]:g} m"
    )
    keys = "; ".join(f"apron {a:g} m: {apron_words(j, lines)}" for j, a in enumerate(aprons))
    limits = ("at the presets' operational limits" if df.operational.all() else
              "without operational limits (the kinematic model)" if not df.operational.any() else
              "at the presets' operational limits where the table's limits column says so")  # fmt: skip
    return (f"Minimum time (left) and swept width of the time-optimal manoeuvre (right) {where}, {limits}; colour:"
            f" the vehicle; {keys}" + ("; x on the axis: no valid trajectory" if failed else ""))  # fmt: skip


def matrix(df: pd.DataFrame) -> str:
    """Vehicle and apron rows x ICD columns: the minimum time (s), 'no' where no valid trajectory."""
    icds = sorted(df.icd.unique())
    rows = []
    for name in dict.fromkeys(df.preset):
        for apron in sorted(df.apron.unique()):
            row = {"preset": name, "apron": f"{apron:g}"}
            for icd in icds:
                g = df[(df.preset == name) & (df.icd == icd) & (df.apron == apron)]
                row[f"{icd:g}"] = "" if g.empty else (fmt(g.iloc[0].t_min, 4) if g.iloc[0].feasible else "no")
            rows.append(row)
    return table(rows, {"preset": "vehicle", "apron": "apron (m)", **{f"{i:g}": f"ICD {i:g} m" for i in icds}})


def preset_limits(df: pd.DataFrame) -> list[str]:
    """One line per vehicle (and limits setting): its limits and the extremes its valid cells reached."""
    lines = []
    for (name, operational), g in df[df.feasible].groupby(["preset", "operational"], sort=False):
        low, high = g.min_acceleration.dropna(), g.max_acceleration.dropna()
        accel = (float(low.min()), float(high.max())) if len(low) and len(high) else None
        lateral = g.max_abs_lateral_acceleration.dropna()
        reached = float(lateral.max()) if len(lateral) else None
        lines.append(f"- {name}: {limits_note(name, bool(operational), reached, accel)}.")
    if not lines:
        return []
    return ["The limits of each vehicle and the extremes its valid cells reached:", "", *lines, ""]


def diagnoses(df: pd.DataFrame) -> list[str]:
    """One line per cell without a valid trajectory: its diagnosis (none: no lines)."""
    failed = df[~df.feasible].to_dict("records")
    if not failed:
        return []
    items = [f"- {r['preset']}, ICD {r['icd']:g} m, apron {r['apron']:g} m: {r['diagnosis'] or '-'}." for r in failed]
    return ["The cells without a valid trajectory and their diagnoses:", "", *items, ""]


def budgets(grid: dict) -> str:
    """The grid's per-cell budgets in a sentence ("" without any)."""
    clock = " of CPU" if grid.get("time_limit_clock") == "cpu" else ""
    named = (("time_limit", "the minimum-time search"), ("energy_time_limit", "the energy-optimal search"))
    parts = [f"{what} {grid[key]:g} s{clock}" for key, what in named if grid.get(key)]
    if not parts:
        return ""
    return f" Budgets per cell: {' and '.join(parts)} (past it, the best validated answer or a refusal)."


CONFIG = Path(__file__).resolve().parents[1] / "config.yaml"
FIGURE_ROWS = 8  # the section shows the table's figure only for a larger grid: a few rows it would repeat
TRIM_DEG = inspect.signature(swept_width).parameters["trim_deg"].default  # the rays kept clear of the legs


def full_grid() -> str:
    """The `road_studies: full` grid of workflows/config.yaml in words: its vehicles (cited) and ICDs."""
    import yaml

    grid = yaml.safe_load(CONFIG.read_text())["road_studies_grids"]["full"]
    icd = sorted(grid["icd"])
    return (f"{presets_cited(grid['vehicles'])} at ICD {icd[0]:g} to {icd[-1]:g} m"
            f" ({len(icd)} sizes)")  # fmt: skip


def cell_rows(df: pd.DataFrame) -> list[dict]:
    """The cells as the table prints them: lengths to the millimetre, times and J to 4 significant digits."""
    out = []
    for r in df.to_dict("records"):
        out.append(r | {
            "result": "valid" if r["feasible"] else "FAILED",
            "apron_used_m": None if pd.isna(r["apron_used_m"]) else f"{r['apron_used_m']:.3f}",
            "swept_width_m": None if pd.isna(r["swept_width_m"]) else f"{r['swept_width_m']:.3f}",
        })  # fmt: skip
    return out


def section(df: pd.DataFrame, mode: str, grid: dict, template: dict, fig: Path, ratio: float, caption: str) -> str:
    rb = template["roundabout"]
    leg = rb["legs"][0]
    n_fail = int((~df.feasible).sum())
    cpu = df.seconds.sum()
    process = df.cpu_seconds.sum() if df.cpu_seconds.notna().all() else None
    lines = [
        "## Design vehicles and roundabout sizes",
        "",
        f"A left turn (the third exit of a four-leg roundabout, right-hand traffic) for each design vehicle,"
        f" inscribed circle diameter and apron. **This is the `road_studies: {mode}` run**: vehicles"
        f" {presets_cited(grid['vehicles'])};"
        f" ICD {', '.join(f'{i:g}' for i in grid['icd'])} m; apron"
        f" {', '.join(f'{a:g}' for a in grid['apron'])} m; N = {grid['intervals']} intervals"
        + (f" (`road_studies: full` in workflows/config.yaml runs {full_grid()})." if mode != "full" else ".")
        + f" {len(df)} cells, {n_fail} without a valid trajectory; {fmt(cpu, 3)} s of solving in all"
        + (f" ({fmt(process, 3)} s of CPU)." if process is not None else ".")
        + budgets(grid),
        "",
        f"The roundabout (workflows/scenarios/roads/left-turn.toml): circulatory width {rb['circulatory_width']:g} m,"
        f" lanes {leg['lane_width']:g} m wide, curb fillets {leg['entry_radius']:g} m (entry) and"
        f" {leg['exit_radius']:g} m (exit) at ICD {rb['inscribed_diameter']:g} m, scaled with the ICD; start and"
        f" goal {template['route']['start_distance']:g} m beyond the outer curb; forward driving only"
        f" (speed in [{template['bounds']['u1'][0]:g}, {template['bounds']['u1'][1]:g}] m/s), the preset's steering"
        f" limit. The apron may be mounted by the trailer of an articulated vehicle, by the whole of a"
        f" single-unit truck, and not by the passenger car P. Per cell: the minimum time (the default multi-start);"
        f" the energy-optimal J at {ratio:g} x that time; *apron used*: how far the exact rectangles of the"
        f" time-optimal manoeuvre reach inside the ring roadway's inner edge (that optimum hugs the island, so this"
        " is what it uses, not the least it needs: compare the cell without an apron); *swept width*: the"
        f" largest radial extent of the swept area on rays through the ring {TRIM_DEG:g} degrees clear of the entry"
        " and exit"
        " legs. Where no start gives a valid trajectory the diagnosis of a minimal-violation solve names the body,"
        " the edge that must give way and by how much (a local solve: an upper bound on what must give way).",
        "",
        limits_paragraph(df),
        "",
        f"Table: Minimum time T_min (s) of the left turn, one row per design vehicle and apron width (m), one"
        f" column per inscribed circle diameter; no: no valid trajectory ({n_fail} such cells).",
        "",
        matrix(df),
        "",
        f"Table: Every cell of the `{mode}` run: the minimum time T_min (s), the energy-optimal J at {ratio:g}"
        f" T_min ({energy_words(df)}), how far the time-optimal manoeuvre reaches onto the apron and its swept"
        " width (m), and its limits (m/s²): *held* at the preset's operational limits with the largest lateral"
        " acceleration a_lat and the acceleration a reached, or *none* with a_lat against the preset's allowed one.",
        "",
        table(
            cell_rows(df),
            {
                "preset": "vehicle",
                "icd": "ICD (m)",
                "apron": "apron (m)",
                "result": "result",
                "t_min": "T_min (s)",
                "energy": energy_header(df, ratio),
                "apron_used_m": "apron used (m)",
                "swept_width_m": "swept width (m)",
                "limits": "limits (m/s²)",
            },  # fmt: skip
        ),
        "",
        *preset_limits(df),
        *diagnoses(df),
        *(line for part in outlier_lines(df) for line in (part, "")),
        *([f"![{caption}]({fig})", ""] if len(df) > FIGURE_ROWS else []),
    ]
    return "\n".join(lines)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--cells", type=Path, nargs="+", required=True)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument("--mode", required=True)
    ap.add_argument("--vehicles", nargs="+", required=True)
    ap.add_argument("--icd", type=float, nargs="+", required=True)
    ap.add_argument("--apron", type=float, nargs="+", required=True)
    ap.add_argument("--intervals", type=int, required=True)
    ap.add_argument("--energy-ratio", type=float, default=1.2)
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args()
    cells = load(args.cells)
    order = {n: k for k, n in enumerate(args.vehicles)}
    df = pd.DataFrame([flat(c) for c in cells])
    df = df.sort_values(["preset", "icd", "apron"], key=lambda s: s.map(order) if s.name == "preset" else s)
    args.out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out / "table.csv", index=False)
    drawn = figure(df, args.out, args.formats)
    grid = {"vehicles": args.vehicles, "icd": args.icd, "apron": args.apron, "intervals": args.intervals}
    template = tomllib.loads(args.template.read_text())
    write_text(args.section, section(df, args.mode, grid, template, args.out / "table.png", args.energy_ratio, drawn))


if __name__ == "__main__":
    main()
