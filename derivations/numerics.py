"""Numerical confirmation: do a solver's controls and costates satisfy the derived PMP conditions?

The trajectory is a DataFrame with columns t, the states, the controls, the costates
p_<state> (maximisation convention), mu (or mu1, mu2, ... for several obstacles; missing
means 0) and optionally H, as returned by ``OCP.solve(...).trajectory``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from derivations.functions import PMPFunctions, pmp_functions
from derivations.pmp import derive

if TYPE_CHECKING:
    from model.problem.ocp import OCP


@dataclass
class Confirmation:
    """Per-node evaluations (``nodes``) and their summary (``summary``: name -> number)."""

    summary: dict[str, float]
    nodes: pd.DataFrame

    def agrees(self, control_tol: float = 1e-3, h_tol: float = 2e-2) -> bool:
        """Controls match the maximum condition and H is constant (and 0 if Tf is free).

        H of a direct solution is constant only up to the discretisation error, O(h) near
        switches and contact points: the default h_tol suits N ~ 100.
        """
        ctrl = [v for k, v in self.summary.items() if k.startswith("max |u - argmax|")]
        h_ok = self.summary["H spread"] <= h_tol and self.summary.get("max |H| (free Tf)", 0.0) <= h_tol
        return all(v <= control_tol for v in ctrl) and h_ok

    def to_text(self) -> str:
        return "\n".join(f"{k}: {v:.3g}" for k, v in self.summary.items())


def confirm(trajectory: pd.DataFrame, ocp: OCP, singular_tol: float = 1e-6) -> Confirmation:
    """Evaluate the derived maximiser, H, the adjoint equations and complementarity along
    ``trajectory``. For bang-singular controls, nodes with |psi| <= singular_tol are singular
    and excluded from the control residual (counted in the summary)."""
    system = derive(ocp)
    fns = pmp_functions(ocp)
    columns = {n: trajectory[n].to_numpy(dtype=float) for n in trajectory.columns}
    missing = [n for n in fns.arguments[: 2 * len(fns.states) + len(fns.controls)] if n not in columns]
    if missing:
        raise KeyError(f"trajectory lacks column {missing[0]!r}")
    derived = fns.evaluate(columns)
    nodes = pd.DataFrame({"t": columns["t"]})
    summary: dict[str, float] = {}
    for law in system.laws:
        summary.update(_control_check(law, columns[law.control.name], derived[f"psi_{law.control.name}"], nodes,
                                      singular_tol))  # fmt: skip
    ham = derived["H"]
    nodes["H_derived"] = ham
    inner = ham[1:-1] if len(ham) > 3 else ham  # end nodes carry half-step costates
    summary["H spread"] = float(np.ptp(inner))
    if system.free_final_time:
        summary["max |H| (free Tf)"] = float(np.max(np.abs(inner)))
    if "H" in trajectory:
        summary["max |H - H column|"] = float(np.max(np.abs(ham - columns["H"])))
    summary["max adjoint residual"] = _adjoint_residual(fns, columns, derived)
    for m in fns.multipliers:
        mu = columns.get(m, np.zeros(len(ham)))
        cv = derived[f"c_{m}"]
        summary[f"min {m}"] = float(np.min(mu))
        summary[f"max |{m}*c|"] = float(np.max(np.abs(mu * cv)))
        summary[f"min c ({m})"] = float(np.min(cv))
    return Confirmation(summary, nodes)


def _control_check(law, u: np.ndarray, psi: np.ndarray, nodes: pd.DataFrame, tol: float) -> dict[str, float]:
    """Compare u with the maximiser: clip(stationary point) or the bang value from psi."""
    name = law.control.name
    if law.kind == "projection":
        predicted = law.choose(psi)
        nodes[f"{name}_tilde"] = psi
        saturated = np.mean(np.isclose(np.abs(predicted - (law.lower + law.upper) / 2),
                                       (law.upper - law.lower) / 2))
        extra = {f"fraction {name} saturated": float(saturated)}
    else:
        predicted = law.choose(psi, tol)
        nodes[f"psi_{name}"] = psi
        extra = {f"fraction {name} singular": float(np.mean(np.isnan(predicted)))}
    nodes[f"{name}_argmax"] = predicted
    gap = np.abs(u - predicted)
    worst = float(np.nanmax(gap)) if np.any(~np.isnan(gap)) else 0.0
    return {f"max |u - argmax| {name}": worst, **extra}


def _adjoint_residual(fns: PMPFunctions, columns: dict, derived: dict) -> float:
    """max over interior intervals of |(p_{k+1} - p_k)/h - (a_k + a_{k+1})/2|, a = -H_x.

    The first and last intervals are left out when there are more than two: the solver's
    end-node costates are the half-step midpoint values (see model/direct/costates.py).
    """
    t = columns["t"]
    if len(t) < 2:
        return 0.0
    inner = slice(1, -1) if len(t) > 3 else slice(None)
    h = np.diff(t)
    worst = 0.0
    for s in fns.states:
        rate = derived[f"adjoint_{s}"]
        gap = np.diff(columns[f"p_{s}"]) / h - (rate[:-1] + rate[1:]) / 2
        worst = max(worst, float(np.max(np.abs(gap[inner]))))
    return worst


def straight_drive(ocp: OCP, speed: float, nodes: int = 21) -> pd.DataFrame:
    """A synthetic exact extremal of the energy (or time) problem without active obstacles:
    driving straight along x at constant ``speed``, p_x = speed (energy) or 1/speed (time).

    Every other state, control and costate is 0 (x, the speed: the vehicle's ``roles``)."""
    tf = ocp.final_time
    t = np.linspace(0.0, tf, nodes)
    time_cost = bool(ocp.cost.free_final_time)
    px = 1.0 / speed if time_cost else speed
    h = 0.0 if time_cost else speed**2 / 2
    zeros = np.zeros_like(t)
    v, r = ocp.vehicle, ocp.vehicle.roles
    frame = {"t": t, **dict.fromkeys(v.states, zeros), r.x: speed * t}
    frame |= {**dict.fromkeys(v.controls, zeros), r.speed: zeros + speed}
    frame |= {**{f"p_{s}": zeros for s in v.states}, f"p_{r.x}": zeros + px, "mu": zeros, "H": zeros + h}
    return pd.DataFrame(frame)
