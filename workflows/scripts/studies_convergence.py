"""Discretisation study: J, Tf and the costates on N = 100, 200, 400, 800 with observed orders."""

from __future__ import annotations

import math

import pandas as pd
from studies_common import parser, scenario, table, write_json, write_text

from model.plotting.figures import ENERGY_UNIT
from model.studies.sweeps import convergence


def decimals(change: float | None) -> int | None:
    """Decimals that reach the leading digit of ``change`` (J's last change between grids); None if unknown."""
    if change is None or not math.isfinite(change) or change <= 0:
        return None
    return max(0, -math.floor(math.log10(change)))


def printed(row: dict) -> dict:
    """A row as the table prints it: J to the decimal of its last change, the costate change as 1.23e-04."""
    out = dict(row)
    places = decimals(row.get("last_change"))
    if row.get("objective") is not None and places is not None:
        out["objective"] = f"{row['objective']:.{places}f}"
    if row.get("costate_change") is not None:
        out["costate_change"] = f"{row['costate_change']:.2e}"
    return out


def section(rows: list[dict], ladders: dict) -> str:
    return "\n".join(
        [
            "## Grid convergence",
            "",
            "Each scenario on successively halved grids (warm-started from the coarser solution; a time-optimal"
            " solve is also started cold and the better kept, since warm starts can land in another local"
            " minimum). Observed order = log2 of the ratio of successive differences; the trapezoid rule is"
            " second order for smooth solutions [@betts2010], the switches and obstacle contacts lower it. Costate"
            " change = max |p_N - p_2N| at the coarse nodes, relative to max |p|.",
            "",
            "Table: Grid convergence, one row per scenario: its grids N (intervals), the objective J on the finest"
            " grid in the unit of its row (the final time for a time-optimal scenario; printed to the decimal of its"
            " last change), the changes of J between"
            " successive grids (same unit), the observed orders of J (-), the relative costate change on the"
            " finest pair of grids (-) and the observed orders of the costates p (-).",
            "",
            table(
                [printed(r) for r in rows],
                {
                    "scenario": "scenario",
                    "grids": "N",
                    "objective": "J, finest N",
                    "unit": "unit of J",
                    "diffs": "successive change of J (unit of J)",
                    "order_J": "order of J (-)",
                    "costate_change": "costate change, finest N (-)",
                    "order_p": "order of p (-)",
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
                "last_change": diffs[-1] if ok and diffs else None,
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
