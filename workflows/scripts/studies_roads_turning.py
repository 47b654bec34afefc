"""Road study (a): the EU turning circle (Directive 96/53/EC, Annex I 1.5) for the EU-semitrailer and every preset.

The steady circle whose outer swept radius is 12.50 m (the front outer corner of the tractor)
fixes the steering angle; the inner swept radius of the exact rectangles follows in closed form
(trailer axle on R_t = sqrt(R^2 + h^2 - L^2)) and from the model integrated through two full
turns from straight driving (model.studies.roads). Writes turning.json, turning.csv (every
preset, steady state), the figure and the paper section.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
from studies_common import parser, table, write_json, write_text

from model.plotting.figures import save
from model.plotting.studies import turning_figure
from model.studies.roads import (
    EU_INNER,
    EU_OUTER,
    corners,
    eu_turning_circle,
    preset_vehicle,
    rectangle_distance,
    source_citation,
)
from model.vehicles import PRESETS, preset

SUBJECT = "EU-semitrailer"


def preset_sources(names: list[str]) -> str:
    """One sentence: where each preset's dimensions come from, with its citation."""
    by_source: dict[str, list[str]] = {}
    for name in names:
        by_source.setdefault(preset(name)["source"], []).append(name)
    parts = [f"{', '.join(group)} from {source}{source_citation(source)}" for source, group in by_source.items()]
    return "The presets' dimensions: " + "; ".join(parts) + "."


def preset_rows() -> list[dict]:
    """The steady-state test for every preset (no integration)."""
    rows = []
    for name in PRESETS:
        v, bodies, limit = preset_vehicle(name)
        r = eu_turning_circle(v, bodies, limit, transient=False)
        least = r.get("least_outer")
        rows.append({
            "preset": name,
            "model": v.model,
            "phi_deg": r.get("phi_deg"),
            "limit_deg": math.degrees(limit) if limit is not None else None,
            "inner": r["steady"]["inner"] if r.get("steady") else None,
            "inner_body": r["steady"]["inner_body"] if r.get("steady") else None,
            "inner_margin": r.get("inner_margin"),
            "least_outer": least["outer"] if least else None,
            "verdict": verdict(r),
        })  # fmt: skip
    return rows


def metres(x: float) -> str:
    """A length to the millimetre."""
    return f"{x:.3f} m"


def angle(x: float) -> str:
    """An angle in degrees to the hundredth."""
    return f"{x:.2f} deg"


def preset_cells(row: dict) -> dict:
    """A preset's row as the table prints it: angles to 0.01 deg, lengths to the millimetre, '-' for none."""
    decimals = {"phi_deg": 2, "limit_deg": 2, "inner": 3, "inner_margin": 3}
    return {k: (f"{v:.{decimals[k]}f}" if k in decimals and v is not None else v) for k, v in row.items()}


def verdict(r: dict) -> str:
    if r.get("phi") is None:
        return f"no: outer radius >= {r['least_outer']['outer']:.2f} m at any steering"
    if not r["within_limit"]:
        return (f"no: needs {r['phi_deg']:.1f} deg > its limit; at the limit the outer radius is "
                f"{r['least_outer']['outer']:.2f} m")  # fmt: skip
    if r["inner_margin"] < 0:
        return f"no: inner radius {r['steady']['inner']:.3f} m < {EU_INNER:.2f} m"
    return "yes"


def figure(name: str, result: dict, out: Path, formats: list[str]) -> None:
    """Two full turns in the directive's annulus and the inner swept radius (model.plotting.studies.turning_figure)."""
    v, bodies, _ = preset_vehicle(name)
    all_corners = corners(v, bodies, result["transient"]["run"])
    least = rectangle_distance(all_corners.get("trailer", all_corners["vehicle"]))
    save(turning_figure(name, result, all_corners, EU_OUTER, EU_INNER, least), out / "turning", formats)


def circle_rows(r: dict, limit: str) -> list[dict]:
    """The turning-circle table of one preset, one value per row (with its unit)."""
    s, tr = r["steady"], r["transient"]
    t1, t2 = tr["turns"][0], tr["turns"][-1]
    after = tr["trailer_axle_radius"]
    pairs = [
        (f"steering angle for an outer swept radius of {EU_OUTER:.2f} m", angle(r["phi_deg"])),
        ("the same in radians", f"{r['phi']:.4f} rad"),
        ("the preset's steering limit", limit),
        ("tractor rear axle radius R (steady)", metres(s["R"])),
        ("tractor front axle radius (steady)", metres(s["front_axle_radius"])),
        ("trailer axle radius R_t (closed form)", metres(s["trailer_axle_radius"])),
        ("articulation (steady)", angle(math.degrees(s["articulation"]))),
        (f"outer swept radius (steady; {s['outer_body']})", metres(s["outer"])),
        (f"its margin against {EU_OUTER:.2f} m", f"{r['outer_margin']:+.3f} m"),
        (f"inner swept radius (steady; {s['inner_body']})", metres(s["inner"])),
        (f"its margin against {EU_INNER:.2f} m", f"{r['inner_margin']:+.3f} m"),
        ("integrated turn 1 from straight: inner swept radius", metres(t1["inner"])),
        ("integrated turn 1: outer swept radius (the trailer still on the straight approach)", metres(t1["outer"])),
        ("integrated turn 2: inner swept radius", metres(t2["inner"])),
        ("integrated turn 2: outer swept radius", metres(t2["outer"])),
        ("integrated turn 2: swept polygon outside the annulus", f"{t2['outside_annulus_m2']:.2g} m²"),
        *((f"trailer axle radius after turn {k}", metres(x)) for k, x in enumerate(after, 1)),
        ("swing-out beyond the straight vehicle's outer side, first half turn", metres(tr["swing_out"])),
    ]
    return [{"what": what, "value": value} for what, value in pairs]


def section(name: str, r: dict, rows: list[dict], fig: Path) -> str:
    p = preset(name)
    limit = (
        "the preset gives no steering limit (the directive publishes none)"
        if r["phi_limit"] is None
        else (f"the preset's limit is {math.degrees(r['phi_limit']):.2f} deg")
    )
    lines = [
        "## The EU turning circle (Directive 96/53/EC, Annex I 1.5)",
        "",
        f"A vehicle combination in motion must turn a full circle within an outer radius of {EU_OUTER:.2f} m and an"
        f" inner radius of {EU_INNER:.2f} m [@directive9653]. Computed here from the model and the exact body"
        " rectangles (model/studies/roads.py): the steady circle at the steering angle whose outer swept radius is"
        f" exactly {EU_OUTER:.2f} m (bisection), the inner swept radius in closed form (trailer axle radius"
        " R_t = sqrt(R^2 + h^2 - L^2), the least distance"
        " of each rectangle from the centre), and the model integrated (DOP853, tolerance 1e-11) through two full"
        " turns of the tractor from straight driving (steering set, trailer aligned behind the tractor), the"
        " swept area of the rectangles measured on 1800 samples per turn and as a shapely polygon.",
        "",
        f"**{name}** ({p['source']}{source_citation(p['source'])}; d = {p['wheelbase']} m, h = {p['hitch_offset']} m,"
        f" L = {p['trailer_wheelbase']} m,"
        f" tractor {p['body']['length']:.2f} m, trailer {p['trailer_body']['length']:.2f} m, width"
        f" {p['body']['width']} m):",
        "",
        f"Table: The {name} on the EU turning circle: the steering angle (deg and rad) whose outer swept radius is"
        f" {EU_OUTER:.2f} m, the axle radii (m) and articulation (deg) of the steady circle, the outer and inner"
        f" swept radii (m) and their margins (m) against {EU_OUTER:.2f} and {EU_INNER:.2f} m, the swept radii (m)"
        " and trailer axle radii (m) of the integrated turns, and the swing-out (m); the unit of each value beside"
        " it.",
        "",
        table(circle_rows(r, limit), {"what": "quantity", "value": "value (unit)"}),
        "",
        f"So the {name} {'meets' if r['passes'] else 'does not meet'} the requirement: the inner margin is"
        f" {r['inner_margin'] * 100:+.1f} cm in the steady state (the worst case: from straight driving the trailer's"
        f" off-tracking builds up towards it from outside, {r['transient_inner_margin'] * 100:+.1f} cm over the"
        f" integrated turns), and the outer radius is met exactly by the choice of the steering angle. The outer"
        " radius of the first integrated turn is that of the trailer still lined up on the straight approach, not"
        " of the circle.",
        "",
        f"![{name}: two integrated full turns in the {EU_OUTER:.2f} / {EU_INNER:.2f} m annulus, and the trailer's"
        f" inner swept radius against the heading turned]({fig})",
        "",
        preset_sources([r["preset"] for r in rows]),
        "",
        f"Table: Every preset in the steady state, one row per preset: its kinematic model, the steering angle"
        f" (deg) whose outer swept radius is {EU_OUTER:.2f} m and the preset's steering limit (deg), the inner"
        f" swept radius (m) and its innermost body, the margin (m) of the inner radius against {EU_INNER:.2f} m"
        f" (negative: inside it), and whether the preset turns within {EU_OUTER:.2f} / {EU_INNER:.2f} m.",
        "",
        table(
            [preset_cells(r) for r in rows],
            {
                "preset": "preset",
                "model": "model",
                "phi_deg": "steering (deg)",
                "limit_deg": "limit (deg)",
                "inner": "inner radius (m)",
                "inner_body": "innermost body",
                "inner_margin": "margin (m)",
                "verdict": f"turns within {EU_OUTER:.2f} / {EU_INNER:.2f} m",
            },
        ),  # fmt: skip
        "",
    ]
    never = [r["preset"] for r in rows if r["phi_deg"] is None]
    if never:
        lines += [
            f"No steering angle brings {', '.join(never)} within 12.50 m: a steady state needs the tractor's rear"
            " axle radius above sqrt(L^2 - h^2) (R_t real), which alone puts the tractor's front corner beyond it.",
        ]
    return "\n".join(lines)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--formats", nargs="+", default=["pdf", "png"])
    args = ap.parse_args()
    v, bodies, limit = preset_vehicle(SUBJECT)
    result = eu_turning_circle(v, bodies, limit)
    rows = preset_rows()
    args.out.mkdir(parents=True, exist_ok=True)
    figure(SUBJECT, result, args.out, args.formats)
    run = result["transient"].pop("run")
    pd.DataFrame(run).iloc[::10].to_csv(args.out / "transient.csv", index=False)
    pd.DataFrame(rows).to_csv(args.out / "presets.csv", index=False)
    write_json(args.out / "turning.json", {"preset": SUBJECT, **result, "presets": rows})
    write_text(args.section, section(SUBJECT, result, rows, args.out / "turning.png"))


if __name__ == "__main__":
    main()
