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

from model.pyomo_sx import PyomoToSX, apply_templates, component_rows


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
            if tmpl is None:
                tmpl = (None, [walk(d.to_bounded_expression(evaluate_bounds=False)[1]) for d in datas])
            pieces.append((tmpl, datas))
            self.constraints += datas
            self._bound_exprs += [d.to_bounded_expression(evaluate_bounds=False)[::2] for d in datas]
        pool = ca.vertcat(x, p, ca.DM(extra)) if extra else ca.vertcat(x, p)
        rows = []
        for (index, body), datas in pieces:
            if index is None:
                rows.append(ca.vertcat(*body) if body else ca.SX(0, 1))
            else:
                rows.append(self._checked(apply_templates(pool, [(index, body)]), datas, walk, x, p))
        g = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        f = self._sense * ca.SX(walk(self.objective.expr))
        return x, p, g, f

    @staticmethod
    def _checked(rows: ca.SX, datas: list, walk: PyomoToSX, x: ca.SX, p: ca.SX) -> ca.SX:
        """Compare template rows with direct walks at three indices; on mismatch, walk all."""
        picks = sorted({0, len(datas) // 2, len(datas) - 1})
        direct = ca.vertcat(*[ca.SX(walk(datas[i].to_bounded_expression(evaluate_bounds=False)[1])) for i in picks])
        check = ca.Function("check", [x, p], [rows[picks] - direct, direct])
        rng = np.random.default_rng(0)
        diff, ref = check(rng.uniform(0.1, 0.9, x.numel()), rng.uniform(0.1, 0.9, p.numel()))
        if np.max(np.abs(np.array(diff))) <= 1e-10 * (1 + np.max(np.abs(np.array(ref)))):
            return rows
        return ca.vertcat(*[ca.SX(walk(d.to_bounded_expression(evaluate_bounds=False)[1])) for d in datas])

    def _reduce(self, x: ca.SX, p: ca.SX, g: ca.SX, f: ca.SX, presolve: bool) -> None:
        """Presolve (if ``presolve``) and build the derivative functions.

        1. eliminate defined variables (``_definitions``);
        2. turn singleton rows lo <= c x_i + k(p) <= hi into bounds on x_i (boundary
           conditions become fixed variables, as CasADi's detect_simple_bounds does).
        """
        self._full = (x, p, g, f)
        self._p_symbol = p
        keep_rows, keep_cols, elim_cols, defs = self._definitions(x, g) if presolve else (None, None, [], None)
        if elim_cols:
            xr = x[keep_cols]
            gr = ca.substitute(g[keep_rows], x[elim_cols], defs)
            fr = ca.substitute(f, x[elim_cols], defs)
            self._expand = ca.Function("expand", [xr, p], [defs])
        else:
            keep_rows, keep_cols = list(range(g.numel())), list(range(x.numel()))
            xr, gr, fr = x, g, f
        self._def_rows = np.setdiff1d(np.arange(g.numel()), np.array(keep_rows, dtype=int))
        self._singletons(xr, p, gr, keep_rows, keep_cols, presolve)
        gr = gr[self._kept_local.tolist()] if len(self._bound_rows) else gr
        self._rows, self._cols, self._elim = np.array(keep_rows)[self._kept_local], np.array(keep_cols), np.array(
            elim_cols, dtype=int
        )
        self._make_functions(xr, p, gr, fr)

    def _singletons(self, xr: ca.SX, p: ca.SX, gr: ca.SX, keep_rows: list, keep_cols: list, presolve: bool) -> None:
        """Rows of the reduced g with one constant Jacobian entry: bounds on that variable."""
        self._bound_rows = np.zeros(0, dtype=int)
        self._kept_local = np.arange(gr.numel())
        if not presolve or gr.numel() == 0:
            return
        jac = ca.jacobian(gr, xr)
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
            return
        offset = ca.substitute(gr[local], xr, ca.DM.zeros(xr.numel()))  # g = c x_i + k(p)
        self._offset = ca.Function("offset", [p], [offset])
        self._bound_rows = np.array(keep_rows)[local]
        self._bound_cols_local = np.array(col)
        self._bound_cols = np.array(keep_cols)[col]
        self._bound_coef = np.array(coef)
        self._kept_local = np.setdiff1d(np.arange(gr.numel()), local)

    def _definitions(self, x: ca.SX, g: ca.SX):
        """Rows 0 = c x_i + rest(x) that define an unbounded x_i from other variables.

        A row qualifies if c is its only constant coefficient, its bounds are the
        number 0 on both sides, and no other eliminated variable appears in it.
        """
        jac = ca.jacobian(g, x)
        rows, cols = jac.sparsity().get_triplet()
        const = _constant_entries(jac, x, self._p_symbol, rows)
        count = np.bincount(rows, minlength=g.numel())
        lbx, ubx = self._var_bounds()
        chosen: dict[int, tuple[int, float]] = {}
        used: set[int] = set()
        for r, entries in const.items():
            (c, coef), bounds = entries[0], self._bound_exprs[r]
            if len(entries) != 1 or count[r] < 2 or coef == 0 or c in used or not all(_is_zero(b) for b in bounds):
                continue
            if np.isfinite(lbx[c]) or np.isfinite(ubx[c]):
                continue
            chosen[r] = (c, coef)
            used.add(c)
        chosen = _without_chains(chosen, rows, cols)
        if not chosen:
            return None, None, [], None
        def_rows = sorted(chosen)
        elim = [chosen[r][0] for r in def_rows]
        coefs = ca.DM([chosen[r][1] for r in def_rows])
        rest = ca.substitute(g[def_rows], x[elim], ca.DM.zeros(len(elim)))  # each row holds only its own
        defs = -rest / coefs
        keep_rows = [r for r in range(g.numel()) if r not in chosen]
        gone = set(elim)
        keep_cols = [c for c in range(x.numel()) if c not in gone]
        return keep_rows, keep_cols, elim, defs

    def _make_functions(self, x: ca.SX, p: ca.SX, g: ca.SX, f: ca.SX) -> None:
        m, n = g.numel(), x.numel()
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


def _constant_entries(jac: ca.SX, x: ca.SX, p: ca.SX, rows: list) -> dict[int, list[tuple[int, float]]]:
    """Per row, the Jacobian entries that are constants (screened numerically, then checked)."""
    fn = ca.Function("jac_values", [x, p], [jac])
    rng = np.random.default_rng(0)
    a, b = (np.array(fn(rng.uniform(0.2, 0.8, x.numel()), rng.uniform(0.2, 0.8, p.numel())).nonzeros())
            for _ in range(2))  # fmt: skip
    same = np.flatnonzero(a == b)
    per_row = np.bincount(np.asarray(rows)[same], minlength=jac.size1())
    sp_rows, sp_cols = np.asarray(rows), np.asarray(jac.sparsity().get_triplet()[1])
    out: dict[int, list[tuple[int, float]]] = {}
    for k in same:
        r = int(sp_rows[k])
        entry = jac.nz[int(k)] if per_row[r] == 1 else None
        if entry is not None and entry.is_constant():
            out[r] = [(int(sp_cols[k]), float(entry))]
        elif per_row[r] > 1:
            out[r] = [(-1, 0.0)] * int(per_row[r])  # several constants: not a definition
    return out


def _without_chains(chosen: dict[int, tuple[int, float]], rows: list, cols: list) -> dict[int, tuple[int, float]]:
    """Drop definitions whose row uses another eliminated variable, until none does."""
    row_cols: dict[int, set[int]] = {}
    for r, c in zip(rows, cols, strict=True):
        if r in chosen:
            row_cols.setdefault(r, set()).add(c)
    while True:
        elim = {c for c, _ in chosen.values()}
        bad = [r for r, (c, _) in chosen.items() if (row_cols[r] & elim) - {c}]
        if not bad:
            return chosen
        for r in bad:
            chosen.pop(r)


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
