"""The paper's section on road scenarios: a table read from the results, and the figures."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from model.plotting.results import fmt
from model.problem.scenario import load_scenario


def row(scenario: Path, results: Path) -> str:
    sc = load_scenario(scenario)
    ocp = sc.ocp
    s = json.loads((results / scenario.stem / "summary.json").read_text())
    bodies = ", ".join(f"{n} {b.length:.2f} x {b.width:.2f} m" for n, b in ocp.bodies.items())
    ok = "valid" if s.get("valid") else f"FAILED ({(s.get('diagnosis') or {}).get('message', s.get('status'))})"
    return (f"| {ocp.name} | {ocp.vehicle.model} ({bodies}) | exit {ocp.road.route.exit} of "
            f"{len(ocp.road.roundabout.legs)}, {ocp.road.roundabout.traffic}-hand | {s.get('objective_name')} | "
            f"{fmt(s.get('final_time'))} | {fmt(s.get('energy'))} | {s.get('exit_taken')} | "
            f"{fmt(s.get('min_clearance'), 3)} | {fmt(s.get('min_clearance_dense'), 3)} | {s.get('iterations')} "
            f"| {ok} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", type=Path, nargs="+", required=True)
    ap.add_argument("--results", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    lines = [
        "## Real roundabouts and vehicle bodies",
        "",
        "Roundabouts with a ring, an apron, legs with entry and exit lanes and curb fillets "
        "(docs/roundabout-format.md); the vehicle's body is a rectangle (for a semitrailer, two), kept in the "
        "route's corridor by equal cover discs in the NLP and checked as exact rectangles against the exact "
        "corridor at every node. Clearances are the smallest distance from a body to the edge of its allowed "
        "region (negative: an encroachment); \"between nodes\" is measured on linearly interpolated states.",
        "",
        "| scenario | vehicle | route | objective | Tf (s) | energy | exit taken | clearance at nodes (m) "
        "| between nodes (m) | iterations | result |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        *(row(s, args.results) for s in args.scenarios),
        "",
    ]
    for s in args.scenarios:
        lines += [f"![{s.stem}: the manoeuvre to scale, bodies every few nodes, swept areas, controls]"
                  f"(results/figures/roads/{s.stem}.png)", ""]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))


if __name__ == "__main__":
    main()
