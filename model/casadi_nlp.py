"""A pynumero ``NLP`` for a Pyomo model, with exact derivatives from CasADi SX.

Pyomo's own cyipopt route needs the ASL library, which cannot be built here; this
class walks the model's active constraints and objective into CasADi SX once,
generates sparse Jacobian and Lagrangian-Hessian functions, and serves them to
pynumero's ``CyIpoptNLP`` through persistent buffers. Mutable Params become CasADi
parameters, so their values may change between solves without a rebuild.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from pyomo.contrib.pynumero.interfaces.nlp import NLP
from pyomo.core.expr.numvalue import native_numeric_types
from scipy.sparse import coo_matrix

_UNARY = {
    "sin": ca.sin,
    "cos": ca.cos,
    "tan": ca.tan,
    "asin": ca.asin,
    "acos": ca.acos,
    "atan": ca.atan,
    "exp": ca.exp,
    "log": ca.log,
    "sqrt": ca.sqrt,
    "abs": ca.fabs,
    "sinh": ca.sinh,
    "cosh": ca.cosh,
    "tanh": ca.tanh,
    "log10": ca.log10,
}


class PyomoToSX:
    """Translate Pyomo expressions to SX over given variable and parameter symbols."""

    def __init__(self, var_index: dict[int, int], x: ca.SX, param_index: dict[int, int], p: ca.SX):
        self.var_index, self.x = var_index, x
        self.param_index, self.p = param_index, p
        self._memo: dict[int, tuple[object, ca.SX]] = {}  # keeps nodes alive: ids stay unique

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
            return node._apply_operation(args)
        if node.is_variable_type():
            if node.fixed:
                return float(node.value)
            return self.x[self.var_index[id(node)]]
        if node.is_parameter_type() and id(node) in self.param_index:
            return self.p[self.param_index[id(node)]]
        return float(pyo.value(node))


class CasadiNLP(NLP):
    """pynumero NLP of a Pyomo model (one active minimising objective) via CasADi."""

    def __init__(self, model: pyo.Block):
        self.model = model
        self.variables = [v for v in model.component_data_objects(pyo.Var, descend_into=True) if not v.fixed]
        self.constraints = list(model.component_data_objects(pyo.Constraint, active=True, descend_into=True))
        self.params = [
            q for q in model.component_data_objects(pyo.Param, descend_into=True) if q.parent_component().mutable
        ]
        objectives = list(model.component_data_objects(pyo.Objective, active=True, descend_into=True))
        if len(objectives) != 1:
            raise ValueError(f"expected one active objective, found {len(objectives)}")
        self.objective = objectives[0]
        self._sense = 1.0 if self.objective.sense == pyo.minimize else -1.0
        self._build_functions()
        self._x = self.init_primals()
        self._y = np.zeros(self.n_constraints())
        self._sigma = np.ones(1)
        self._p = np.array([float(pyo.value(q)) for q in self.params])

    # -- construction ---------------------------------------------------------
    def _build_functions(self) -> None:
        n, m = len(self.variables), len(self.constraints)
        x, p = ca.SX.sym("x", n), ca.SX.sym("p", len(self.params))
        walk = PyomoToSX(
            {id(v): i for i, v in enumerate(self.variables)}, x, {id(q): i for i, q in enumerate(self.params)}, p
        )
        g_exprs, self._bound_exprs = [], []
        for con in self.constraints:
            lo, body, hi = con.to_bounded_expression(evaluate_bounds=False)
            g_exprs.append(walk(body))
            self._bound_exprs.append((lo, hi))
        self._evaluate_bounds()
        g = ca.vertcat(*[ca.SX(e) for e in g_exprs]) if g_exprs else ca.SX(0, 1)
        f = self._sense * ca.SX(walk(self.objective.expr))
        sigma, lam = ca.SX.sym("sigma"), ca.SX.sym("lam", m)
        jac = ca.jacobian(g, x)
        hess = ca.tril(ca.hessian(sigma * f + ca.dot(lam, g), x)[0])
        self._jac_rc = jac.sparsity().get_triplet()
        self._hess_rc = hess.sparsity().get_triplet()
        args = [x, p]
        self._fns = {
            "f": _Buffered(ca.Function("f", args, [f]), 1),
            "grad": _Buffered(ca.Function("grad", args, [ca.densify(ca.gradient(f, x))]), n),
            "g": _Buffered(ca.Function("g", args, [g]), m),
            "jac": _Buffered(ca.Function("jacobian_g", args, [jac]), jac.nnz()),
            "hess": _Buffered(ca.Function("hessian_lag", [x, p, sigma, lam], [hess]), hess.nnz()),
        }

    # -- sizes and bounds -------------------------------------------------------
    def n_primals(self) -> int:
        return len(self.variables)

    def n_constraints(self) -> int:
        return len(self.constraints)

    def nnz_jacobian(self) -> int:
        return len(self._jac_rc[0])

    def nnz_hessian_lag(self) -> int:
        return len(self._hess_rc[0])

    def primals_lb(self) -> np.ndarray:
        return np.array([-np.inf if v.lb is None else v.lb for v in self.variables], dtype=float)

    def primals_ub(self) -> np.ndarray:
        return np.array([np.inf if v.ub is None else v.ub for v in self.variables], dtype=float)

    def constraints_lb(self) -> np.ndarray:
        return self._gl.copy()

    def constraints_ub(self) -> np.ndarray:
        return self._gu.copy()

    def init_primals(self) -> np.ndarray:
        vals = [v.value for v in self.variables]
        return np.array([0.0 if a is None else a for a in vals], dtype=float)

    def init_duals(self) -> np.ndarray:
        return np.zeros(self.n_constraints())

    def create_new_vector(self, vector_type: str) -> np.ndarray:
        size = self.n_primals() if vector_type.startswith("primal") else self.n_constraints()
        return np.zeros(size)

    # -- state -------------------------------------------------------------------
    def set_primals(self, primals: np.ndarray) -> None:
        np.copyto(self._x, primals)

    def get_primals(self) -> np.ndarray:
        return self._x.copy()

    def set_duals(self, duals: np.ndarray) -> None:
        np.copyto(self._y, duals)

    def get_duals(self) -> np.ndarray:
        return self._y.copy()

    def set_obj_factor(self, obj_factor: float) -> None:
        self._sigma[0] = obj_factor

    def get_obj_factor(self) -> float:
        return float(self._sigma[0])

    def refresh_parameters(self) -> None:
        """Re-read mutable Param values and the constraint bounds that use them."""
        self._p[:] = [float(pyo.value(q)) for q in self.params]
        self._evaluate_bounds()

    def _evaluate_bounds(self) -> None:
        """Constraint bounds may be Param expressions: evaluate them now."""
        self._gl = np.array([-np.inf if lo is None else pyo.value(lo) for lo, _ in self._bound_exprs], dtype=float)
        self._gu = np.array([np.inf if hi is None else pyo.value(hi) for _, hi in self._bound_exprs], dtype=float)

    def get_obj_scaling(self):
        return None

    def get_primals_scaling(self):
        return None

    def get_constraints_scaling(self):
        return None

    # -- evaluations ---------------------------------------------------------------
    def evaluate_objective(self) -> float:
        return float(self._fns["f"](self._x, self._p)[0])

    def evaluate_grad_objective(self, out: np.ndarray | None = None) -> np.ndarray:
        return _emit(self._fns["grad"](self._x, self._p), out)

    def evaluate_constraints(self, out: np.ndarray | None = None) -> np.ndarray:
        return _emit(self._fns["g"](self._x, self._p), out)

    def evaluate_jacobian(self, out: coo_matrix | None = None) -> coo_matrix:
        data = self._fns["jac"](self._x, self._p)
        if out is not None:
            np.copyto(out.data, data)
            return out
        rows, cols = self._jac_rc
        return coo_matrix((data.copy(), (rows, cols)), shape=(self.n_constraints(), self.n_primals()))

    def evaluate_hessian_lag(self, out: coo_matrix | None = None) -> coo_matrix:
        data = self._fns["hess"](self._x, self._p, self._sigma, self._y)
        if out is not None:
            np.copyto(out.data, data)
            return out
        rows, cols = self._hess_rc
        n = self.n_primals()
        return coo_matrix((data.copy(), (rows, cols)), shape=(n, n))

    def report_solver_status(self, status_code, status_message) -> None:
        self.status = (status_code, status_message)

    # -- back into Pyomo -------------------------------------------------------------
    def load_primals(self, x: np.ndarray) -> None:
        """Write primal values into the Pyomo variables."""
        for v, val in zip(self.variables, x, strict=True):
            v.set_value(float(val), skip_validation=True)

    def load_duals(self, mult_g: np.ndarray) -> None:
        """Store constraint duals in ``model.dual`` with Pyomo's sign convention.

        Ipopt's Lagrangian is f + mult_g . g; Pyomo (AMPL) reports -mult_g for a
        minimisation (Pyomo issue 2831), i.e. d(objective)/d(constraint bound).
        """
        if not hasattr(self.model, "dual"):
            self.model.dual = pyo.Suffix(direction=pyo.Suffix.IMPORT)
        for con, lam in zip(self.constraints, mult_g, strict=True):
            self.model.dual[con] = -self._sense * float(lam)


class _Buffered:
    """A CasADi Function called through persistent numpy buffers (no copies per call)."""

    def __init__(self, fn: ca.Function, n_out: int):
        self.fn = fn
        self.buf, self.trigger = fn.buffer()
        self.out = np.zeros(n_out)
        self.buf.set_res(0, memoryview(self.out))

    def __call__(self, *args: np.ndarray) -> np.ndarray:
        for i, a in enumerate(args):
            self.buf.set_arg(i, memoryview(np.ascontiguousarray(a, dtype=float)))
        self.trigger()
        return self.out


def _emit(values: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    if out is None:
        return values.copy()
    np.copyto(out, values)
    return out
