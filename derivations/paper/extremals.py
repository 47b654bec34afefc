"""Explicit extremals (closed-form x, p, u, mu of t) and a check of every PMP condition on them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from derivations.paper.checking import compare
from derivations.pmp import PMPSystem
from derivations.symbolic import derivative_symbol
from model.vehicles import expression

T = sp.Symbol("t", real=True)


@dataclass
class Extremal:
    """Closed-form candidate: ``values`` maps every state, costate, control and multiplier
    symbol of the system to an expression in ``T``; ``params`` gives numbers for sign checks."""

    name: str
    values: dict[sp.Symbol, sp.Expr]
    horizon: float
    params: dict[sp.Symbol, float] = field(default_factory=dict)

    def at(self, expr: sp.Expr) -> sp.Expr:
        return expression(expr).subs(self.values)


def _numbers(expr: sp.Expr, params: dict, horizon: float, n: int = 9) -> np.ndarray:
    f = sp.lambdify(T, expression(expr).subs(params), "numpy")
    ts = np.linspace(0.0, horizon, n)
    return np.broadcast_to(np.asarray(f(ts), dtype=float), ts.shape)


def verify(system: PMPSystem, ext: Extremal, tol: float = 1e-9) -> dict[str, bool]:
    """Every necessary condition of the system on ``ext``: state and adjoint equations,
    maximum condition, constancy of H (and H = 0 for free Tf), multiplier sign,
    complementarity, feasibility and non-triviality."""
    params = {**system.parameters, **ext.params}
    out = {
        "state equations": all(compare(sp.diff(ext.at(s), T), ext.at(f)).equal
                               for s, f in zip(system.states, system.dynamics, strict=True)),
        "adjoint equations": all(compare(sp.diff(ext.at(p), T), ext.at(a)).equal
                                 for p, a in zip(system.costates, system.adjoint, strict=True)),
        "maximum condition": all(_maximised(system, ext, law, params, tol) for law in system.laws),
        "H constant": compare(sp.diff(ext.at(system.hamiltonian), T), 0).equal,
    }
    if system.free_final_time:
        out["H = 0 (free final time)"] = compare(ext.at(system.hamiltonian), 0).equal
    for m, c in zip(system.multipliers, system.constraints, strict=True):
        out[f"{m} >= 0"] = bool(np.all(_numbers(ext.at(m), params, ext.horizon) >= -tol))
        out[f"{m}*c = 0"] = bool(np.all(np.abs(_numbers(ext.at(m * c), params, ext.horizon)) <= 1e-7))
        out[f"c >= 0 ({m})"] = bool(np.all(_numbers(ext.at(c), params, ext.horizon) >= -1e-7))
    costs = [_numbers(ext.at(p), params, ext.horizon) for p in system.costates]
    out["(p0, p) != 0"] = system.p0 != 0 or bool(np.any(np.abs(np.array(costs)) > tol))
    return out


def _maximised(system: PMPSystem, ext: Extremal, law, params: dict, tol: float) -> bool:
    """u(t) attains max_u H at sample times (bang/singular or projection)."""
    u = _numbers(ext.at(law.control), params, ext.horizon)
    if law.kind == "projection":
        target = law.choose(_numbers(ext.at(law.stationary), params, ext.horizon))
        return bool(np.allclose(u, target, atol=1e-8))
    psi_expr = ext.at(law.switching)
    if compare(psi_expr.subs(params), 0).equal:  # singular: any admissible value maximises
        return bool(np.all((u >= law.lower - tol) & (u <= law.upper + tol)))
    psi = _numbers(psi_expr, params, ext.horizon)
    chosen = law.choose(psi, tol)
    ok = np.isnan(chosen) | np.isclose(u, chosen)
    return bool(np.all(ok) and np.all((u >= law.lower - tol) & (u <= law.upper + tol)))


def holds_all(conditions: dict[str, bool]) -> bool:
    return all(conditions.values())


def describe(conditions: dict[str, bool]) -> str:
    """'state equations: yes, ...' for evidence text."""
    return ", ".join(f"{k}: {'yes' if v else 'NO'}" for k, v in conditions.items())


def on_extremal(system: PMPSystem, ext: Extremal) -> dict[sp.Symbol, sp.Expr]:
    """Values on ``ext`` with the control and multiplier derivatives it implies (for ``singular_arc``)."""
    on = {s: ext.values[s] for s in [*system.states, *system.costates, *system.time_functions]}
    for base in system.time_functions:
        for k in range(1, 7):
            on[derivative_symbol(base, k)] = sp.diff(ext.values[base], T, k)
    return on
