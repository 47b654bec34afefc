"""Time-optimal study: minimum times, arc structure, chattering, and the rate-penalty regularisation."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from studies_common import fmt, parser, save, solved, table, write_json, write_text

from model.analysis.arcs import arc_structure
from model.plotting.studies import time_controls_figure
from model.problem.costs import Time
from model.studies.roads import limits_note
from model.studies.sweeps import progress

EPSILONS = [1e-5, 1e-4]
REAL_SCALE = 1.0  # m: a wheelbase from here up is a vehicle's, not the paper's model scale (d = 0.02 m)
REFERENCE_PRESET = "SU-30"  # the design vehicle whose operational limits the real truck (d = 5 m) is set beside


def describe(name: str, res) -> dict:
    """Minimum time, certificate verdict and arc structure of one pipeline solve."""
    if res is None:
        return {"name": name, "ok": False}
    arcs = arc_structure(res)
    cert = res.summary.get("certificate", {})
    ham = cert.get("items", {}).get("hamiltonian", {})
    ocp = res.ocp
    return {
        "name": name,
        "ok": True,
        "final_time": res.summary["final_time"],
        "wheelbase": ocp.vehicle.wheelbase,
        "u1_max": ocp.max_speed(),
        "max_abs_lateral_acceleration": (res.summary.get("lateral_acceleration") or {}).get("max_abs_nodes"),
        "certificate": cert.get("passed"),
        "H_deviation": ham.get("value"),
        "H_tolerance": ham.get("tolerance"),
        "adjoint_residual": cert.get("items", {}).get("adjoint", {}).get("value"),
        "structure_u1": arcs["controls"]["u1"]["structure"],
        "structure_u2": arcs["controls"]["u2"]["structure"],
        "switches_u2": [round(t, 4) for t in arcs["controls"]["u2"]["switching_times"]],
        "chattering": arcs["chattering_detected"],
        "chattering_windows": arcs["chattering"],
        "straight_arcs": arcs["straight_arcs"],
        "boundary_arcs": arcs["boundary_arcs"],
    }


def regularise(res, name: str) -> list[dict]:
    """Re-solve with Time(rate_penalty=eps), warm from the plain solution; Tf and chattering."""
    out = []
    for eps in progress(EPSILONS, f"regularise {name}"):
        ocp = dataclasses.replace(res.ocp, cost=Time(rate_penalty=eps))
        sol = ocp.solve(intervals=len(res.trajectory) - 1, guess=res.trajectory)
        arcs = arc_structure(sol) if sol.ok else None
        out.append(
            {
                "name": name,
                "eps": eps,
                "ok": sol.ok,
                "final_time": sol.final_time if sol.ok else None,
                "increase": sol.final_time - res.summary["final_time"] if sol.ok else None,
                "chattering": arcs["chattering_detected"] if arcs else None,
                "structure_u2": arcs["controls"]["u2"]["structure"] if arcs else None,
            }
        )
    return out


def figure(results: dict, out: Path) -> None:
    """Controls of each time-optimal solve over its bounds, chattering windows shaded and not drawn
    (model.plotting.studies.time_controls_figure)."""
    runs = []
    for name, res in results.items():
        if res is not None:
            windows = arc_structure(res)["chattering"]
            runs.append((name, res.trajectory, {c: res.ocp.bounds[c] for c in ("u1", "u2")}, windows))
    save(time_controls_figure(runs), out / "controls")


def limits_lines(rows: list[dict]) -> list[str]:
    """What the real-scale rows (the seed paper's model, kept exactly) are beside a design vehicle's limits."""
    real = [r for r in rows if r["wheelbase"] >= REAL_SCALE]
    if not real:
        return []
    return [
        f"The real-truck rows are the seed paper's model (1) **without operational limits** (the speed a control), "
        f"kept as it is; set beside the operational limits of the {REFERENCE_PRESET}, the AASHTO single-unit truck "
        "nearest to this d = 5 m truck (docs/dynamics-format.md; the road sections run it at those limits):",
        "",
        *(
            f"- `{r['name']}`: {limits_note(REFERENCE_PRESET, False, r['max_abs_lateral_acceleration'])}." for r in real
        ),  # fmt: skip
        "",
    ]


def section(rows: list[dict], reg: list[dict], fig: Path) -> str:
    ok = [r for r in rows if r["ok"]]
    failed = [r["name"] for r in rows if not r["ok"]]
    lines = [
        "## Time-optimal manoeuvres (the paper's Section 3, solved)",
        "",
        "Minimum time with a free final time, at the paper's scale (d = 0.02 m, |u1| <= 1 m/s) and for a"
        " real truck (d = 5 m, |u1| <= 10 m/s, the paper's geometry scaled by 68). Each solve carries a"
        " Pontryagin certificate (`model/analysis/certificate.py`): the adjoint residual, the deviation of H from"
        " 0 against the allowance for switches lying on the grid, the maximum condition, transversality"
        " and complementarity. Arc structure: `+`/`-` upper/lower bound, `s` strictly inside the bounds"
        " (a singular arc or a junction), read from the controls and switching functions (`model/analysis/arcs.py`).",
        "",
        table(
            ok,
            {
                "name": "scenario",
                "wheelbase": "d [m]",
                "u1_max": "u1 max",
                "final_time": "min Tf [s]",
                "max_abs_lateral_acceleration": "max abs(a_lat) [m/s^2]",
                "structure_u1": "u1 arcs",
                "structure_u2": "u2 arcs",
                "chattering": "chattering",
                "certificate": "certificate",
                "H_deviation": "max abs(H)",
                "H_tolerance": "H allowance",
                "adjoint_residual": "adjoint residual",
            },
            digits=5,
        ),
        "",
        *limits_lines(ok),
    ]
    if failed:
        lines += [f"Failed (not shown): {', '.join(failed)}.", ""]
    for r in ok:
        if r["straight_arcs"]:
            spans = ", ".join(f"[{fmt(a['t0'])}, {fmt(a['t1'])}] s" for a in r["straight_arcs"])
            lines.append(f"- `{r['name']}`: straight singular arcs (u2 = 0, phi = 0) on {spans}.")
        if r["boundary_arcs"]:
            b = max(r["boundary_arcs"], key=lambda a: a["nodes"])
            lines.append(
                f"- `{r['name']}`: {len(r['boundary_arcs'])} contact run(s) with the obstacle, the longest"
                f" {b['nodes']} node(s) at |phi| = {fmt(b['mean_abs_phi'])} (a boundary arc predicts"
                f" atan(d/R) = {fmt(b['predicted_phi'])})."
            )
        for c, wins in r["chattering_windows"].items():
            for w in wins:
                lines.append(
                    f"- `{r['name']}`: {c} chatters on [{fmt(w['t0'])}, {fmt(w['t1'])}] s"
                    f" ({w['reversals']} reversals): reported, not plotted as a control."
                )
    lines += [
        "",
        "The rate penalty eps sum_k (u_{k+1} - u_k)^2 / h (`Time(rate_penalty=eps)`) regularises the"
        " junctions; its cost in final time (the certificate is that of the unregularised problem and is"
        " not expected to pass for eps > 0):",
        "",
        table(
            reg,
            {
                "name": "scenario",
                "eps": "eps",
                "final_time": "Tf [s]",
                "increase": "Tf increase [s]",
                "chattering": "chattering",
                "structure_u2": "u2 arcs",
            },
            digits=6,
        ),
        "",
        f"![Controls of the time-optimal solves (the seed paper's model without operational limits), scaled by their"
        f" bounds; chattering windows shaded]({fig})",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = parser(__doc__, results=True)
    ap.add_argument("--scenarios", nargs="+", required=True)
    ap.add_argument("--regularise", nargs="*", default=[])
    args = ap.parse_args()
    results = {n: solved(args.results, n) for n in args.scenarios}
    rows = [describe(n, r) for n, r in results.items()]
    reg = [x for n in args.regularise if results.get(n) is not None for x in regularise(results[n], n)]
    write_json(args.out / "time.json", {"scenarios": rows, "regularisation": reg})
    figure(results, args.out)
    write_text(args.section, section(rows, reg, args.out / "controls.png"))


if __name__ == "__main__":
    main()
