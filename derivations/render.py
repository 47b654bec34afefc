"""Readable text and LaTeX renderings of a PMPSystem."""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy as sp

from derivations.symbolic import latex_names

if TYPE_CHECKING:
    from derivations.pmp import ControlLaw, PMPSystem


def tex(system: PMPSystem, expr: sp.Expr) -> str:
    """LaTeX of an expression with dotted names for derivative symbols."""
    return sp.latex(expr, symbol_names=latex_names(system.time_functions))


def _kind(system: PMPSystem) -> str:
    return "abnormal (p0 = 0)" if system.abnormal else "normal (p0 = -1)"


def _law_text(law: ControlLaw) -> list[str]:
    u, lo, hi = law.control, law.lower, law.upper
    if law.kind == "bang-singular":
        return [
            f"  psi_{u} = dH/d{u} = {sp.sstr(law.switching)}",
            f"  {u} = {hi:g} if psi_{u} > 0, {lo:g} if psi_{u} < 0, "
            f"singular (any value in [{lo:g}, {hi:g}]) if psi_{u} = 0 on an interval",
        ]
    return [
        f"  dH/d{u} = {sp.sstr(law.switching)},  d2H/d{u}2 = {sp.sstr(law.curvature)} < 0",
        f"  {u}~ = {sp.sstr(law.stationary)}  (stationary point, the unconstrained maximiser)",
        f"  {u} = clip({u}~, {lo:g}, {hi:g})  (H strictly concave in {u}: no singular arc)",
    ]


def pmp_text(system: PMPSystem) -> str:
    """Plain-text rendering: H, adjoints, maximum condition, constancy, transversality."""
    lines = [f"PMP system of {system.name!r}, {_kind(system)}, maximisation convention", ""]
    path = f" + {sp.sstr(system.path_terms)}" if system.path else ""
    lines.append(f"H = {sp.sstr(system.hamiltonian)}{path}")
    lines.append("")
    lines.append("State equations:")
    lines += [f"  {s}' = {sp.sstr(f)}" for s, f in zip(system.states, system.dynamics, strict=True)]
    lines.append("Adjoint equations (p' = -dH/dx" + (", path constraints adjoined" if system.path else "") + "):")
    adjoint = [a + r for a, r in zip(system.adjoint, system.path_adjoint, strict=True)]
    lines += [f"  {p}' = {sp.sstr(a)}" for p, a in zip(system.costates, adjoint, strict=True)]
    if system.constraints:
        lines.append("State constraints (c >= 0, multiplier >= 0, multiplier*c = 0):")
        lines += [f"  {m}: {sp.sstr(c)} >= 0"
                  for m, c in zip(system.multipliers, system.constraints, strict=True)]
    lines += _path_text(system)
    lines.append("Maximum condition:")
    for law in system.laws:
        lines += _law_text(law)
    lines += _first_derivatives_text(system)
    lines.append("Hamiltonian: " + _constancy(system))
    lines.append("Transversality:")
    lines += [f"  {sp.sstr(eq.lhs)} = 0" for eq in system.transversality()] or ["  none (all fixed)"]
    lines.append("Parameters: " + ", ".join(f"{k} = {v:g}" for k, v in system.parameters.items()))
    lines += [f"Note: {n}" for n in system.notes]
    return "\n".join(lines)


def _path_text(system: PMPSystem) -> list[str]:
    """The adjoined path constraints: each family's multiplier and constraint, the bodies' points."""
    if not system.path:
        return []
    lines = ["Path constraints adjoined to H (multiplier densities, trajectory.csv columns mu_<family>):"]
    shown = set()
    for f in system.path:
        if f.point is not None and f.name.rsplit("_", 1)[0] not in shown:
            body = f.name.rsplit("_", 1)[0]
            shown.add(body)
            x, y = (sp.sstr(q) for q in f.point)
            lines.append(f"  points i = 1..n_{body} of the {body}: (X_i, Y_i) = ({x}, {y})")
        lines.append(f"  {f.name}: {sp.sstr(f.multiplier)}, {f.description}")
    if any(f.point is not None for f in system.path):
        lines.append(
            "  c_<family>_X, c_<family>_Y: the gradient of the family's constraint at the point; "
            "the terms -sum_j mu_j dc_j/dx above are these gradients times d(X_i, Y_i)/dx"
        )
    return lines


def _first_derivatives_text(system: PMPSystem) -> list[str]:
    out = []
    for law in system.laws:
        if law.kind == "bang-singular":
            d1 = sp.simplify(system.time_derivative(law.switching))
            out.append(f"  d/dt psi_{law.control} = {sp.sstr(d1)}")
    return out


def _constancy(system: PMPSystem) -> str:
    if not system.autonomous:
        return "non-autonomous: not constant in general"
    base = "autonomous, so H is constant along extremals"
    return base + (" and H = 0 (free final time)" if system.free_final_time else " (fixed final time)")


def _law_latex(system: PMPSystem, law: ControlLaw) -> list[str]:
    u = sp.latex(law.control)
    lo, hi = f"{law.lower:g}", f"{law.upper:g}"
    if law.kind == "bang-singular":
        psi = rf"\psi_{{{u}}}"
        return [
            rf"{psi} = \frac{{\partial H}}{{\partial {u}}} = {tex(system, law.switching)}",
            rf"{u} = \begin{{cases}} {hi} & {psi} > 0 \\ {lo} & {psi} < 0 \\ "
            rf"\in [{lo}, {hi}] & {psi} \equiv 0 \text{{ (singular)}} \end{{cases}}",
        ]
    return [
        rf"\frac{{\partial H}}{{\partial {u}}} = {tex(system, law.switching)}, \quad "
        rf"\frac{{\partial^2 H}}{{\partial {u}^2}} = {tex(system, law.curvature)} < 0",
        rf"\tilde{{{u}}} = {tex(system, law.stationary)}, \quad "
        rf"{u}^* = \Pi_{{[{lo}, {hi}]}}(\tilde{{{u}}})",
    ]


def pmp_latex(system: PMPSystem) -> str:
    """LaTeX rendering (Markdown with $$ blocks)."""
    out = [f"**PMP system of `{system.name}`**, {_kind(system)}, maximisation convention."]
    path = f" + {tex(system, system.path_terms)}" if system.path else ""
    out.append(rf"$$H = {tex(system, system.hamiltonian)}{path}$$")
    adjoint = [a + r for a, r in zip(system.adjoint, system.path_adjoint, strict=True)]
    eqs = [rf"\dot{{{sp.latex(p)}}} &= {tex(system, a)}" for p, a in zip(system.costates, adjoint, strict=True)]
    out.append(r"$$\begin{aligned}" + r" \\ ".join(eqs) + r"\end{aligned}$$")
    for law in system.laws:
        out += [f"$${line}$$" for line in _law_latex(system, law)]
    trans = [sp.latex(eq) for eq in system.transversality()]
    out.append(f"Hamiltonian: {_constancy(system)}.")
    out.append("Transversality: " + (", ".join(f"${t}$" for t in trans) if trans else "none."))
    params = ", ".join(f"${sp.latex(k)} = {v:g}$" for k, v in system.parameters.items())
    out.append(f"Parameters: {params}.")
    out += [
        f"Path constraint `{f.name}` (multiplier ${tex(system, f.multiplier)}$): {f.description}." for f in system.path
    ]
    out += [f"Note: {n}." for n in system.notes]
    return "\n\n".join(out)
