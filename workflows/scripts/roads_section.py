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
    return (
        f"| {ocp.name} | {ocp.vehicle.model} ({bodies}) | exit {ocp.road.route.exit} of "
        f"{len(ocp.road.roundabout.legs)}, {ocp.road.roundabout.traffic}-hand | {s.get('objective_name')} | "
        f"{fmt(s.get('final_time'))} | {fmt(s.get('energy'))} | {s.get('exit_taken')} | "
        f"{fmt(s.get('min_clearance'), 3)} | {fmt(s.get('min_clearance_dense'), 3)} | {s.get('iterations')} "
        f"| {ok} |"
    )


def animation(gif: Path) -> list[str]:
    """The paragraph embedding the animated GIF (the PDF shows its first frame)."""
    return [
        f"![{gif.stem}, animated: the vehicle drives its optimal trajectory; each body's swept path grows "
        "behind it, the dotted line is the rear axle's path ahead. (In the PDF: the first frame; the HTML "
        f"paper plays it, and it is `{gif.as_posix()}` in the results.)]({gif.as_posix()})",
        "",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", type=Path, nargs="+", required=True)
    ap.add_argument("--results", type=Path, required=True)
    ap.add_argument("--animation", type=Path, help="a GIF of one road (results/figures/roads/<road>.gif)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    lines = [
        "## Real roundabouts and vehicle bodies",
        "",
        "Roundabouts with a ring, an apron, legs with entry and exit lanes and curb fillets "
        "(docs/roundabout-format.md); the vehicle's body is a rectangle (for a semitrailer, two), kept in the "
        "route's corridor by equal cover discs in the NLP and checked as exact rectangles against the exact "
        "corridor at every node. Clearances are the smallest distance from a body to the edge of its allowed "
        'region (negative: an encroachment); "between nodes" is measured on linearly interpolated states.',
        "",
        "| scenario | vehicle | route | objective | Tf (s) | energy | exit taken | clearance at nodes (m) "
        "| between nodes (m) | iterations | result |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        *(row(s, args.results) for s in args.scenarios),
        "",
    ]
    for s in args.scenarios:
        lines += [
            f"![{s.stem}: the plan to scale (curbs, hatched truck apron, central island, centre and "
            "give-way lines), each body's swept path outlined, the bodies along the path, the axle tracks; "
            "right: speed u1, steering rate u2, steering angle phi and, for a trailer, the "
            f"articulation angle over time, their bounds dashed](results/figures/roads/{s.stem}.png)",
            "",
        ]
    if args.animation:
        lines += animation(args.animation)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))


if __name__ == "__main__":
    main()
