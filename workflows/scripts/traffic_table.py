"""The truck in traffic: the tables over vehicle x conflicting flow x driver, the critical gaps, the comparisons.

From the cells' JSON files (workflows/scripts/traffic_cell.py): per cell the runs arrived and with a
collision (runs / runs), least distance (exact rectangles), the strongest braking caused beside the same
runs without the truck, the truck's delay (median, mean ± 95 % CI), everyone's delay (mean ± 95 % CI),
road violations; the critical gaps (Raff's and the maximum-likelihood one, with their spreads) of SUMO's
cars at their entries and of the truck at its own; the measured waits against Adams' delay and
Siegloch's capacity against the HCM 6th edition's (model.traffic.study). The figure: waits against
the conflicting flow with Adams' curve; capacity against the conflicting flow with the HCM curve.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats
from studies_common import parser, table, write_text

from model.plotting.figures import save
from model.traffic.gaps import HCM_CRITICAL_GAP, HCM_FOLLOW_UP
from model.traffic.study import FORMULA_MIN_DRIVERS, everyone_delay, group_measures, others_delay, others_measures

DRIVER_STYLE = {"autopilot": {"color": "#1f6fb4", "marker": "o"}, "sumo": {"color": "#d2691e", "marker": "s"},
                "cooperative": {"color": "#2e8b57", "marker": "^"},
                "reservation": {"color": "#8b2e7a", "marker": "v"}}  # fmt: skip


def rounded(rows: list[dict], digits: int = 9) -> list[dict]:
    """The rows with every float rounded to ``digits`` decimals (a wait of -4e-15 s is 0 s)."""
    return [{k: round(v, digits) + 0.0 if isinstance(v, float) else v for k, v in r.items()} for r in rows]


def values(runs: list[dict], key: str) -> list[float]:
    return [r[key] for r in runs if r.get(key) is not None]


def mean_ci(x: list[float]) -> tuple[float | None, float | None]:
    """The mean and the half-width of its 95 % confidence interval (Student's t; None with fewer than 2 values)."""
    if not x:
        return None, None
    if len(x) < 2:
        return float(x[0]), None
    return float(np.mean(x)), float(stats.t.ppf(0.975, len(x) - 1) * np.std(x, ddof=1) / np.sqrt(len(x)))


def pm(mean: float | None, half: float | None, n: int | None = None) -> str:
    """``mean ± half (n)`` for a table cell ('-' without a mean)."""
    if mean is None:
        return "-"
    text = f"{mean:.3g}" + (f" ± {half:.2g}" if half is not None else "")
    return text + (f" (n={n})" if n is not None else "")


def of(k: int, n: int) -> str:
    return f"{k}/{n}"


HARDER = 0.1  # m/s^2: braking caused counted as harder than without the truck beyond this (SUMO's speeds print 1e-2)


def everyone(runs: list[dict]) -> list[float]:
    """Per run the truck's delay plus the others' loss because of it (``model.traffic.study.everyone_delay``)."""
    return [e for r in runs if (e := everyone_delay(r)) is not None]


def others(runs: list[dict]) -> list[float]:
    """Per run the time the others lost because of the truck (``model.traffic.study.others_delay``)."""
    return [o for r in runs if (o := others_delay(r)) is not None]


def flat(c: dict) -> dict:
    """One cell as a table row (numbers for the CSV, texts for the Markdown)."""
    runs = c["runs"]
    n = len(runs)
    delay, caused = values(runs, "delay"), values(runs, "max_braking_caused")
    alone = values(runs, "max_braking_without_truck")
    harder = sum(1 for r in runs if (r.get("max_braking_caused") or 0.0)
                 > (r.get("max_braking_without_truck") or 0.0) + HARDER)  # fmt: skip
    arrived = sum(bool(r["arrived"]) for r in runs)
    collided = sum((r.get("collisions") or 0) > 0 for r in runs)
    violations = sum(bool(r.get("road_violation")) for r in runs)
    d_mean, d_half = mean_ci(delay)
    e_mean, e_half = mean_ci(everyone(runs))
    o_mean, o_half = mean_ci(others(runs))
    return {"vehicle": c["vehicle"], "rate": c["rate"], "driver": c["driver"], "runs": n,
            "demand_vph": 3600 * c["demand_q"], "arrived": arrived, "arrived_text": of(arrived, n),
            "collided": collided, "collided_text": of(collided, n), "road_violations": violations,
            "violations_text": of(violations, n), "min_distance": min(values(runs, "min_distance"), default=None),
            "min_clearance": min(values(runs, "min_clearance"), default=None),
            "lateral_text": lateral_text(runs),
            "max_braking": max(caused, default=None), "max_braking_without": max(alone, default=None),
            "harder": harder, "harder_text": of(harder, n),
            "delay_median": float(np.median(delay)) if delay else None, "delay_mean": d_mean, "delay_ci": d_half,
            "delay_text": pm(d_mean, d_half), "entry_wait": mean_ci(values(runs, "entry_wait"))[0],
            "others": o_mean, "others_ci": o_half, "others_text": pm(o_mean, o_half),
            "everyone": e_mean, "everyone_ci": e_half, "everyone_text": pm(e_mean, e_half),
            "realtime_factor": max(values(runs, "realtime_factor"), default=None)}  # fmt: skip


def lateral_text(runs: list[dict]) -> str:
    """The largest |lateral acceleration| any run drove (every row of its trajectory.csv) and the truck's bound."""
    driven, bound = values(runs, "lateral_driven"), values(runs, "lateral_bound")
    if not driven:
        return "-"
    return f"{max(driven):.2f}" + (f" (bound {max(bound):g})" if bound else "")


def everyone_rows(cells: list[dict]) -> list[dict]:
    """Per vehicle and rate: each driver's everyone's delay, mean ± 95 % CI over the same seeds."""
    out: dict[tuple, dict] = {}
    for c in cells:
        got = everyone(c["runs"])
        row = out.setdefault((c["vehicle"], c["rate"]), {"vehicle": c["vehicle"], "rate": c["rate"]})
        row[c["driver"]] = pm(*mean_ci(got), len(got))
    return list(out.values())


CELL = {"vehicle": "vehicle", "rate": "flow entering per other leg (veh/h)", "driver": "driver"}
SAFETY_COLUMNS = CELL | {
    "arrived_text": "arrived (runs / runs)",
    "collided_text": "with a collision (runs / runs)",
    "min_distance": "least distance to another vehicle (m)",
    "violations_text": "leaving the road (runs / runs)",
    "lateral_text": "largest lateral acceleration driven (m/s², every row)",
}
BRAKING_COLUMNS = CELL | {
    "max_braking": "strongest braking caused (m/s²)", "max_braking_without": "same runs without the truck (m/s²)",
    "harder_text": "braking harder than without the truck (runs / runs)"}  # fmt: skip
DELAY_COLUMNS = CELL | {
    "demand_vph": "conflicting demand at the truck's entry (veh/h)",
    "delay_median": "truck's delay, median (s)",
    "delay_text": "truck's delay, mean ± 95 % CI (s)",
    "entry_wait": "truck stood before the line, mean (s)",
}
GAP_COLUMNS = {"who": "drivers at the line", "drivers": "drivers (offers used)", "rejected": "rejected gaps",
               "raff_text": "t_c Raff ± bootstrap SE (s)", "mle_text": "t_c max. likelihood ± SE (s)",
               "mle_sd": "spread of the drivers' t_c (s, log-normal SD)", "follow_up": "t_f (s)",
               "line_time_free": "line to entry without a rejected gap, median (s)"}  # fmt: skip
CARS_COLUMNS = {
    "rate": "flow entering per other leg (veh/h)",
    "leg": "entry leg",
    "vc_pcph": "conflicting flow v_c (pc/h, measured)",
    "observed": "cars at the line",
    "line_wait": "measured wait at the line (s, mean)",
    "adams_delay": "Adams E[W] (s)",
    "capacity_pcph": "gap capacity, Siegloch (pc/h)",
    "hcm_capacity_pcph": "HCM 6th ed. capacity (pc/h)",
}
TRUCK_COLUMNS = {"vehicle": "vehicle", "driver": "driver", "rate": "flow entering per other leg (veh/h)",
                 "vc_pcph": "conflicting flow v_c (pc/h, measured)", "observed": "runs entered",
                 "line_wait": "measured wait at the line (s, mean)", "adams_delay": "Adams E[W], own t_c (s)",
                 "adams_reference": "Adams E[W], the cars' t_c (s)",
                 "hcm_capacity_pcph": "HCM 6th ed. capacity (pc/h)"}  # fmt: skip


def groups(cells: list[dict], reference_gap: float | None) -> dict[tuple[str, str], dict]:
    keys = sorted({(c["vehicle"], c["driver"]) for c in cells})
    return {k: group_measures([c for c in cells if (c["vehicle"], c["driver"]) == k], reference_gap) for k in keys}


def gap_row(who: str, g: dict) -> dict:
    used = f"{g['drivers']}"
    return g | {"who": who, "drivers": used, "raff_text": pm(g["raff"], g["raff_se"]) if g["raff"] is not None else (
        f"at most {g['raff_at_most']:.3g}" if g.get("raff_at_most") is not None else "-"),
        "mle_text": pm(g["mle"], g["mle_se"])}  # fmt: skip


def figure(cars: dict, measures: dict, stem: Path) -> None:
    """Measured waits against Adams' delay; Siegloch's capacity with the measured gaps against the HCM's
    (model.plotting.studies.comparison_figure)."""
    from model.plotting.studies import comparison_figure
    from model.traffic.gaps import HCM_BASE, HCM_SLOPE, adams_delay, gap_capacity, hcm_capacity

    formulas = {"adams_delay": adams_delay, "gap_capacity": gap_capacity, "hcm_capacity": hcm_capacity,
                "hcm_label": f"HCM 6th ed. {HCM_BASE:g} exp(-{HCM_SLOPE:.3g} $v_c$)"}  # fmt: skip
    save(comparison_figure(cars, measures, DRIVER_STYLE, formulas), stem)


def findings(cars: dict) -> str:
    """One sentence on the cars' critical gap against the HCM's and their waits against Adams' delay."""
    if cars["critical_gap"] is None:
        return "No critical gap of SUMO's cars could be estimated on this grid (no rejected gap, or too few drivers)."
    est = (
        f"SUMO's cars: t_c = {pm(cars['mle'], cars['mle_se'])} s by maximum likelihood"
        if cars["mle"] is not None
        else f"SUMO's cars: Raff's t_c = {cars['raff']:.3g} s"
    )
    pairs = [(r["line_wait"], r["adams_delay"]) for r in cars["cells"] if r.get("line_wait") is not None
             and r.get("adams_delay") is not None]  # fmt: skip
    waits = ""
    if pairs:
        measured, adams = float(np.mean([w for w, _ in pairs])), float(np.mean([a for _, a in pairs]))
        waits = (
            f"; over {len(pairs)} flow-and-leg cells their mean measured wait is {measured:.2f} s against Adams'"
            f" {adams:.2f} s (measured minus Adams {measured - adams:+.2f} s)"
        )
    return (
        f"**Result.** {est} from {cars['drivers']} drivers and {cars['rejected']} rejected gaps, against the"
        f" HCM's passenger-car t_c of {HCM_CRITICAL_GAP:.2f} s{waits}."
    )


def section(tables: dict[str, str], mode: str, grid: dict, figure_path: str, extra: str, result: str) -> str:
    return f"""## The truck in traffic

The truck drives through the four-leg 40 m roundabout of `workflows/scenarios/traffic/` among SUMO
traffic [@sumo2018] (docs/traffic-format.md): every other leg sends a random (Poisson) stream of passenger cars of
the given rate, exits shared equally, no U-turns. The drivers on the same seeds: the project's
`autopilot` (its plan's path, with a speed profile chosen against the predicted vehicles), SUMO's
own driver model moving a vehicle of the truck's length (the baseline; SUMO has no trailers, so its
truck's trailer is reconstructed and off-tracks as it would), the `cooperative` mode (the autopilot
among connected vehicles; it asks the vehicles about to meet it in its entry's area to keep out of the
part it occupies, only while it would otherwise wait and once its lost time exceeds what the hold costs
them) and the `reservation` baseline (first come, first served on the ring's areas after Dresner and
Stone's intersection management [@dresner2008]: cars arriving after the truck keep out of its areas
while it occupies them). Every distance is between exact rectangles; a failed run is counted, never dropped.

Grid run: **{mode}** (vehicles {", ".join(grid["vehicles"])}; {", ".join(f"{r:g}" for r in grid["rates"])} veh/h per
leg; drivers {", ".join(grid["drivers"])}; {grid["runs"]} seeds from {grid["seed"]}). A larger grid's results are
committed as benchmarks/traffic-study.md (its header names the grid and the command that wrote it; the full grid's:
`snakemake -c2 --config traffic_study=full -- benchmarks/traffic-study.md`).

Table: Safety per vehicle, flow and driver (over the runs): arrivals, collisions, the least distance between
exact rectangles, runs in which a body left the road, and the largest lateral acceleration the truck drove at any row
of its trajectory against its bound (the autopilot's: the tracked motion, which may exceed the plan's bound; SUMO's
driver's: reconstructed from SUMO's poses, a vType having no lateral limit).

{tables["safety"]}

Table: Braking caused per vehicle, flow and driver: the strongest deceleration of another vehicle within 50 m
of the truck, beside the same seeds' traffic replayed without the truck (SUMO's cars brake up to 4.5 m/s² at
the entries on their own); a run brakes harder when the first exceeds the second by more than {HARDER} m/s².

{tables["braking"]}

Table: The truck's delay per vehicle, flow and driver: travel time less the same driver's without other traffic.

{tables["delay"]}

Table: Everyone's delay (s, mean ± 95 % CI over n runs, Student's t), the drivers on the same seeds: the truck's
delay plus the others' summed SUMO time loss less the same vehicles' loss without the truck over the same span.

{tables["everyone"]}

**Gap acceptance.** Every driver at an entry is observed, SUMO's passenger cars at their legs as
well as the truck at its own: a driver is at the line from when its front comes within 10 m of the
outer curb (or, in a queue, from when the vehicle ahead entered) until its front crosses the curb. The
conflicting stream of an entry is the times circulating vehicles (the truck included) cross the ray
along the leg's axis across the ring roadway. The offered intervals start at the arrival (the lag,
then the stream's headways); the one containing the entry is accepted, the earlier ones rejected; an
accepted gap cut by the run's end is left out. Raff's t_c [@raff1950] is where the number of accepted gaps shorter
than t equals the number of rejected gaps longer than t (its standard error by resampling the drivers,
200 draws); the maximum-likelihood t_c is Troutbeck's (each consistent driver's critical gap between its
longest rejected and its accepted gap, the drivers' critical gaps log-normal; the mean, its standard
error from the likelihood's curvature, and the drivers' spread). t_f: the cars' entry headway when a
queued car took the same gap as the one ahead; the truck's is its entry occupancy (front in to the last
rear in), a lower bound.

Table: Critical gaps (s) of the drivers at the line.

{tables["gaps"]}

**Against traffic engineering.** Adams' delay [@adams1936] E[W] = (exp(q t_c) - 1 - q t_c) / q is the mean wait
of a driver arriving at random at a Poisson stream of rate q who needs a gap t_c (the estimate above,
the maximum-likelihood one where there is one); the measured wait is the mean line-to-entry time beyond
the median of the drivers who took the first gap offered (queued cars that followed the one ahead left
out). Siegloch's entry capacity [@siegloch1973] c = exp(-q (t_c - t_f / 2)) / t_f with the cars' measured t_c and t_f
is set beside the HCM 6th edition's [@hcm2016] single-lane entry capacity c = 1380 exp(-1.02e-3 v_c) (pc/h, v_c the
conflicting flow in pc/h; Exhibit 22-12), itself Siegloch's with t_f = {HCM_FOLLOW_UP:.2f} s and
t_c = {HCM_CRITICAL_GAP:.2f} s. The capacities are formulas at the measured v_c; the runs do not saturate
the entries, so no capacity is measured.

Table: SUMO's cars per flow and entry leg: measured waits against Adams, Siegloch's capacity against the HCM's.

{tables["cars"]}

Table: The truck's waits at its line against Adams' delay with its own critical gap (from {FORMULA_MIN_DRIVERS}
entries with a rejected gap among them) and with the cars' critical gap.

{tables["truck"]}

{result}

{extra}

![Measured waits against Adams' delay; Siegloch's capacity against the HCM 6th edition's]({figure_path})
"""


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--cells", type=Path, nargs="+", required=True)
    ap.add_argument("--mode", required=True)
    ap.add_argument("--vehicles", nargs="+", required=True)
    ap.add_argument("--rates", type=float, nargs="+", required=True)
    ap.add_argument("--drivers", nargs="+", default=["autopilot", "sumo", "cooperative", "reservation"])
    ap.add_argument("--runs", type=int, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--figure-link", required=True, help="the figure's path as the paper links it")
    ap.add_argument("--extra", type=Path, help="a Markdown fragment appended (the run figures' links)")
    args = ap.parse_args()
    cells = [json.loads(p.read_text()) for p in args.cells]
    cells.sort(key=lambda c: (c["vehicle"], c["rate"], c["driver"]))
    rows = [flat(c) for c in cells]
    args.out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).drop(columns=[k for k in rows[0] if k.endswith("_text")] if rows else []).to_csv(
        args.out / "table.csv", index=False
    )
    cars = others_measures(cells)
    measures = groups(cells, cars["critical_gap"])
    gap_rows = [gap_row("SUMO's passenger cars, every entry", cars)]
    gap_rows += [gap_row(f"{v} ({d}) at its entry", g) for (v, d), g in measures.items()]
    truck_rows = [{"vehicle": v, "driver": d, **r} for (v, d), g in measures.items() for r in g["cells"]]
    (args.out / "measures.json").write_text(json.dumps({"cars": cars} | {f"{v}/{d}": g for (v, d), g in
                                                                           measures.items()}, indent=2))  # fmt: skip
    figure(cars, measures, args.out / "comparison")
    grid = {
        "vehicles": args.vehicles,
        "rates": args.rates,
        "runs": args.runs,
        "seed": args.seed,
        "drivers": args.drivers,
    }
    extra = args.extra.read_text() if args.extra else ""
    drivers = sorted({c["driver"] for c in cells})
    tables = {"safety": table(rows, SAFETY_COLUMNS), "braking": table(rows, BRAKING_COLUMNS),
              "delay": table(rows, DELAY_COLUMNS),
              "gaps": table(gap_rows, GAP_COLUMNS),
              "everyone": table(everyone_rows(cells), {"vehicle": "vehicle", "rate": "flow per other leg (veh/h)",
                                                       **{d: f"{d} (s)" for d in drivers}}),
              "cars": table(rounded(cars["cells"]), CARS_COLUMNS),
              "truck": table(rounded(truck_rows), TRUCK_COLUMNS)}  # fmt: skip
    write_text(args.section, section(tables, args.mode, grid, args.figure_link, extra, findings(cars)))


if __name__ == "__main__":
    main()
