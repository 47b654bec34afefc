"""A pynumero ``NLP`` for a Pyomo model, with exact derivatives from CasADi SX.

Pyomo's own cyipopt route needs the ASL library, which cannot be built here. This
class translates the model's active constraints and objective into CasADi SX (one
template per indexed Constraint, see ``model.pyomo_sx``), generates sparse Jacobian
and Lagrangian-Hessian functions, and serves them to pynumero's ``CyIpoptNLP``
through persistent buffers. Mutable Params are CasADi parameters, so their values
may change between solves without a rebuild.

Presolve: an equality row with exactly one constant coefficient, on an unbounded
variable, that defines it from other variables (dX[t] == Tf f(X[t], U[t]) in a
pyomo.dae model) is used to eliminate that variable. Ipopt sees the reduced NLP (the
same one CasADi Opti builds for the trapezoid rule); the eliminated values and the
multipliers of the defining rows are recovered for Pyomo afterwards.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from pyomo.contrib.pynumero.interfaces.nlp import NLP
from pyomo.core.expr.numvalue import native_numeric_types
from scipy.sparse import coo_matrix

from model.pyomo_sx import PyomoToSX, component_rows


class CasadiNLP(NLP):
    """pynumero NLP of a Pyomo model (one active objective) via CasADi, presolved."""

    def __init__(self, model: pyo.Block, presolve: bool = True, templates: bool = True):
        self.model = model
        self.variables = [v for v in model.component_data_objects(pyo.Var, descend_into=True) if not v.fixed]
        self.params = [
            q for comp in model.component_objects(pyo.Param, descend_into=True) if comp.mutable for q in comp.values()
        ]
        objectives = list(model.component_data_objects(pyo.Objective, active=True, descend_into=True))
        if len(objectives) != 1:
            raise ValueError(f"expected one active objective, found {len(objectives)}")
        self.objective = objectives[0]
        self._sense = 1.0 if self.objective.sense == pyo.minimize else -1.0
        x_full, p, g_full, f = self._translate(templates)
        self._reduce(x_full, p, g_full, f, presolve)
        self._x = self.init_primals()
        self._y = np.zeros(self.n_constraints())
        self._sigma = np.ones(1)
        self._p = np.array([float(pyo.value(q)) for q in self.params])
        self._evaluate_bounds()

    # -- construction ---------------------------------------------------------
    def _translate(self, templates: bool):
        """SX of every active constraint body (component by component) and of the objective."""
        x = ca.SX.sym("x", len(self.variables))
        p = ca.SX.sym("p", len(self.params))
        walk = PyomoToSX({id(v): i for i, v in enumerate(self.variables)}, x,
                         {id(q): i for i, q in enumerate(self.params)}, p)  # fmt: skip
        self.constraints, self._bound_exprs, pieces, extra = [], [], [], []
        for comp in self.model.component_objects(pyo.Constraint, active=True, descend_into=True):
            datas = [d for d in comp.values() if d.active]
            tmpl = None
            if templates and comp.is_indexed() and len(datas) == len(comp) > 2:
                tmpl = component_rows(comp, walk, extra)
            pieces.append((tmpl, datas, len(self.constraints)))
            self.constraints += datas
            self._bound_exprs += [d.to_bounded_expression(evaluate_bounds=False)[::2] for d in datas]
        self._pool = ca.vertcat(x, p, ca.DM(extra)) if extra else ca.vertcat(x, p)
        rows, self._templates = [], []
        for tmpl, datas, offset in pieces:
            body = tmpl.on(self._pool) if tmpl is not None else None
            if body is not None and self._agrees(body, datas, walk, x, p):
                self._templates.append((tmpl, offset))
            else:
                body = ca.vertcat(*[walk(d.to_bounded_expression(evaluate_bounds=False)[1]) for d in datas])
            rows.append(body if datas else ca.SX(0, 1))
        g = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        f = self._sense * ca.SX(walk(self.objective.expr))
        return x, p, g, f

    @staticmethod
    def _agrees(rows: ca.SX, datas: list, walk: PyomoToSX, x: ca.SX, p: ca.SX) -> bool:
        """Do the template rows equal direct walks at three indices (random point)?"""
        picks = sorted({0, len(datas) // 2, len(datas) - 1})
        direct = ca.vertcat(*[ca.SX(walk(datas[i].to_bounded_expression(evaluate_bounds=False)[1])) for i in picks])
        check = ca.Function("check", [x, p], [rows[picks] - direct, direct])
        rng = np.random.default_rng(0)
        diff, ref = check(rng.uniform(0.1, 0.9, x.numel()), rng.uniform(0.1, 0.9, p.numel()))
        return bool(np.max(np.abs(np.array(diff))) <= 1e-10 * (1 + np.max(np.abs(np.array(ref)))))

    def _reduce(self, x: ca.SX, p: ca.SX, g: ca.SX, f: ca.SX, presolve: bool) -> None:
        """Presolve (if ``presolve``) and build the derivative functions.

        1. eliminate defined variables (``_definitions``, found on the templates);
        2. turn singleton rows lo <= c x_i + k(p) <= hi into bounds on x_i (boundary
           conditions become fixed variables, as CasADi's detect_simple_bounds does).
        """
        self._full = (x, p, g, f)
        def_rows, elim, defs = self._definitions(x.numel()) if presolve else ([], [], None)
        keep_rows = np.setdiff1d(np.arange(g.numel()), def_rows)
        keep_cols = np.setdiff1d(np.arange(x.numel()), elim)
        order = np.argsort(elim)  # setdiff1d sorts; keep defs aligned with sorted columns
        self._elim, self._def_rows = np.asarray(elim, dtype=int)[order], np.asarray(def_rows, dtype=int)[order]
        xr, gr, fr = x[keep_cols.tolist()], g[keep_rows.tolist()], f
        if len(elim):
            defs = defs[order.tolist()]
            gr = ca.substitute(gr, x[self._elim.tolist()], defs)
            fr = ca.substitute(f, x[self._elim.tolist()], defs)
            self._expand = ca.Function("expand", [xr, p], [defs])
        self._cols = keep_cols
        jac = ca.jacobian(gr, xr)
        kept = self._singletons(xr, p, gr, jac, keep_rows, presolve)
        self._rows = keep_rows[kept]
        self._make_functions(xr, p, gr[kept.tolist()], fr, jac[kept.tolist(), :])

    def _definitions(self, n_x: int) -> tuple[list[int], list[int], ca.SX | None]:
        """Template rows 0 = c X[t] + rest(other variables): X[t] := -rest / c.

        A template qualifies if exactly one slot has a constant coefficient, that slot
        is an unbounded Var indexed like the constraint, the bounds are the number 0,
        and no other definition's variable appears in it.
        """
        lbx, ubx = self._var_bounds()
        found = []
        for tmpl, offset in self._templates:
            n = tmpl.index.shape[1]
            if not all(_is_zero(b) for lohi in self._bound_exprs[offset : offset + n] for b in lohi):
                continue
            slots = ca.vertcat(*tmpl.symbols)
            grad = ca.jacobian(tmpl.row, slots)
            const = [k for k in range(grad.numel()) if grad.nz[k].is_constant() and float(grad.nz[k]) != 0]
            if len(const) != 1:
                continue
            s = grad.sparsity().get_col()[const[0]]
            cols = tmpl.index[s]
            others = [k for k in range(len(tmpl.symbols)) if k != s and np.all(tmpl.index[k] < n_x)]
            if not tmpl.own[s] or not others or np.isfinite(lbx[cols]).any() or np.isfinite(ubx[cols]).any():
                continue
            rest = ca.substitute(tmpl.row, tmpl.symbols[s], 0)
            fn = ca.Function("definition", [slots], [-rest / float(grad.nz[const[0]])]).map(n)
            found.append((offset + np.arange(n), cols, tmpl.index[others].ravel(), tmpl, fn))
        while True:  # no chains: a definition may not use another's variable
            used = np.concatenate([c for _, c, _, _, _ in found]) if found else np.zeros(0, int)
            bad = [i for i, (_, c, deps, _, _) in enumerate(found) if np.isin(deps, np.setdiff1d(used, c)).any()]
            if not bad:
                break
            found = [item for i, item in enumerate(found) if i not in bad]
        if not found or len(np.unique(used)) != len(used):
            return [], [], None
        rows = np.concatenate([r for r, _, _, _, _ in found]).tolist()
        defs = ca.vertcat(*[tmpl.on(self._pool, fn) for _, _, _, tmpl, fn in found])
        return rows, used.tolist(), defs

    def _singletons(self, xr, p, gr, jac, keep_rows: np.ndarray, presolve: bool) -> np.ndarray:
        """Rows with one constant Jacobian entry become bounds; returns the rows kept."""
        self._bound_rows = np.zeros(0, dtype=int)
        everything = np.arange(gr.numel())
        if not presolve or gr.numel() == 0:
            return everything
        rows, cols = (np.asarray(a) for a in jac.sparsity().get_triplet())
        counts = np.bincount(rows, minlength=gr.numel())
        local, col, coef = [], [], []
        for k in np.flatnonzero(counts[rows] == 1):
            entry = jac.nz[int(k)]
            if entry.is_constant() and float(entry) != 0:
                local.append(int(rows[k]))
                col.append(int(cols[k]))
                coef.append(float(entry))
        if not local:
            return everything
        offset = ca.substitute(gr[local], xr, ca.DM.zeros(xr.numel()))  # g = c x_i + k(p)
        self._offset = ca.Function("offset", [p], [offset])
        self._bound_rows = keep_rows[local]
        self._bound_cols_local = np.array(col)
        self._bound_cols = self._cols[col]
        self._bound_coef = np.array(coef)
        return np.setdiff1d(everything, local)

    def _make_functions(self, x: ca.SX, p: ca.SX, g: ca.SX, f: ca.SX, jac: ca.SX) -> None:
        m, n = g.numel(), x.numel()
        sigma, lam = ca.SX.sym("sigma"), ca.SX.sym("lam", m)
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
        return len(self._cols)

    def n_constraints(self) -> int:
        return len(self._rows)

    def nnz_jacobian(self) -> int:
        return len(self._jac_rc[0])

    def nnz_hessian_lag(self) -> int:
        return len(self._hess_rc[0])

    def _var_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lb = np.array([-np.inf if v.lb is None else v.lb for v in self.variables], dtype=float)
        ub = np.array([np.inf if v.ub is None else v.ub for v in self.variables], dtype=float)
        return lb, ub

    def primals_lb(self) -> np.ndarray:
        return self._reduced_bounds()[0]

    def primals_ub(self) -> np.ndarray:
        return self._reduced_bounds()[1]

    def _reduced_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds of the reduced NLP, tightened by the singleton rows."""
        lb, ub = (b[self._cols] for b in self._var_bounds())
        if len(self._bound_rows):
            k = np.array(self._offset(self._p)).ravel()
            c = self._bound_coef
            lo = (self._gl[self._bound_rows] - k) / c
            hi = (self._gu[self._bound_rows] - k) / c
            lo, hi = np.where(c > 0, lo, hi), np.where(c > 0, hi, lo)
            np.maximum.at(lb, self._bound_cols_local, lo)
            np.minimum.at(ub, self._bound_cols_local, hi)
        return lb, ub

    def constraints_lb(self) -> np.ndarray:
        return self._gl[self._rows]

    def constraints_ub(self) -> np.ndarray:
        return self._gu[self._rows]

    def init_primals(self) -> np.ndarray:
        vals = np.array([0.0 if v.value is None else v.value for v in self.variables], dtype=float)
        return vals[self._cols]

    def init_duals(self) -> np.ndarray:
        return np.zeros(self.n_constraints())

    def create_new_vector(self, vector_type: str) -> np.ndarray:
        size = self.n_primals() if vector_type.startswith("primal") else self.n_constraints()
        return np.zeros(size)

    def _bounds_now(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([-np.inf if a is None else pyo.value(a) for a, _ in self._bound_exprs], dtype=float)
        hi = np.array([np.inf if b is None else pyo.value(b) for _, b in self._bound_exprs], dtype=float)
        return lo, hi

    def _evaluate_bounds(self) -> None:
        """Constraint bounds may be Param expressions: evaluate them now."""
        self._gl, self._gu = self._bounds_now()

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
    def full_primals(self, x: np.ndarray) -> np.ndarray:
        """All model variables' values from a reduced primal vector."""
        full = np.empty(len(self.variables))
        full[self._cols] = x
        if len(self._elim):
            full[self._elim] = np.array(self._expand(x, self._p)).ravel()
        return full

    def load_primals(self, x: np.ndarray) -> None:
        """Write primal values (reduced vector) into the Pyomo variables."""
        for v, val in zip(self.variables, self.full_primals(x), strict=True):
            v.set_value(float(val), skip_validation=True)

    def full_duals(self, x: np.ndarray, mult_g: np.ndarray) -> np.ndarray:
        """Multipliers of all rows; presolved rows from stationarity in their variable.

        For the column i of a presolved row r: df/dx_i + sum_j J_ji lam_j = 0 over all rows
        (the variable's own bounds assumed inactive), solved for lam_r; definitions first,
        then singleton rows.
        """
        lam = np.zeros(len(self.constraints))
        lam[self._rows] = mult_g
        if not len(self._elim) and not len(self._bound_rows):
            return lam
        if not hasattr(self, "_kkt"):
            xf, p, g, f = self._full
            self._kkt = ca.Function("kkt", [xf, p], [ca.gradient(f, xf), ca.jacobian(g, xf)])
        grad, jac = self._kkt(self.full_primals(x), self._p)
        grad, J = np.array(grad).ravel(), jac.sparse().tocsc()
        if len(self._elim):  # an eliminated column meets only its definition and kept rows
            rest = grad[self._elim] + J[self._rows][:, self._elim].T @ mult_g
            lam[self._def_rows] = -rest / np.asarray(J[self._def_rows, self._elim]).ravel()
        for r, c in zip(self._bound_rows, getattr(self, "_bound_cols", []), strict=True):
            column = J[:, c]
            others = column.indices != r
            lam[r] = -(grad[c] + column.data[others] @ lam[column.indices[others]]) / J[r, c]
        return lam

    def load_duals(self, mult_g: np.ndarray, x: np.ndarray | None = None) -> None:
        """Store constraint duals in ``model.dual`` with Pyomo's sign convention.

        Ipopt's Lagrangian is f + mult_g . g; Pyomo (AMPL) reports -mult_g for a
        minimisation (Pyomo issue 2831), i.e. d(objective)/d(constraint bound).
        """
        if not hasattr(self.model, "dual"):
            self.model.dual = pyo.Suffix(direction=pyo.Suffix.IMPORT)
        lam = self.full_duals(self._x if x is None else x, mult_g)
        for con, val in zip(self.constraints, lam, strict=True):
            self.model.dual[con] = -self._sense * float(val)


def _is_zero(value) -> bool:
    return type(value) in native_numeric_types and value == 0


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
