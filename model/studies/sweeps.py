"""Studies built from many solves: time-energy trade-off, wheelbase sweep, grid convergence.

Every solve is kept with its status; a failed solve is a row with ``ok = False`` and
is never used as a point of a front or a sweep. Batched loops report progress on stderr.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

import numpy as np
import pandas as pd

from model.direct.resolve import Resolver
from model.problem.costs import Energy, Time
from model.problem.ocp import OCP
from model.vehicles import Truck

T = TypeVar("T")


def progress(items: Iterable[T], label: str, total: int | None = None) -> Iterator[T]:
    """Yield ``items`` while drawing a text progress bar on stderr."""
    items = list(items)
    total = total or len(items)
    for k, item in enumerate(items, 1):
        bar = "#" * (20 * k // total)
        sys.stderr.write(f"\r{label:<28} [{bar:<20}] {k}/{total}")
        sys.stderr.flush()
        yield item
    sys.stderr.write("\n")


def as_time(ocp: OCP, guess: float | None = None) -> OCP:
    """The same problem with the time objective (free Tf; ``guess`` its first value)."""
    return dataclasses.replace(ocp, cost=Time(), final_time=guess if guess is not None else ocp.final_time)


def as_energy(ocp: OCP, final_time: float) -> OCP:
    """The same problem with the energy objective at a fixed ``final_time``."""
    return dataclasses.replace(ocp, cost=Energy(), final_time=final_time)


def with_wheelbase(ocp: OCP, d: float) -> OCP:
    return dataclasses.replace(ocp, vehicle=Truck(wheelbase=d))


def row(sol, **extra) -> dict:
    """One solve as a flat record (objective, Tf, energy, status, certificate verdict)."""
    cert = sol.certificate or {}
    return {
        **extra,
        "ok": bool(sol.ok),
        "status": sol.status,
        "objective": sol.objective,
        "final_time": sol.final_time,
        "energy": sol.energy,
        "iterations": sol.iterations,
        "certificate": cert.get("passed"),
    }


def solve_best(ocp: OCP, intervals: int, guess=None, fallback: bool = True):
    """Solve warm from ``guess``; if that fails (or a time solve lands higher), also cold."""
    sol = ocp.solve(intervals=intervals, guess=guess)
    if guess is None or not fallback:
        return sol
    if sol.ok and not ocp.cost.free_final_time:
        return sol
    cold = ocp.solve(intervals=intervals)
    if cold.ok and (not sol.ok or cold.objective < sol.objective):
        return cold
    return sol


# -- time-energy trade-off --------------------------------------------------------
def pareto_front(ocp: OCP, t_min_sol, final_times: list[float], intervals: int, label: str = "") -> pd.DataFrame:
    """Energy-optimal J(Tf) for increasing Tf. The first point starts from the minimum-time
    trajectory; each next Tf re-solves the built model from the previous primal-dual point
    (``model.direct.resolve``, no rebuild), with a fresh solve if that fails."""
    rows, guess, again = [], t_min_sol.trajectory if t_min_sol.ok else None, None
    for tf in progress(final_times, f"pareto {label}"):
        sol = again.solve(final_time=tf) if again is not None else None
        if sol is None or not sol.ok:
            sol = solve_best(as_energy(ocp, tf), intervals, guess=guess)
            again = Resolver(sol) if sol.ok else None
        rows.append(row(sol, final_time_set=tf))
        if sol.ok:
            guess = sol.trajectory
    return pd.DataFrame(rows)


def front_statements(front: pd.DataFrame, cases: dict[str, tuple[float, float]], u_max: tuple[float, float]) -> dict:
    """Checks of the paper's Section 5.7 on one front: J(Tf) decreasing, C = 2 J / Tf vs its bound.

    ``cases`` maps each of the paper's cases on this front to its own solve's (Tf, J): its C is 2 J / Tf of
    that solve, the scenario table's energy over its final time. Interpolating C between the front's points
    instead overstates it (C(Tf) is convex, about L^2 / Tf^2 for a path of length L; the chord lies above it).
    """
    good = front[front.ok].sort_values("final_time_set")
    steps = np.diff(good["objective"].to_numpy())
    c_bound = u_max[0] ** 2 + u_max[1] ** 2
    c = 2 * good["objective"] / good["final_time_set"]
    return {
        "points": int(len(good)),
        "failed": int((~front.ok).sum()),
        "monotone_decreasing": bool(np.all(steps < 0)),
        "largest_increase": float(max(steps.max(initial=-math.inf), 0.0)) if len(steps) else 0.0,
        "C_bound": c_bound,
        "C_max": float(c.max()) if len(c) else None,
        "C_at_cases": {name: 2 * energy / tf for name, (tf, energy) in cases.items()},
        "C_ratio_at_tmin": float(c.iloc[0] / c_bound) if len(c) else None,
    }


# -- grid convergence ---------------------------------------------------------------
def observed_orders(values: list[float]) -> list[float | None]:
    """log2 of the ratios of successive differences (grids halving h)."""
    diffs = np.abs(np.diff(values))
    out: list[float | None] = []
    for a, b in zip(diffs[:-1], diffs[1:], strict=True):
        out.append(float(np.log2(a / b)) if a > 0 and b > 0 else None)
    return out


def costate_distance(coarse: pd.DataFrame, fine: pd.DataFrame, states: list[str]) -> float:
    """max |p_coarse - p_fine| at the coarse nodes (fine interpolated, normalised time), relative."""
    s_c = coarse["t"] / coarse["t"].iloc[-1]
    s_f = fine["t"] / fine["t"].iloc[-1]
    inner = slice(1, -1)
    worst, scale = 0.0, 1e-12
    for x in states:
        pf = np.interp(s_c, s_f, fine[f"p_{x}"])
        worst = max(worst, float(np.max(np.abs(coarse[f"p_{x}"].to_numpy()[inner] - pf[inner]))))
        scale = max(scale, float(np.max(np.abs(fine[f"p_{x}"]))))
    return worst / scale


def convergence(ocp: OCP, grids: list[int], label: str = "") -> tuple[pd.DataFrame, dict]:
    """Solve on each grid (warm from the previous one); J, Tf, costate changes and their orders."""
    rows, sols, guess = [], [], None
    for n in progress(grids, f"grids {label}"):
        sol = solve_best(ocp, n, guess=guess)
        rows.append(row(sol, intervals=n))
        sols.append(sol)
        guess = sol.trajectory if sol.ok else guess
    table = pd.DataFrame(rows)
    states = list(ocp.vehicle.states)
    dp = [costate_distance(a.trajectory, b.trajectory, states) for a, b in zip(sols[:-1], sols[1:], strict=True)]
    table["costate_change"] = [None, *dp]
    all_ok = bool(table.ok.all())
    orders = {
        "objective": observed_orders(list(table.objective)) if all_ok else None,
        "costates": [float(np.log2(a / b)) for a, b in zip(dp[:-1], dp[1:], strict=True)] if all_ok else None,
    }
    return table, orders
