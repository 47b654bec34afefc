"""Road study (b): the table of design vehicles x roundabout sizes, from the cells' JSON files.

Writes table.csv, the figure (minimum time and swept width against the ICD; failed cells marked
as failed, never drawn as solutions) and the paper section, which states the grid that was run.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pandas as pd
from studies_common import fmt, parser, plt, table, write_text

from model.plotting.figures import save


def load(cells: list[Path]) -> list[dict]:
    return [json.loads(p.read_text()) for p in cells]


def flat(c: dict) -> dict:
    t, e, m = c["time"], c.get("energy") or {}, c.get("measures") or {}
    d = {} if t["valid"] else (t.get("diagnosis") or {})
    if d.get("body") and d.get("edge") and d.get("encroachment_m") is not None:  # what must give way, by how much
        diag = f"the {d['body']} crosses the {d['edge']} by {d['encroachment_m']:.2f} m"
    else:
        diag = d.get("message")
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
    }


def figure(df: pd.DataFrame, out: Path, formats: list[str]) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    presets = list(dict.fromkeys(df.preset))
    for k, name in enumerate(presets):
        color = f"C{k}"
        for apron, style in ((0.0, "--"), (2.0, "-")):
            g = df[(df.preset == name) & (df.apron == apron)].sort_values("icd")
            ok = g[g.feasible]
            label = f"{name}, apron {apron:g} m"
            ax1.plot(ok.icd, ok.t_min, style, marker="o", ms=4, color=color, label=label)
            ax2.plot(ok.icd, ok.swept_width_m, style, marker="o", ms=4, color=color, label=label)
            bad = g[~g.feasible]
            for ax in (ax1, ax2) if len(bad) else ():
                ax.plot(bad.icd, [0.02] * len(bad), "x", color=color, ms=8, mew=2,
                        transform=ax.get_xaxis_transform(), clip_on=False)  # fmt: skip
    ax1.set_xlabel("inscribed circle diameter ICD (m)")
    ax1.set_ylabel("minimum time (s)")
    ax2.set_xlabel("inscribed circle diameter ICD (m)")
    ax2.set_ylabel("swept width in the ring (m)")
    ax1.set_title("minimum time (x on the axis: no valid trajectory)", fontsize=9)
    ax2.set_title("swept width of the time-optimal manoeuvre", fontsize=9)
    fig.legend(*ax1.get_legend_handles_labels(), loc="outside lower center", ncol=min(6, 2 * len(presets)), fontsize=7)
    save(fig, out / "table", formats)


def matrix(df: pd.DataFrame) -> str:
    """Vehicle rows x ICD columns: minimum time without / with the apron, 'no' where infeasible."""
    icds = sorted(df.icd.unique())
    rows = []
    for name in dict.fromkeys(df.preset):
        row = {"preset": name}
        for icd in icds:
            parts = []
            for apron in sorted(df.apron.unique()):
                g = df[(df.preset == name) & (df.icd == icd) & (df.apron == apron)]
                if g.empty:
                    parts.append("")
                else:
                    r = g.iloc[0]
                    parts.append(fmt(r.t_min, 4) if r.feasible else "no")
            row[f"{icd:g}"] = " / ".join(parts)
        rows.append(row)
    return table(rows, {"preset": "vehicle", **{f"{i:g}": f"ICD {i:g} m" for i in icds}})


def section(df: pd.DataFrame, mode: str, grid: dict, template: dict, fig: Path, ratio: float) -> str:
    rb = template["roundabout"]
    leg = rb["legs"][0]
    n_fail = int((~df.feasible).sum())
    cpu = df.seconds.sum()
    aprons = sorted(df.apron.unique())
    lines = [
        "## Design vehicles and roundabout sizes",
        "",
        f"A left turn (the third exit of a four-leg roundabout, right-hand traffic) for each design vehicle,"
        f" inscribed circle diameter and apron. **This is the `road_studies: {mode}` run**: vehicles"
        f" {', '.join(grid['vehicles'])}; ICD {', '.join(f'{i:g}' for i in grid['icd'])} m; apron"
        f" {', '.join(f'{a:g}' for a in grid['apron'])} m; N = {grid['intervals']} intervals"
        + (
            " (`road_studies: full` in workflows/config.yaml runs every AASHTO preset and the EU-semitrailer at"
            " ICD 25 to 55 m)."
            if mode != "full"
            else "."
        )
        + f" {len(df)} cells, {n_fail} without a valid trajectory; {fmt(cpu, 3)} s of solving in all.",
        "",
        f"The roundabout (workflows/scenarios/roads/left-turn.toml): circulatory width {rb['circulatory_width']:g} m,"
        f" lanes {leg['lane_width']:g} m wide, curb fillets {leg['entry_radius']:g} m (entry) and"
        f" {leg['exit_radius']:g} m (exit) at ICD {rb['inscribed_diameter']:g} m, scaled with the ICD; start and"
        f" goal {template['route']['start_distance']:g} m beyond the outer curb; forward driving only"
        f" (u1 in [{template['bounds']['u1'][0]:g}, {template['bounds']['u1'][1]:g}] m/s), the preset's steering"
        f" limit. The apron may be mounted by the trailer of an articulated vehicle, by the whole of a"
        f" single-unit truck, and not by the passenger car P. Per cell: the minimum time (the default multi-start);"
        f" the energy-optimal J at {ratio:g} x that time; *apron used*: how far the exact rectangles of the"
        f" time-optimal manoeuvre reach inside the ring roadway's inner edge (that optimum hugs the island, so this"
        " is what it uses, not the least it needs: compare the cell without an apron); *swept width*: the"
        " largest radial extent of the swept area on rays through the ring 45 degrees clear of the entry and exit"
        " legs. Where no start gives a valid trajectory the diagnosis of a minimal-violation solve names the body,"
        " the edge that must give way and by how much (a local solve: an upper bound on what must give way).",
        "",
        "Minimum time in seconds, " + " / ".join(f"apron {a:g} m" for a in aprons) + " (no: no valid trajectory):",
        "",
        matrix(df),
        "",
        table(
            df.assign(result=["valid" if f else "FAILED" for f in df.feasible]).to_dict("records"),
            {
                "preset": "vehicle",
                "icd": "ICD (m)",
                "apron": "apron (m)",
                "result": "result",
                "t_min": "T_min (s)",
                "energy": f"J at {ratio:g} T_min",
                "apron_used_m": "apron used (m)",
                "swept_width_m": "swept width (m)",
                "diagnosis": "diagnosis",
            },  # fmt: skip
        ),
        "",
        f"![Minimum time and swept width against the ICD; solid: with the apron, dashed: without; x: no valid"
        f" trajectory]({fig})",
        "",
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
    figure(df, args.out, args.formats)
    grid = {"vehicles": args.vehicles, "icd": args.icd, "apron": args.apron, "intervals": args.intervals}
    template = tomllib.loads(args.template.read_text())
    write_text(args.section, section(df, args.mode, grid, template, args.out / "table.png", args.energy_ratio))


if __name__ == "__main__":
    main()
