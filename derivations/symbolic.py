"""Symbols the derivations add to a model: costates, multipliers, obstacle data, time derivatives."""

from __future__ import annotations

import sympy as sp

from model.vehicles import sym


def costate(state: str) -> sp.Symbol:
    """The costate p_<state> of a state (maximisation convention)."""
    return sym(f"p_{state}")


def positive(name: str) -> sp.Symbol:
    """A real positive symbol (multipliers, radii, wheelbase-like parameters)."""
    return sp.Symbol(name, real=True, positive=True)


def multiplier(index: int, count: int) -> sp.Symbol:
    """mu (one obstacle) or mu1, mu2, ... (several), the state-constraint multiplier density.

    Declared real, not positive: the sign is a condition to check, not an assumption.
    """
    return sym("mu" if count == 1 else f"mu{index + 1}")


def obstacle_symbols(index: int, count: int) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbolic centre (x_obs, y_obs) and keep-out radius R of obstacle ``index``."""
    tag = "" if count == 1 else str(index + 1)
    return sym(f"x_obs{tag}"), sym(f"y_obs{tag}"), positive(f"R{tag}")


def circle_constraint(x: sp.Expr, y: sp.Expr, xo: sp.Expr, yo: sp.Expr, radius: sp.Expr) -> sp.Expr:
    """c = dist((x, y), (xo, yo)) - R, kept >= 0 (the paper's (3))."""
    return sp.sqrt((x - xo) ** 2 + (y - yo) ** 2) - radius


def derivative_symbol(base: sp.Symbol, order: int) -> sp.Symbol:
    """The symbol for the ``order``-th time derivative of a time function such as u1 or mu."""
    if order == 0:
        return base
    marks = "'" * order if order <= 2 else f"^({order})"
    return sp.Symbol(f"{base.name}{marks}", real=True)


def latex_names(symbols: list[sp.Symbol], max_order: int = 6) -> dict[sp.Symbol, str]:
    """LaTeX names for the derivative symbols of ``symbols`` (dots, then bracketed orders)."""
    names: dict[sp.Symbol, str] = {}
    for base in symbols:
        tex = sp.latex(base)
        for k in range(1, max_order + 1):
            if k == 1:
                names[derivative_symbol(base, k)] = rf"\dot{{{tex}}}"
            elif k == 2:
                names[derivative_symbol(base, k)] = rf"\ddot{{{tex}}}"
            else:
                names[derivative_symbol(base, k)] = rf"{tex}^{{({k})}}"
    return names
