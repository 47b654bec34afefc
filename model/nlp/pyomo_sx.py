"""Pyomo expressions to CasADi SX: one node walk per expression, or one per template.

A collocation model repeats one constraint template per node. ``component_rows``
asks Pyomo for the template of an indexed Constraint (``templatize_constraint``),
translates it to SX once, and applies it to all indices (a ``model.nlp.blocks.Block``);
only the lookup of each index's variables runs in Python. Components that cannot be
templatised, or whose template disagrees with a direct walk at sample indices, fall
back to walking every constraint.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from pyomo.core.expr.numeric_expr import SumExpression
from pyomo.core.expr.numvalue import native_numeric_types
from pyomo.core.expr.relational_expr import EqualityExpression, InequalityExpression, RangedExpression
from pyomo.core.expr.template_expr import GetItemExpression, IndexTemplate, templatize_constraint

from model.nlp.blocks import Block

_UNARY = {
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "asin": ca.asin, "acos": ca.acos, "atan": ca.atan,
    "exp": ca.exp, "log": ca.log, "sqrt": ca.sqrt, "abs": ca.fabs, "sinh": ca.sinh, "cosh": ca.cosh,
    "tanh": ca.tanh, "log10": ca.log10,
}  # fmt: skip


class PyomoToSX:
    """Translate Pyomo expressions to SX over given variable and parameter symbols."""

    def __init__(self, var_index: dict[int, int], x: ca.SX, param_index: dict[int, int], p: ca.SX):
        self.var_index, self.x = var_index, x
        self.param_index, self.p = param_index, p
        self._memo: dict[int, tuple[object, ca.SX]] = {}  # keeps nodes alive: ids stay unique
        self._xs: list[ca.SX] | None = None

    def _entries(self) -> list[ca.SX]:
        """The entries of x as separate SX (split once: indexing x costs a call each)."""
        if self._xs is None:
            self._xs = ca.vertsplit(self.x)
        return self._xs

    def __call__(self, node) -> ca.SX | float:
        if type(node) in native_numeric_types:
            return node
        key = id(node)
        if key in self._memo:
            return self._memo[key][1]
        out = self._convert(node)
        if node.is_expression_type():
            self._memo[key] = (node, out)
        return out

    def _convert(self, node) -> ca.SX | float:
        if node.is_expression_type():
            args = [self(a) for a in node.args]
            name = getattr(node, "getname", lambda: "")()
            if name in _UNARY and len(args) == 1:
                return _UNARY[name](args[0])
            if isinstance(node, SumExpression) and len(args) > 2:  # one call, not n - 1 additions
                return ca.sum1(ca.vertcat(*[a if isinstance(a, ca.SX) else ca.SX(a) for a in args]))
            return node._apply_operation(args)
        if node.is_variable_type():
            return float(node.value) if node.fixed else self._entries()[self.var_index[id(node)]]
        if node.is_parameter_type() and id(node) in self.param_index:
            return self.p[self.param_index[id(node)]]
        return float(pyo.value(node))


class _TemplateToSX(PyomoToSX):
    """Like PyomoToSX, but each indexed reference (x[t], p[i], t) becomes a slot symbol."""

    def __init__(self, base: PyomoToSX):
        super().__init__(base.var_index, base.x, base.param_index, base.p)
        self.slots: list[tuple[object, tuple]] = []
        self.symbols: list[ca.SX] = []
        self._slot_of: dict[str, int] = {}

    def _convert(self, node) -> ca.SX | float:
        if isinstance(node, IndexTemplate):
            return self._slot(None, (node,), f"@{node}")
        if isinstance(node, GetItemExpression):
            return self._slot(node.args[0], tuple(node.args[1:]), str(node))
        if not node.is_expression_type() and (node.is_variable_type() or node.is_parameter_type()):
            return self._slot(node, (), f"#{id(node)}")  # a scalar: the same at every index
        return super()._convert(node)

    def _slot(self, base, index_args: tuple, key: str) -> ca.SX:
        if key not in self._slot_of:
            self._slot_of[key] = len(self.slots)
            self.slots.append((base, index_args))
            self.symbols.append(ca.SX.sym(f"s{len(self.slots)}"))
        return self.symbols[self._slot_of[key]]


def _bounded(expr) -> tuple[object, object, object]:
    """(lower, body, upper) of a relational template, following Pyomo's own rule."""
    if isinstance(expr, RangedExpression):
        return expr.args
    a, b = expr.args
    if isinstance(expr, EqualityExpression):
        if not _variable(b):
            return b, a, b
        return (a, b, a) if not _variable(a) else (0, a - b, 0)
    if isinstance(expr, InequalityExpression):
        if not _variable(a):
            return a, b, None
        return (None, a, b) if not _variable(b) else (None, a - b, 0)
    raise TypeError(f"not a relational expression: {type(expr).__name__}")


def _variable(e) -> bool:
    return type(e) not in native_numeric_types and e.is_potentially_variable()


def component_rows(comp, walk: PyomoToSX, pool_extra: list[float]) -> Block | None:
    """The template of ``comp`` as a Block, or None if Pyomo cannot templatise it.

    ``pool_extra`` collects numeric per-index constants; the pool vector is
    (x, p, pool_extra).
    """
    try:
        expr, templates = templatize_constraint(comp)
        lo, body, hi = _bounded(expr)
    except Exception:  # noqa: BLE001  (any rule Pyomo cannot templatise)
        return None
    tw = _TemplateToSX(walk)
    try:
        row = ca.SX(tw(body))
    except Exception:  # noqa: BLE001
        return None
    keys = list(comp.keys())
    index = np.empty((len(tw.slots), len(keys)), dtype=np.int64)
    n_x, n_p = walk.x.numel(), walk.p.numel()
    general, own = [], [False] * len(tw.slots)
    for s, (base, args) in enumerate(tw.slots):
        if base is not None and not args:  # a scalar: one position for every index
            index[s, :] = _position(base, walk, n_x, n_p, pool_extra)
        elif base is not None and _same(args, templates) and base.ctype is pyo.Var:
            index[s, :] = _positions(base, keys, walk)  # x[t] with t the constraint's own index
            own[s] = True
        else:
            general.append(s)
    if general and not _resolve_general(tw, general, templates, keys, index, walk, pool_extra):
        return None
    block = Block(row, ca.vertcat(*tw.symbols), index, own=np.array(own, dtype=bool))
    if all(b is None or type(b) in native_numeric_types for b in (lo, hi)):
        block.bounds = (lo, hi)
    return block


def _resolve_general(tw, general, templates, keys, index, walk, pool_extra) -> bool:
    """Fill the index rows of slots like x[tp[k - 1]]; False if an index is not understood."""
    n_x, n_p = walk.x.numel(), walk.p.numel()
    try:
        columns = list(zip(*[k if isinstance(k, tuple) else (k,) for k in keys], strict=True))
        by_template = {id(t): list(col) for t, col in zip(templates, columns, strict=True)}
        for s in general:
            base, args = tw.slots[s]
            if base is None:  # the index value itself, e.g. t in a coefficient
                index[s, :] = [_constant(float(v), n_x, n_p, pool_extra) for v in by_template[id(args[0])]]
                continue
            idx = [_index_values(a, by_template, len(keys)) for a in args]
            datas = _items(base, [i[0] if len(i) == 1 else i for i in zip(*idx, strict=True)])
            index[s, :] = [_position(d, walk, n_x, n_p, pool_extra) for d in datas]
    except (TypeError, KeyError, IndexError, ValueError):
        return False
    return True


def _same(args: tuple, templates: tuple) -> bool:
    """Is the index exactly the constraint's own template index (by identity)?"""
    return len(args) == len(templates) and all(a is t for a, t in zip(args, templates, strict=True))


def _positions(base, keys: list, walk: PyomoToSX) -> list[int]:
    """x positions of base[key] for every key (free Vars only; else the slower path)."""
    where = walk.var_index
    return [where[id(d)] for d in _items(base, keys)]


def _position(data, walk: PyomoToSX, n_x: int, n_p: int, extra: list[float]) -> int:
    """Position in the pool (x, then p, then constants) of one Var, Param or number."""
    if type(data) in native_numeric_types:
        return _constant(float(data), n_x, n_p, extra)
    if data.is_variable_type() and not data.fixed:
        return walk.var_index[id(data)]
    if data.is_parameter_type() and id(data) in walk.param_index:
        return n_x + walk.param_index[id(data)]
    return _constant(float(pyo.value(data)), n_x, n_p, extra)


def _constant(value: float, n_x: int, n_p: int, extra: list[float]) -> int:
    extra.append(value)
    return n_x + n_p + len(extra) - 1


def _items(base, keys: list) -> list:
    """base[key] for every key; straight from the component's data dict when it has them all."""
    data = getattr(base, "_data", None)
    if isinstance(data, dict):
        try:
            return [data[k] for k in keys]
        except (KeyError, TypeError):
            pass
    return [base[k] for k in keys]


def _index_values(a, by_template: dict[int, list], n: int) -> list:
    """Values of a small index expression (t, k - 1, tp[k - 1]) at every index at once."""
    if type(a) in native_numeric_types:
        return [a] * n
    if isinstance(a, IndexTemplate):
        return by_template[id(a)]
    if isinstance(a, GetItemExpression):
        inner = [_index_values(b, by_template, n) for b in a.args[1:]]
        base = a.args[0]
        return _items(base, [i[0] if len(i) == 1 else i for i in zip(*inner, strict=True)])
    if isinstance(a, SumExpression):
        parts = [_index_values(b, by_template, n) for b in a.args]
        return [sum(vals) for vals in zip(*parts, strict=True)]
    raise TypeError(f"unsupported index expression {a}")
