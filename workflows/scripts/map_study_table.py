"""Map study: the turning-path table of a real roundabout (vehicles x movements x apron) from the cells' JSON files.

Writes table.csv and table.md (one row per cell: passes or fails, the diagnosis, least clearance at
the nodes and between them, apron used, lanelets used, Tf), one figure per vehicle (the map's
lanelets drawn by type; the swept paths of every passing movement, with and without the apron side by
side; the failed movements listed under the panel, never drawn as solutions) and the paper section,
which says which grid ran.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pandas as pd
from studies_common import fmt, parser, table, write_text
from studies_common import limits_paragraph as common_limits_paragraph

from model.plotting.figures import save
from model.plotting.maps import map_figure, movement_name
from model.problem.maps import map_of
from model.studies.maps import movements
from model.studies.roads import limits_cell, limits_note, presets_cited

COLUMNS = {
    "preset": "vehicle",
    "movement": "movement",
    "apron_use": "apron use",
    "to_lanelet": "goal on",
    "result": "result",
    "final_time": "Tf (s)",
    "intervals_solved": "N",
    "min_clearance": "clearance nodes (m)",
    "min_clearance_dense": "clearance between (m)",
    "apron_used_m": "apron depth (m)",
    "apron_area_m2": "apron area (m^2)",
    "lanelets_used": "lanelets used",
    "limits": "limits",
    "diagnosis": "diagnosis",
}


# the section's cell table: the columns of COLUMNS that fit a page (the lanelets used and the full limits note are
# in table.csv and table.md), the limits in a table cell's length
PAPER_COLUMNS = {k: v for k, v in COLUMNS.items() if k not in ("lanelets_used", "limits", "diagnosis")} | {
    "to_lanelet": "goal on lanelet",
    "apron_area_m2": "apron area (m²)",
}
# the section's number formats: times to 0.01 s, clearances to the millimetre, depths to 1 cm, areas to 0.1 m^2
FORMATS = {"final_time": ".2f", "min_clearance": ".3f", "min_clearance_dense": ".3f", "apron_used_m": ".2f",
           "apron_area_m2": ".1f"}  # fmt: skip


CONFIG = Path(__file__).resolve().parents[1] / "config.yaml"


def full_grid() -> str:
    """The `map_study: full` grid of workflows/config.yaml in words: its vehicles (cited) and movements."""
    import yaml

    grid = yaml.safe_load(CONFIG.read_text())["map_studies"]["full"]
    moves = "every movement" if grid["movements"] == "all" else f"movements {', '.join(grid['movements'])}"
    return f"{presets_cited(grid['vehicles'])} on {moves}"


def lanelet_words(ids: list) -> str:
    """Lanelet ids in words, never in brackets (which read as a citation): "lanelet 50", "lanelets 50 and 51"."""
    names = [str(i) for i in ids]
    if not names:
        return "no lanelets"
    if len(names) == 1:
        return f"lanelet {names[0]}"
    return f"lanelets {', '.join(names[:-1])} and {names[-1]}"


def paper_rows(df: pd.DataFrame) -> list[dict]:
    """The cells as the section prints them (``FORMATS``; a missing value stays missing)."""
    out = []
    for r in df.to_dict("records"):
        out.append(r | {k: format(r[k], f) for k, f in FORMATS.items() if isinstance(r.get(k), float) and r[k] == r[k]})
    return out


def note(c: dict) -> str | None:
    """A passing cell's note: whether it passes only once more round the ring (``route_loops``)."""
    return f"passes only once more round the ring ({c['route_loops']} loop)" if c.get("route_loops") else None


def flat(c: dict) -> dict:
    """A cell as a table row."""
    valid = bool(c.get("valid"))
    route = c.get("route") or {}
    return {
        "preset": c["preset"],
        "movement": c["movement"],
        "apron": bool(c["apron"]),
        "apron_use": c["apron_use"],
        "from_lanelet": route.get("from_lanelet"),
        "to_lanelet": route.get("to_lanelet"),
        "start_offset": route.get("start_offset"),
        "goal_offset": route.get("goal_offset"),
        "intervals": c["intervals"],
        "intervals_solved": c.get("intervals_solved"),
        "status": c.get("status"),
        "valid": valid,
        "result": "passes" if valid else "FAILS",
        "final_time": c.get("final_time") if valid else None,
        "min_clearance": c.get("min_clearance"),
        "min_clearance_dense": c.get("min_clearance_dense"),
        "apron_used_m": c.get("apron_used_m") if valid else None,
        "apron_area_m2": c.get("apron_area_m2") if valid else None,
        "apron_gap_m": c.get("apron_gap_m"),
        "lanelets_used": " ".join(map(str, c.get("lanelets_used") or [])) if valid else None,  # of a solution only
        "diagnosis": note(c) if valid else (c.get("diagnosis") or {}).get("message"),
        "seconds": c.get("seconds"),
        "operational": bool(c.get("operational", False)),
        "speed_bound": c.get("speed_bound"),
        "initial_speed": c.get("initial_speed"),
        "limits": limits_of(c),
        "max_abs_lateral": c.get("max_abs_lateral_acceleration") if valid else None,
        "min_acceleration": c.get("min_acceleration") if valid else None,
        "max_acceleration": c.get("max_acceleration") if valid else None,
        "limits_cell": limits_cell(
            c["preset"],
            bool(c.get("operational")),
            c.get("max_abs_lateral_acceleration") if valid else None,
            (c.get("min_acceleration"), c.get("max_acceleration")) if valid else None,
        ),
    }


def limits_of(c: dict) -> str:
    """The cell's limits note (model.studies.roads.limits_note): what it was held to and what it reached."""
    operational, valid = bool(c.get("operational")), bool(c.get("valid"))
    if not valid and not operational:
        return "kinematic model without operational limits"
    return limits_note(c["preset"], operational, c.get("max_abs_lateral_acceleration") if valid else None,
                       (c.get("min_acceleration"), c.get("max_acceleration")) if valid else None)  # fmt: skip


def limits_paragraph(df: pd.DataFrame) -> str:
    """How the vehicles were driven (``studies_common.limits_paragraph`` with this study's switch)."""
    return common_limits_paragraph(df, "map_study_operational")


def figure(lanelet_map, cells: list[dict], preset: str, stem: Path, formats: list[str]) -> str:
    """One vehicle's movements on the map (model.plotting.maps.map_figure); returns the caption."""
    save(map_figure(lanelet_map, cells, preset), stem, formats)
    mine = [c for c in cells if c["preset"] == preset]
    held = [bool(c.get("operational")) for c in mine]
    limits = (f"at the {preset}'s operational limits" if all(held) else
              "without operational limits (the kinematic model)" if not any(held) else
              "at the operational limits where the table's limits column says so")  # fmt: skip
    return (
        f"{preset} ({limits}): the swept paths (all bodies, exact rectangles) of every movement that passes, on"
        " the map's lanelets drawn by type, each movement named by the directions of its legs, its route dotted"
        " with arrowheads from its start (circle) to its goal (square); a panel per apron setting, one where both"
        " sweep the same paths; the movements that fail are listed under each panel, not drawn"
    )


def movement_key(name: str) -> tuple[int, int]:
    """``"90-102"`` -> (90, 102): movements by entry, then exit."""
    entry, exit_ = name.split("-")
    return int(entry), int(exit_)


def apron_label(apron: bool) -> str:
    return "with apron" if apron else "without apron"


def matrix(df: pd.DataFrame) -> str:
    """Movement rows x (vehicle, apron) columns: Tf (s), "fails" where a cell fails."""
    columns = {(p, a): f"{p}, {apron_label(a)}" for p in dict.fromkeys(df.preset)
               for a in sorted(set(df.apron), reverse=True)}  # fmt: skip
    rows = []
    for movement in sorted(set(df.movement), key=movement_key):
        legs = df[df.movement == movement]["legs"].iloc[0] if "legs" in df else None
        row = {"movement": f"{legs} ({movement})" if isinstance(legs, str) else movement}
        for (preset, apron), header in columns.items():
            g = df[(df.movement == movement) & (df.preset == preset) & (df.apron == apron)]
            row[header] = "" if g.empty else (f"{g.iloc[0].final_time:.1f}" if g.iloc[0].valid else "fails")
        rows.append(row)
    return table(rows, {"movement": "movement", **{h: h for h in columns.values()}})


def preset_limits(df: pd.DataFrame) -> list[str]:
    """One line per vehicle (and limits setting): its limits and the extremes its passing cells reached."""
    lines = []
    for (name, operational), g in df[df.valid].groupby(["preset", "operational"], sort=False):
        low, high, lateral = (g[k].dropna() for k in ("min_acceleration", "max_acceleration", "max_abs_lateral"))
        accel = (float(low.min()), float(high.max())) if len(low) and len(high) else None
        reached = float(lateral.max()) if len(lateral) else None
        lines.append(f"- {name}: {limits_note(name, bool(operational), reached, accel)}.")
    return ["The limits of each vehicle and the extremes its passing cells reached:", "", *lines, ""] if lines else []


def notes(df: pd.DataFrame) -> list[str]:
    """Each cell's diagnosis or note (none: no lines)."""
    found = [f"- {r['preset']} {r['movement']} {apron_label(r['apron'])}: {r['diagnosis']}."
             for r in df.to_dict("records") if isinstance(r.get("diagnosis"), str)]  # fmt: skip
    return ["Diagnoses and notes:", "", *found, ""] if found else []


def section(df: pd.DataFrame, mode: str, grid: dict, template: dict, n_movements: int, figures: list[tuple]) -> str:
    cpu = df.seconds.sum()
    lines = [
        "## A real roundabout: turning paths of the design vehicles",
        "",
        f"Every movement (entry lanelet x exit lanelet that a route connects through the ring, written entry-exit)"
        f" of the roundabout {template['map'].get('dataset', template['map'].get('file'))} of the rounD dataset"
        f" [@round2020] (its CommonRoad map [@commonroad2017]; {n_movements} movements in the map's lanelet graph),"
        f" for each design vehicle, with and without the apron"
        f" ({lanelet_words(template['route'].get('apron_lanelets', []))}). **This is the `map_study: {mode}` run**:"
        f" vehicles {presets_cited(grid['vehicles'])}; movements"
        f" {', '.join(grid['movements'])}; apron"
        f" {', '.join('with' if a else 'without' for a in grid['apron'])}; N = {grid['intervals']}"
        + (f" (`map_study: full` in workflows/config.yaml runs {full_grid()})." if mode != "full" else ".")
        + f" {len(df)} cells, {int((~df.valid).sum())} failing; {fmt(cpu, 3)} s of job time in all.",
        "",
        "Per cell (model/studies/maps.py): the minimum-time manoeuvre by the map corridor strips, forward only;"
        " start and goal on the route's centre line where every body's exact rectangle stands inside the corridor (the"
        " goal on the last lanelet after the ring where the vehicle, standing straight, fits: column *goal on*; where"
        " that is not the movement's exit lanelet the lanes beyond it are too narrow for the vehicle, and a"
        " movement where no such lanelet exists is *not posed*);"
        " *passes* only if the solve converged and every body stays inside its corridor at the nodes and on 4"
        " sub-steps between them (a cell that fails only between the nodes is solved again on 2N: column N)."
        " The apron may be mounted by the trailer of an articulated vehicle, by the whole"
        " of a single-unit truck and not by the passenger car P; *apron depth* is how far the swept area reaches"
        " from the lanes into the apron lanelets, *apron area* the part of it on the apron. A failing cell gives"
        " the diagnosis (which body leaves the corridor where, by how much); it is never drawn as a solution. A"
        " failure is that of the map search (model/search/maps.py: the centre-line strip sequence, a finer grid, a"
        " minimal-violation start; docs/map-corridor.md): evidence, not a proof, that the vehicle cannot make the"
        " movement.",
        "",
        limits_paragraph(df),
        "",
        f"Table: The turning-path table of the `{mode}` run: the minimum time Tf (s) of each movement (by the"
        " directions of its legs from the island, as in the figures, and its entry-exit lanelets), one column per"
        " vehicle and apron setting; fails: no valid trajectory (the diagnosis below).",
        "",
        matrix(df),
        "",
        "Table: Every cell: how the vehicle may use the apron, the lanelet the goal is on, the result, Tf (s), the"
        " grid N, the smallest clearance at the nodes and between them (m), and how deep (m) and how much (m²) of"
        " the swept area lies on the apron; each vehicle's limits and what its cells reached are listed below"
        " (`table.csv` has each cell's limits, the route's lanelets and offsets too).",
        "",
        table(paper_rows(df), PAPER_COLUMNS),
        "",
        *preset_limits(df),
        *notes(df),
        *gap_note(df, template),
    ]
    for path, caption in figures:
        lines += [f"![{caption}]({path})", ""]
    return "\n".join(lines)


def gap_note(df: pd.DataFrame, template: dict) -> list[str]:
    """A paragraph on how far the apron lanelets lie from the lanes and the route's ``apron_gap`` that paves
    the strip between (nothing where they touch or are not used)."""
    gaps = df.apron_gap_m.dropna()
    if gaps.empty or float(gaps.min()) <= 1e-3:
        return []
    apron = lanelet_words(template["route"].get("apron_lanelets", []))
    paved = float(template["route"].get("apron_gap", 0.0))
    reach = (f"The template's `apron_gap = {paved:g}` m (docs/map-format.md) paves strips narrower than that"
             " between the lanes and the apron, so the apron can be reached; the cells with the apron use that"
             " corridor." if paved > float(gaps.min()) else
             " No `apron_gap` wider than that is set, so on this map the apron cannot be reached, and a cell with"
             " it poses the problem of the cell without it.")  # fmt: skip
    return [f"The apron ({apron}) does not touch the corridor's lanes: it lies {float(gaps.min()):.2f} m from them"
            f" (a strip no lanelet covers). {reach}", ""]  # fmt: skip


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--cells", type=Path, nargs="+", required=True)
    ap.add_argument("--template", type=Path, required=True)
    ap.add_argument("--mode", required=True)
    ap.add_argument("--vehicles", nargs="+", required=True)
    ap.add_argument("--movements", nargs="+", required=True)
    ap.add_argument("--apron", nargs="+", required=True, choices=["true", "false"])
    ap.add_argument("--intervals", type=int, required=True)
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args()
    cells = [json.loads(p.read_text()) for p in args.cells]
    order = {n: k for k, n in enumerate(args.vehicles)}
    template = tomllib.loads(args.template.read_text())
    lanelet_map = map_of(template, args.template.parent)
    df = pd.DataFrame([flat(c) | {"legs": movement_name(lanelet_map, c["route"])} for c in cells])
    keys = {"preset": order.get, "movement": movement_key}
    df = df.sort_values(["preset", "movement", "apron"], ascending=[True, True, False],
                        key=lambda s: s.map(keys[s.name]) if s.name in keys else s)  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out / "table.csv", index=False)
    write_text(args.out / "table.md", table(df.to_dict("records"), COLUMNS))
    drawn = [(args.out / f"{v}.png", figure(lanelet_map, cells, v, args.out / v, args.formats))
             for v in args.vehicles]  # fmt: skip
    grid = {"vehicles": args.vehicles, "movements": args.movements, "apron": [a == "true" for a in args.apron],
            "intervals": args.intervals}  # fmt: skip
    write_text(args.section, section(df, args.mode, grid, template, len(movements(lanelet_map)), drawn))


if __name__ == "__main__":
    main()
