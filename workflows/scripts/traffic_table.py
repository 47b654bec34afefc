"""The truck in traffic: the table over vehicle x conflicting flow x driver, the two comparisons, the section.

From the cells' JSON files (workflows/scripts/traffic_cell.py): per cell the runs' arrival and
collision rates, least distance (exact rectangles), largest braking caused, median and mean delay,
entry wait, the others' time loss with and without the truck, and the road violations; per vehicle
and driver the effective critical gap (Raff), the follow-up time, and per cell the mean wait at the
line against Adams' delay and the entry capacity against the HCM 6th edition's
(model.traffic.study.group_measures). Figures: delay and wait against the conflicting flow with
Adams' curve; capacity against the conflicting flow with the HCM curve.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from studies_common import parser, plt, table, write_text

from model.plotting.figures import save
from model.traffic.gaps import HCM_CRITICAL_GAP, HCM_FOLLOW_UP, PCE_HEAVY, adams_delay, gap_capacity, hcm_capacity
from model.traffic.study import group_measures

DRIVER_STYLE = {"autopilot": {"color": "#1f6fb4", "marker": "o"}, "sumo": {"color": "#d2691e", "marker": "s"},
                "cooperative": {"color": "#2e8b57", "marker": "^"}}  # fmt: skip


def values(runs: list[dict], key: str) -> list[float]:
    return [r[key] for r in runs if r.get(key) is not None]


def flat(c: dict) -> dict:
    """One cell as a table row."""
    runs = c["runs"]
    delay = values(runs, "delay")
    row = {"vehicle": c["vehicle"], "rate": c["rate"], "driver": c["driver"], "runs": len(runs),
           "demand_vph": 3600 * c["demand_q"],
           "arrived": float(np.mean([bool(r["arrived"]) for r in runs])) if runs else None,
           "collision_rate": float(np.mean([(r.get("collisions") or 0) > 0 for r in runs])) if runs else None,
           "road_violations": int(sum(bool(r.get("road_violation")) for r in runs)),
           "min_distance": min(values(runs, "min_distance"), default=None),
           "min_clearance": min(values(runs, "min_clearance"), default=None),
           "max_braking": max(values(runs, "max_braking_caused"), default=None),
           "delay_median": float(np.median(delay)) if delay else None,
           "delay_mean": float(np.mean(delay)) if delay else None,
           "entry_wait": float(np.mean(values(runs, "entry_wait"))) if values(runs, "entry_wait") else None,
           "others_loss": float(np.mean(values(runs, "others_time_loss"))) if runs else None,
           "others_loss_without": float(np.mean(values(runs, "others_time_loss_without_truck"))) if runs else None,
           "realtime_factor": max(values(runs, "realtime_factor"), default=None)}  # fmt: skip
    # everyone's delay per run: the truck's delay and the time the others lost because of it (their summed time loss
    # beyond the same vehicles' loss without the truck over the same span); None if the truck did not arrive
    keys = ("delay", "others_time_loss", "others_time_loss_without_truck")
    everyone = [r["delay"] + r["others_time_loss"] - r["others_time_loss_without_truck"] for r in runs
                if all(r.get(k) is not None for k in keys)]  # fmt: skip
    row["everyone"] = float(np.mean(everyone)) if everyone else None
    return row


def everyone_rows(rows: list[dict]) -> list[dict]:
    """Per vehicle and rate: each driver's mean of everyone's delay per run (the truck's delay + the others' loss)."""
    cells = {}
    for r in rows:
        cells.setdefault((r["vehicle"], r["rate"]), {"vehicle": r["vehicle"], "rate": r["rate"]})[r["driver"]] = (
            r["everyone"])
    return list(cells.values())


COLUMNS = {"vehicle": "vehicle", "rate": "veh/h per leg", "driver": "driver", "runs": "runs",
           "demand_vph": "conflicting veh/h", "arrived": "arrived", "collision_rate": "collision rate",
           "min_distance": "least distance m", "max_braking": "max braking caused m/s²",
           "delay_median": "median delay s", "entry_wait": "mean entry wait s", "others_loss": "others' loss s",
           "others_loss_without": "without truck s", "min_clearance": "least road clearance m",
           "road_violations": "road violations", "everyone": "everyone's delay s"}  # fmt: skip
EVERYONE_COLUMNS = {"vehicle": "vehicle", "rate": "veh/h per leg",
                    **{d: f"{d}: everyone's delay s" for d in DRIVER_STYLE}}  # fmt: skip
GAP_COLUMNS = {"vehicle": "vehicle", "driver": "driver", "critical_gap": "t_c (Raff) s",
               "critical_gap_at_most": "t_c at most s", "accepted": "accepted",
               "rejected": "rejected", "follow_up": "t_f s", "line_time_free": "line to entry, free s"}  # fmt: skip
COMPARE_COLUMNS = {"vehicle": "vehicle", "driver": "driver", "rate": "veh/h per leg", "vc_pcph": "v_c measured pc/h",
                   "line_wait": "wait at the line s", "adams_delay": "Adams E[W] s",
                   "capacity_pcph": "gap capacity pc/h", "hcm_capacity_pcph": "HCM capacity pc/h"}  # fmt: skip


def groups(cells: list[dict]) -> dict[tuple[str, str], dict]:
    keys = sorted({(c["vehicle"], c["driver"]) for c in cells})
    return {k: group_measures([c for c in cells if (c["vehicle"], c["driver"]) == k]) for k in keys}


def figure(cells: list[dict], measures: dict, stem: Path) -> None:
    """Wait against Adams, capacity against the HCM, for each vehicle (columns)."""
    vehicles = sorted({c["vehicle"] for c in cells})
    fig, axes = plt.subplots(2, len(vehicles), figsize=(5.2 * len(vehicles), 7.2), squeeze=False)
    qmax = max([3600 * c["demand_q"] for c in cells] + [100.0])
    vc = np.linspace(0, 1.1 * qmax, 200)
    for j, vehicle in enumerate(vehicles):
        top, bottom = axes[0, j], axes[1, j]
        bottom.plot(vc, [hcm_capacity(v) for v in vc], color="0.3", lw=1.5, label="HCM 6th ed. 1380 exp(-1.02e-3 v_c)")
        for driver, style in DRIVER_STYLE.items():
            g = measures.get((vehicle, driver))
            if not g:
                continue
            rows = g["cells"]
            x = [r["vc_pcph"] for r in rows]
            top.plot(x, [r["line_wait"] for r in rows], ls="none", ms=6, label=f"{driver}: measured", **style)
            tc, tf = g["critical_gap"], g["follow_up"]
            if tc is not None:
                top.plot(vc, [adams_delay(v / 3600, tc) for v in vc], color=style["color"], lw=1.2,
                         label=f"{driver}: Adams, t_c = {tc:.2f} s")  # fmt: skip
                if tf:
                    bottom.plot(vc, [PCE_HEAVY * 3600 * gap_capacity(v / 3600, tc, tf) for v in vc],
                                color=style["color"], lw=1.2, label=f"{driver}: gap capacity, t_f = {tf:.2f} s")
        top.set(title=vehicle, xlabel="conflicting flow at the entry (veh/h, measured)",
                ylabel="mean wait at the line beyond free flow (s)")  # fmt: skip
        bottom.set(xlabel="conflicting flow v_c (pc/h)", ylabel="entry capacity (pc/h, truck = 2 pc)", ylim=(0, None))
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
    fig.tight_layout()
    save(fig, stem)


def section(rows, gap_rows, compare_rows, mode: str, grid: dict, figure_path: str, extra: str) -> str:
    return f"""## The truck in traffic

The truck drives through the four-leg 40 m roundabout of `workflows/scenarios/traffic/` among SUMO
traffic (docs/traffic-format.md): every other leg sends a random (Poisson) stream of passenger cars of
the given rate, exits shared equally, no U-turns. The drivers on the same seeds: the project's
`autopilot` (its plan's path, with a speed profile chosen against the predicted vehicles), SUMO's
own driver model moving a vehicle of the truck's length (the baseline; SUMO has no trailers, so its
truck's trailer is reconstructed and off-tracks as it would) and the `cooperative` mode (the autopilot
among connected vehicles that are held out of the ring's areas while the truck occupies them; an
experimental first version). Every distance is between exact rectangles; a failed run is counted,
never dropped.

Grid run: **{mode}** (vehicles {', '.join(grid['vehicles'])}; {', '.join(f'{r:g}' for r in grid['rates'])} veh/h per
leg; {grid['runs']} seeds from {grid['seed']}); the full grid is `traffic_study: full` in
workflows/config.yaml.

{table(rows, COLUMNS)}

**Everyone's delay.** Per run the truck's delay plus the time the other vehicles lost because of the truck:
their summed time loss (SUMO's `timeLoss`, up to the run's end) less the same vehicles' loss in the run
without the truck over the same span ("others' loss s" less "without truck s" above); the mean over the
cell's runs, the same seeds for every driver:

{table(everyone_rows(rows), EVERYONE_COLUMNS)}

**Gap acceptance.** The conflicting stream is measured where the truck enters: the times at which
circulating vehicles cross the ray along the entry leg's axis across the ring roadway. The gap the
truck accepted is the headway of that stream containing its entry (its front bumper crossing the outer
curb); the gaps it rejected are the complete headways between its arrival within 10 m of the curb and
its entry. The effective critical gap t_c is Raff's: the t at which the number of accepted gaps
shorter than t equals the number of rejected gaps longer than t. With no rejected gap there is no
estimate, only an upper bound (the shortest accepted gap, "t_c at most"), and no Adams delay or gap
capacity is computed from it. The follow-up time t_f is the truck's mean entry occupancy
(front bumper in to the rear of its last body in), a lower bound of a queued truck's follow-up headway.

{table(gap_rows, GAP_COLUMNS)}

**Against traffic engineering.** Adams' delay E[W] = (exp(q t_c) - 1 - q t_c) / q is the mean wait
of a vehicle arriving at random at a Poisson stream of rate q that needs a gap t_c; the measured wait
is the mean time from the line (10 m before the curb) to the entry beyond the same time at zero flow.
The entry capacity of gap-accepting trucks on a Poisson stream is Siegloch's c = exp(-q (t_c - t_f / 2)) / t_f,
counted as 2 passenger cars per truck, beside the HCM 6th edition's single-lane entry capacity
c = 1380 exp(-1.02e-3 v_c) (pc/h) at the measured conflicting flow, itself Siegloch's form with
t_f = {HCM_FOLLOW_UP:.2f} s and t_c = {HCM_CRITICAL_GAP:.2f} s for passenger cars. With t_f the truck's entry
occupancy (a lower bound of a queued truck's follow-up time) the truck's capacity is an upper bound.

{table(compare_rows, COMPARE_COLUMNS)}

{extra}

![Wait against Adams' delay and capacity against the HCM]({figure_path})
"""


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--cells", type=Path, nargs="+", required=True)
    ap.add_argument("--mode", required=True)
    ap.add_argument("--vehicles", nargs="+", required=True)
    ap.add_argument("--rates", type=float, nargs="+", required=True)
    ap.add_argument("--runs", type=int, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--figure-link", required=True, help="the figure's path as the paper links it")
    ap.add_argument("--extra", type=Path, help="a Markdown fragment appended (the run figures' links)")
    args = ap.parse_args()
    cells = [json.loads(p.read_text()) for p in args.cells]
    cells.sort(key=lambda c: (c["vehicle"], c["rate"], c["driver"]))
    rows = [flat(c) for c in cells]
    args.out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(args.out / "table.csv", index=False)
    measures = groups(cells)
    gap_rows = [{"vehicle": v, "driver": d, **{k: g[k] for k in GAP_COLUMNS if k in g}}
                for (v, d), g in measures.items()]  # fmt: skip
    compare_rows = [{"vehicle": v, "driver": d, **r} for (v, d), g in measures.items() for r in g["cells"]]
    (args.out / "measures.json").write_text(json.dumps({f"{v}/{d}": g for (v, d), g in measures.items()}, indent=2))
    figure(cells, measures, args.out / "comparison")
    grid = {"vehicles": args.vehicles, "rates": args.rates, "runs": args.runs, "seed": args.seed}
    extra = args.extra.read_text() if args.extra else ""
    write_text(args.section, section(rows, gap_rows, compare_rows, args.mode, grid, args.figure_link, extra))


if __name__ == "__main__":
    main()
