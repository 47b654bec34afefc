"""Time-energy trade-off: energy-optimal J(Tf) from the minimum time upward (warm-started continuation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from studies_common import fmt, parser, plt, save, scenario, solved, table, write_json, write_text

from derivations.paper.claims_numbers import PRINTED_RESULTS
from model.plotting.figures import ENERGY_UNIT
from model.studies.sweeps import front_statements, pareto_front

PRINTED_ENERGIES = [e for _, _, _, e, _ in PRINTED_RESULTS]  # the seed paper's printed E of its cases
# geometry (time scenario) -> the paper's energy cases on that front
FRONTS = {"s1": ("time-s1", ["s1"]), "s2": ("time-s2", ["s2-case1", "s2-case2", "s2-case3"]), "s3": ("time-s3", ["s3"])}
FIRST = 1.01  # a front's first final time, as a multiple of the minimum time
# the tables' number formats: times to 0.1 ms, J to 4 significant digits (trailing zeros kept), C to 3 decimals
FORMATS = {
    "t_min": ".4f",
    "final_time_set": ".4f",
    "objective": "#.4g",
    "C_max": ".3f",
    "C_bound": ".3f",
    "ratio": ".3f",
}


def final_times(t_min: float, t_max: float, count: int) -> list[float]:
    """Denser near the minimum time, where J(Tf) bends most."""
    s = np.linspace(0.0, 1.0, count) ** 2
    return list(t_min * FIRST + (t_max - t_min * FIRST) * s)


def one_front(results: Path, key: str, count: int, t_max: float) -> tuple[pd.DataFrame, dict, list[dict]]:
    time_name, cases = FRONTS[key]
    tmin = solved(results, time_name)
    if tmin is None:
        return pd.DataFrame(), {"error": f"{time_name} did not solve"}, []
    base = scenario(cases[0])
    sol = type("S", (), {"ok": True, "trajectory": tmin.trajectory})
    front = pareto_front(base, sol, final_times(tmin.summary["final_time"], t_max, count), base_intervals(base), key)
    front.insert(0, "front", key)
    marks = []
    for c in cases:
        r = solved(results, c)
        if r is not None:
            marks.append(
                {"front": key, "case": c, "final_time": r.summary["final_time"], "energy": r.summary["objective"]}
            )
    u = base.bounds["u1"][1], base.bounds["u2"][1]
    verdict = front_statements(front, {m["case"]: (m["final_time"], m["energy"]) for m in marks}, u)
    verdict["t_min"] = tmin.summary["final_time"]
    return front, verdict, marks


def base_intervals(ocp) -> int:
    """The grid of the paper's scenarios (N = 100)."""
    return 100


def figure(fronts: pd.DataFrame, marks: list[dict], verdicts: dict, out: Path) -> None:
    fig, ax = plt.subplots(figsize=(6, 4))
    for key, grp in fronts.groupby("front"):
        good = grp[grp.ok]
        line = ax.plot(good.final_time_set, good.objective, "o-", ms=3, label=f"{key} (energy-optimal J(Tf))")[0]
        ax.axvline(verdicts[key]["t_min"], color=line.get_color(), ls=":", lw=1)
        for m in (m for m in marks if m["front"] == key):
            ax.plot(m["final_time"], m["energy"], "*", ms=11, color=line.get_color())
            ax.annotate(
                m["case"], (m["final_time"], m["energy"]), fontsize=7, xytext=(4, 4), textcoords="offset points"
            )
    ax.set_xlabel("final time Tf [s] (dotted: minimum time)")
    ax.set_ylabel(f"J = ½∫(u1² + u2²) dt ({ENERGY_UNIT})")
    ax.legend(fontsize=8)
    save(fig, out / "pareto")


def cells(row: dict) -> dict:
    """A row as the tables print it (``FORMATS``); other and missing values unchanged."""
    return {k: format(v, FORMATS[k]) if k in FORMATS and isinstance(v, float) else v for k, v in row.items()}


def section(verdicts: dict, marks: list[dict], fronts: pd.DataFrame, fig: Path) -> str:
    rows = []
    for key, v in verdicts.items():
        if "error" in v:
            rows.append({"front": key, "note": v["error"]})
            continue
        rows.append(
            {
                "front": key,
                "t_min": v["t_min"],
                "points": v["points"],
                "failed": v["failed"],
                "monotone": v["monotone_decreasing"],
                "C_max": v["C_max"],
                "C_bound": v["C_bound"],
                "ratio": v["C_ratio_at_tmin"],
            }
        )
    samples = fronts[fronts.ok].groupby("front").apply(lambda g: g.iloc[[0, len(g) // 2, -1]], include_groups=False)
    samples = samples.reset_index(level=0).to_dict("records")
    all_mono = all(v.get("monotone_decreasing") for v in verdicts.values())
    c_rows = [
        {"case": c, "C": v["C_at_cases"][c], "C_bound": v["C_bound"]}
        for v in verdicts.values()
        if "C_at_cases" in v
        for c in v["C_at_cases"]
    ]
    max_ratio = max((v["C_ratio_at_tmin"] for v in verdicts.values() if v.get("C_ratio_at_tmin")), default=None)
    lines = [
        "## The time-energy trade-off (the paper's Section 5.7, tested)",
        "",
        "The seed paper [@seed] states that a longer final time costs less energy and that J = 1/2 C Tf with C at"
        " its upper bound for bang-bang controls. For each geometry, the energy-optimal cost J(Tf) from just above"
        " the minimum time upward, each solve warm-started from the previous one (the first from the time-optimal"
        " solution); the paper's cases are marked on their front. A failed solve is left out of the front and"
        " counted.",
        "",
        "Table: The time-energy fronts, one row per geometry: its minimum final time Tf (s), the converged"
        " energy solves on the front and the failed ones, whether J falls as Tf grows, the largest C = 2J/Tf over"
        " the front and its admissibility bound u1max² + u2max² (both m²/s² + rad²/s²), and the ratio C/bound (-)"
        " at the front's first point, just above the minimum time.",
        "",
        table(
            [cells(r) for r in rows],
            {
                "front": "geometry",
                "t_min": "min Tf (s)",
                "points": "converged",
                "failed": "failed",
                "monotone": "J decreasing in Tf",
                "C_max": "max C = 2J/Tf (m²/s² + rad²/s²)",
                "C_bound": "u1max² + u2max² (m²/s² + rad²/s²)",
                "ratio": "C/bound near min Tf (-)",
            },
        ),
        "",
        f"Table: Samples of each front (its first, middle and last converged solve): the final time Tf (s), the"
        f" energy-optimal cost J ({ENERGY_UNIT}) and the solver's iterations.",
        "",
        table(
            [cells(r) for r in samples],
            {
                "front": "geometry",
                "final_time_set": "Tf (s)",
                "objective": f"J ({ENERGY_UNIT})",
                "iterations": "iterations",
            },
        ),
        "",
        "What the fronts say about the paper's statements:",
        "",
        f"- *Longer Tf, less energy*: J(Tf) decreases monotonically on {'every' if all_mono else 'not every'} front"
        " computed here" + ("." if all_mono else " (see the table)."),
        f"- *J = 1/2 C Tf with C at its upper bound for bang-bang controls*: C = 2J/Tf never exceeds"
        f" u1max^2 + u2max^2 = {fmt(rows[0].get('C_bound'))} (admissibility), and approaches it only near the minimum"
        f" time (C/bound up to {fmt(max_ratio)} at {FIRST:g} Tmin). At the paper's cases C = 2E/Tf of each"
        " case's own solve (its E and Tf in the scenario table) is: "
        + ", ".join(f"{r['case']} {format(r['C'], FORMATS['C_max'])}" for r in c_rows)
        + ".",
        f"- The paper's printed energies ({fmt(min(PRINTED_ENERGIES))} to {fmt(max(PRINTED_ENERGIES))} {ENERGY_UNIT},"
        " derivations/paper/claims_numbers.py) lie far above every front: no admissible control reaches"
        " them (J <= 1/2 C_bound Tf).",
        "",
        f"![Energy-optimal J against Tf; stars: the paper's cases; dotted: minimum time]({fig})",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = parser(__doc__, results=True)
    ap.add_argument("--points", type=int, default=6)
    ap.add_argument("--t-max", type=float, default=3.0)
    args = ap.parse_args()
    fronts, verdicts, marks = [], {}, []
    for key in FRONTS:
        front, verdict, m = one_front(args.results, key, args.points, args.t_max)
        fronts.append(front)
        verdicts[key] = verdict
        marks += m
    allf = pd.concat(fronts, ignore_index=True)
    args.out.mkdir(parents=True, exist_ok=True)
    allf.to_csv(args.out / "pareto.csv", index=False)
    write_json(args.out / "pareto.json", {"verdicts": verdicts, "cases": marks})
    figure(allf, marks, verdicts, args.out)
    write_text(args.section, section(verdicts, marks, allf, args.out / "pareto.png"))


if __name__ == "__main__":
    main()
