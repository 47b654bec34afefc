"""SymPy expressions (the problem's one definition) as Pyomo expressions."""

from __future__ import annotations

import functools
import operator

import pyomo.environ as pyo
import sympy as sp

_FUNCS = {
    sp.sin: pyo.sin,
    sp.cos: pyo.cos,
    sp.tan: pyo.tan,
    sp.atan: pyo.atan,
    sp.exp: pyo.exp,
    sp.log: pyo.log,
    sp.asin: pyo.asin,
    sp.acos: pyo.acos,
}


def sympy_to_pyomo(expr: sp.Expr, env: dict[sp.Symbol, object]):
    """Translate a SymPy expression into a Pyomo one, symbols looked up in ``env``."""
    if expr.is_Symbol:
        return env[expr]
    if expr.is_Integer:
        return int(expr)
    if expr.is_Number:
        return float(expr)
    args = [sympy_to_pyomo(a, env) for a in expr.args]
    if expr.is_Add:  # not sum(): Pyomo's templatize_constraint replaces it
        return functools.reduce(operator.add, args)
    if expr.is_Mul:
        return functools.reduce(operator.mul, args)
    if expr.is_Pow:
        base, exp = args
        return pyo.sqrt(base) if expr.exp == sp.Rational(1, 2) else base**exp
    if expr.func in _FUNCS:
        return _FUNCS[expr.func](args[0])
    raise NotImplementedError(f"cannot translate {expr.func} to Pyomo")
