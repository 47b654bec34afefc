"""Wheelbase sweep: minimum time and energy at a fixed Tf against d (paper scale and a real truck)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from studies_common import parser, save, scenario, table, write_text

from model.plotting.figures import ENERGY_UNIT
from model.plotting.studies import wheelbase_figure
from model.studies.sweeps import as_energy, progress, row, solve_best, with_wheelbase

# sweep name -> (time scenario, energy scenario, fixed Tf for the energy solves, wheelbases)
SWEEPS = {
    "paper s2": ("time-s2", "s2-case2", None, [0.01, 0.02, 0.04]),
    "paper s3": ("time-s3", "s3", None, [0.01, 0.02, 0.04]),
    "real s2": ("time-real-s2", "time-real-s2", 10.0, [4.0, 5.0, 6.0]),
}
TF_DECIMALS = 4  # decimals of the minimum time in the table
J_DIGITS = 5  # significant digits of J in the table


def sweep(label: str, time_name: str, energy_name: str, tf: float | None, ds: list[float]) -> list[dict]:
    """Time solves start cold; each energy solve warm-starts from the previous d's solution."""
    t_ocp, e_ocp = scenario(time_name), scenario(energy_name)
    tf = tf or e_ocp.final_time
    rows, e_guess = [], None
    for d in progress(ds, f"wheelbase {label}"):
        ts = with_wheelbase(t_ocp, d).solve(intervals=100)  # cold: the file's guess is robust
        if e_guess is None and ts.ok:
            e_guess = ts.trajectory
        rows.append({**row(ts, sweep=label, d=d, kind="time"), "fixed_tf": None})
        if ts.ok and ts.final_time > tf:
            rows.append(_infeasible(label, d, tf))
            continue
        es = solve_best(as_energy(with_wheelbase(e_ocp, d), tf), 100, guess=e_guess)
        rows.append({**row(es, sweep=label, d=d, kind="energy"), "fixed_tf": tf})
        e_guess = es.trajectory if es.ok else e_guess
    return rows


def _infeasible(label: str, d: float, tf: float) -> dict:
    """Not solved: the fixed Tf is below this wheelbase's minimum time, so no control is admissible."""
    return {
        "sweep": label,
        "d": d,
        "kind": "energy",
        "ok": False,
        "status": "Tf below min time",
        "objective": None,
        "final_time": tf,
        "energy": None,
        "iterations": 0,
        "certificate": None,
        "fixed_tf": tf,
    }


def figure(frame: pd.DataFrame, out: Path) -> None:
    """Both panels relative to the same reference per sweep (model.plotting.studies.wheelbase_figure)."""
    save(wheelbase_figure(frame), out / "wheelbase")


def section(frame: pd.DataFrame, fig: Path) -> str:
    rows = []
    for (label, d), g in frame.groupby(["sweep", "d"], sort=False):
        t, e = g[g.kind == "time"].iloc[0], g[g.kind == "energy"].iloc[0]
        rows.append(
            {
                "sweep": label,
                "d": d,
                "tmin": f"{t.final_time:.{TF_DECIMALS}f}" if t.ok else None,
                "t_status": t.status,
                "tf": e.fixed_tf,
                "J": f"{e.objective:#.{J_DIGITS}g}" if e.ok else None,  # '#': trailing zeros kept
                "e_status": e.status,
                "cert": bool(t.certificate) and bool(e.certificate),
            }
        )
    return "\n".join(
        [
            "## The wheelbase d",
            "",
            "Minimum time and energy-optimal cost at a fixed final time against the wheelbase (the turning radius"
            " d / tan(phi) grows with d and the steering rate |u2| <= 0.35 rad/s limits how fast phi can change)."
            " Each d starts from the previous d's solution; a failed solve is listed with its status and not"
            " plotted.",
            "",
            "Table: The wheelbase sweeps, one row per sweep and wheelbase d (m): the minimum final time (s) and the"
            " status of its solve, the fixed final time Tf (s) of the energy solve, its energy-optimal cost J"
            f" ({ENERGY_UNIT}) and status, and whether both solutions pass their optimality certificates; d and the"
            f" fixed Tf as set, the minimum time to {TF_DECIMALS} decimals, J to {J_DIGITS} significant digits.",
            "",
            table(
                rows,
                {
                    "sweep": "sweep",
                    "d": "d (m)",
                    "tmin": "min Tf (s)",
                    "t_status": "time status",
                    "tf": "fixed Tf (s)",
                    "J": f"J at fixed Tf ({ENERGY_UNIT})",
                    "e_status": "energy status",
                    "cert": "certificates pass",
                },
                digits=5,
            ),
            "",
            f"![Minimum time and energy against the wheelbase (normalised by their medians)]({fig})",
        ]
    )


def main() -> None:
    ap = parser(__doc__)
    args = ap.parse_args()
    frame = pd.DataFrame([r for label, spec in SWEEPS.items() for r in sweep(label, *spec)])
    args.out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out / "wheelbase.csv", index=False)
    figure(frame, args.out)
    write_text(args.section, section(frame, args.out / "wheelbase.png"))


if __name__ == "__main__":
    main()
