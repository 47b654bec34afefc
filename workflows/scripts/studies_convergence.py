"""Discretisation study: J, Tf and the costates on N = 100, 200, 400, 800 with observed orders."""

from __future__ import annotations

import pandas as pd
from studies_common import parser, scenario, table, write_json, write_text

from model.plotting.figures import ENERGY_UNIT
from model.studies.sweeps import convergence


def section(rows: list[dict], ladders: dict) -> str:
    return "\n".join(
        [
            "## Grid convergence",
            "",
            "Each scenario on successively halved grids (warm-started from the coarser solution; a time-optimal"
            " solve is also started cold and the better kept, since warm starts can land in another local"
            " minimum). Observed order = log2 of the ratio of successive differences; the trapezoid rule is"
            " second order for smooth solutions, the switches and obstacle contacts lower it. Costate change ="
            " max |p_N - p_2N| at the coarse nodes, relative to max |p|.",
            "",
            table(
                rows,
                {
                    "scenario": "scenario",
                    "grids": "N",
                    "objective": "J (finest)",
                    "unit": "unit of J",
                    "diffs": "successive change of J",
                    "order_J": "order of J",
                    "costate_change": "costate change (finest)",
                    "order_p": "order of p",
                },
                digits=4,
            ),
            "",
            "Grids per scenario: " + "; ".join(f"`{k}` {v}" for k, v in ladders.items()) + ".",
        ]
    )


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--scenarios", nargs="+", required=True, help="name or name:N1,N2,...")
    args = ap.parse_args()
    frames, summary, rows, ladders = [], {}, [], {}
    for spec in args.scenarios:
        name, _, grids = spec.partition(":")
        ladder = [int(g) for g in grids.split(",")] if grids else [100, 200, 400, 800]
        ladders[name] = ladder
        frame, orders = convergence(scenario(name), ladder, name)
        frame.insert(0, "scenario", name)
        frames.append(frame)
        summary[name] = orders
        ok = bool(frame.ok.all())
        diffs = frame.objective.diff().abs().dropna().tolist()
        time = scenario(name).cost.objective == "time"
        rows.append(
            {
                "scenario": name,
                "unit": "s (the final time)" if time else ENERGY_UNIT,
                "grids": ",".join(map(str, ladder)),
                "objective": frame.objective.iloc[-1] if ok else None,
                "diffs": ", ".join(f"{d:.2e}" for d in diffs) if ok else "failed: " + ",".join(frame.status),
                "order_J": ", ".join(f"{o:.2f}" for o in orders["objective"] if o is not None) if ok else None,
                "costate_change": frame.costate_change.iloc[-1] if ok else None,
                "order_p": ", ".join(f"{o:.2f}" for o in orders["costates"]) if ok else None,
            }
        )
    args.out.mkdir(parents=True, exist_ok=True)
    pd.concat(frames, ignore_index=True).to_csv(args.out / "convergence.csv", index=False)
    write_json(args.out / "convergence.json", {"orders": summary, "rows": rows})
    write_text(args.section, section(rows, ladders))


if __name__ == "__main__":
    main()
