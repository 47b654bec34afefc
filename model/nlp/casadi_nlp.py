"""A pynumero ``NLP`` for a Pyomo model, with exact derivatives from CasADi SX.

Pyomo's own cyipopt route needs the ASL library, which cannot be built here. This
class translates each active constraint component into a row template over slots
(``model.nlp.blocks.Block``, built by ``model.nlp.pyomo_sx``), differentiates the templates
symbolically (Jacobian and Lagrangian Hessian per index), evaluates them mapped over
their indices, and sums the entries into the sparse patterns with constant matrices
inside CasADi; pynumero's ``CyIpoptNLP`` reads them through persistent buffers.
Mutable Params are CasADi parameters, so their values may change between solves
without a rebuild.

Presolve: an equality row with exactly one constant coefficient, on an unbounded
variable, that defines it from other variables (dX[t] == Tf f(X[t], U[t]) in a
pyomo.dae model) removes that variable: rows that use it linearly keep a link to its
value (computed once per node), other uses get the definition substituted. Blocks of
singleton rows become variable bounds. Ipopt sees the reduced NLP (the same one CasADi
Opti builds for the trapezoid rule with detect_simple_bounds); the eliminated values
and the multipliers of the presolved rows are recovered for Pyomo afterwards.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from pyomo.contrib.pynumero.interfaces.nlp import NLP
from pyomo.core.expr.numvalue import native_numeric_types
from scipy.sparse import coo_matrix, csc_matrix, csr_matrix

from model.nlp.blocks import (
    Assembly,
    Block,
    Definition,
    Layout,
    eliminate,
    find_definition,
    from_expressions,
    hessian_layout,
    jacobian_layout,
    merge,
    no_links,
    nonlinear_uses,
    pad_columns,
    split_linear,
    through,
    tidy,
)
from model.nlp.pyomo_sx import PyomoToSX, component_rows


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
        self._p = np.array([float(pyo.value(q)) for q in self.params], dtype=float)
        self._translate(templates)
        self._reduce(presolve)
        self._x = self.init_primals()
        self._y = np.zeros(self.n_constraints())
        self._sigma = np.ones(1)
        self._evaluate_bounds()

    # -- construction ---------------------------------------------------------
    def _translate(self, templates: bool) -> None:
        """One Block per active constraint component (a template where Pyomo gives one,
        checked against direct walks) and one for the objective."""
        x = ca.SX.sym("x", len(self.variables))
        p = ca.SX.sym("p", len(self.params))
        walk = PyomoToSX({id(v): i for i, v in enumerate(self.variables)}, x,
                         {id(q): i for i, q in enumerate(self.params)}, p)  # fmt: skip
        self.constraints, self._bound_exprs, extra, pieces = [], [], [], []
        for comp in self.model.component_objects(pyo.Constraint, active=True, descend_into=True):
            datas = [d for d in comp.values() if d.active]
            if not datas:
                continue
            block = None
            if templates and comp.is_indexed() and len(datas) == len(comp) > 2:
                block = component_rows(comp, walk, extra)
            pieces.append((block, datas, len(self.constraints)))
            self.constraints += datas
        self._consts = np.array(extra, dtype=float)
        agree = self._agrees([(b, d) for b, d, _ in pieces if b is not None], walk, x, p)
        self._blocks = []
        for block, datas, offset in pieces:
            if block is None or not agree.pop(0):
                rows = ca.vertcat(*[walk(d.to_bounded_expression(evaluate_bounds=False)[1]) for d in datas])
                block = from_expressions(rows, x, p, offset)
            block.offset = offset
            self._blocks.append(block)
            self._bound_exprs += _bounds(block, datas)
        self._objective_block = from_expressions(self._sense * ca.SX(walk(self.objective.expr)), x, p, 0)

    def _agrees(self, pairs: list, walk: PyomoToSX, x: ca.SX, p: ca.SX) -> list[bool]:
        """Does each template equal direct walks at three of its indices (random point)?"""
        if not pairs:
            return []
        rng = np.random.default_rng(0)
        xv, pv = rng.uniform(0.1, 0.9, x.numel()), rng.uniform(0.1, 0.9, p.numel())
        pool = np.concatenate([xv, pv, self._consts])
        picks = [sorted({0, len(datas) // 2, len(datas) - 1}) for _, datas in pairs]
        direct = [walk(datas[i].to_bounded_expression(evaluate_bounds=False)[1]) for (_, datas), ks in
                  zip(pairs, picks, strict=True) for i in ks]  # fmt: skip
        ref = np.array(ca.Function("direct", [x, p], [ca.vertcat(*direct)])(xv, pv)).ravel()
        out, k = [], 0
        for (block, _), ks in zip(pairs, picks, strict=True):
            fn = ca.Function("template", [block.slots], [block.row])
            got = np.array([float(fn(block.gather(pool)[:, i])) for i in ks])
            want = ref[k : k + len(ks)]
            k += len(ks)
            out.append(bool(np.max(np.abs(got - want)) <= 1e-10 * (1 + np.max(np.abs(want)))))
        return out

    def _reduce(self, presolve: bool) -> None:
        """Presolve (if ``presolve``) and build the derivative functions.

        1. defined variables (``_definitions``) leave the NLP: where they enter a row
           linearly with constant coefficients (dX in the trapezoid rows, a sum of
           running costs) the row keeps a link to the definition's value, computed
           once per index; elsewhere the definition is substituted into the template;
        2. blocks of singleton rows lo <= c x_i + k(p) <= hi become bounds on x_i
           (boundary conditions become fixed variables, as CasADi's
           detect_simple_bounds does).
        """
        n_x = len(self.variables)
        defs = self._definitions(n_x) if presolve else []
        try:
            blocks, objective, links, obj_links = self._link(defs, n_x)
        except ValueError:
            defs = []
            blocks, objective, links, obj_links = self._link(defs, n_x)
        self._defs = [(d, d.block.mapped(d.value)) for d in defs]
        elim = np.concatenate([d.cols for d in defs]).astype(int) if defs else np.zeros(0, int)
        rows = np.concatenate([d.block.rows() for d in defs]).astype(int) if defs else np.zeros(0, int)
        order = np.argsort(elim)
        self._elim, self._def_rows = elim[order], rows[order]
        self._cols = np.setdiff1d(np.arange(n_x), elim)
        kept, self._bounds, linked = [], [], set(links[0].tolist())
        for b in blocks:
            found = _singleton(b, n_x) if presolve and not linked.intersection(b.rows().tolist()) else None
            (self._bounds.append((b, *found)) if found else kept.append(b))
        kept = _merge_by_size(kept)
        self._rows = np.concatenate([b.rows() for b in kept]).astype(int) if kept else np.zeros(0, int)
        self._make_bounds(n_x)
        position = np.full(len(self.constraints), -1)
        position[self._rows] = np.arange(len(self._rows))
        n_d = sum(d.block.n for d in defs)
        C = csr_matrix((links[2], (position[links[0]], links[1])), shape=(len(self._rows), n_d))
        c_obj = csr_matrix((obj_links[2], (np.zeros(len(obj_links[1]), int), obj_links[1])), shape=(1, n_d))
        reindex = self._reindexer(n_x)
        self._make_functions([reindex(b) for b in kept], reindex(objective),
                             [reindex(tidy(replace(d.block, row=d.value))) for d in defs], C, c_obj)  # fmt: skip

    def _link(self, defs: list[Definition], n_x: int) -> tuple:
        """Blocks without defined variables, and links (row, definition value, coefficient)."""
        owner, dpos = np.full(n_x, -1), np.full(n_x, -1)
        at, start = np.full(n_x, -1), 0
        for i, d in enumerate(defs):
            owner[d.cols], at[d.cols], dpos[d.cols] = i, np.arange(d.block.n), start + np.arange(d.block.n)
            start += d.block.n
        defining = {id(d.block) for d in defs}
        blocks, links, pool = [], [], self._pool(np.zeros(n_x))
        n_free = n_x + len(self.params)
        for b in [*(b for b in self._blocks if id(b) not in defining), self._objective_block]:
            only = np.full(n_x, -1)  # substitute the nonlinear uses, link the rest
            bad = nonlinear_uses(b, owner, n_free)
            only[bad] = owner[bad]
            split = split_linear(eliminate(b, defs, only, at), owner, dpos, pool, n_free)
            split = split or (eliminate(b, defs, owner, at), no_links())
            blocks.append(split[0])
            links.append(split[1])
        joined = tuple(np.concatenate([q[k] for q in links[:-1]]) for k in range(3))
        return blocks[:-1], blocks[-1], joined, links[-1]

    def _definitions(self, n_x: int) -> list[Definition]:
        """Templates 0 = c X[t] + rest(other variables) with zero bounds: X[t] := -rest / c.

        No chains: a definition may not use another definition's variable.
        """
        lbx, ubx = self._var_bounds()
        free = ~np.isfinite(lbx) & ~np.isfinite(ubx)
        found = []
        for b in self._blocks:
            lohi = self._bound_exprs[b.offset : b.offset + b.m]
            if len(b.own) and all(_is_zero(v) for pair in lohi for v in pair):
                d = find_definition(b, n_x, free)
                found += [d] if d is not None else []
        while found:
            used = np.concatenate([d.cols for d in found])
            bad = [i for i, d in enumerate(found) if np.isin(_uses(d, n_x), np.setdiff1d(used, d.cols)).any()]
            if not bad:
                return found if len(np.unique(used)) == len(used) else []
            found = [d for i, d in enumerate(found) if i not in bad]
        return []

    def _reindexer(self, n_x: int):
        """A function giving a block over the reduced pool (kept x, p, constants)."""
        where = np.full(n_x, -1)
        where[self._cols] = np.arange(len(self._cols))

        def reindex(block: Block) -> Block:
            idx = block.index
            new = np.where(idx < n_x, where[np.minimum(idx, n_x - 1)], idx - n_x + len(self._cols))
            if np.any((idx < n_x) & (new < 0)):
                raise RuntimeError("presolve left a reference to an eliminated variable")
            return replace(block, index=new)

        return reindex

    def _make_bounds(self, n_x: int) -> None:
        """Singleton blocks: bound rows, their columns and coefficients, and the offset k(p)."""
        self._bound_rows = np.zeros(0, dtype=int)
        self._bound_cols = np.zeros(0, dtype=int)
        if not self._bounds:
            return
        self._bound_rows = np.concatenate([b.rows() for b, _, _ in self._bounds])
        self._bound_cols = np.concatenate([b.index[s] for b, s, _ in self._bounds])
        self._bound_coef = np.concatenate([np.full(b.n, c) for b, _, c in self._bounds])
        self._bound_cols_local = np.searchsorted(self._cols, self._bound_cols)
        self._offsets = [(b, b.mapped(ca.substitute(b.row, b.slots[s], 0))) for b, s, _ in self._bounds]

    def _make_functions(self, blocks, objective, def_blocks, C: csr_matrix, c_obj: csr_matrix) -> None:
        """g, f, gradient, Jacobian and Lagrangian Hessian as buffered MX Functions."""
        graph = _Graph(len(self._cols), len(self.params), sum(b.m for b in blocks), self._consts)
        start = 0
        for b in blocks:
            graph.rows(b, start)
            start += b.m
        graph.objective(objective)
        for block, (lo, hi) in zip(def_blocks, _segments(def_blocks), strict=True):
            graph.definition(block, C[:, lo:hi], c_obj[:, lo:hi])
        self._fns, jac, hess = graph.functions()
        self._jac_rc, self._hess_rc = (jac.rows, jac.cols), (hess.rows, hess.cols)

    # -- sizes and bounds -------------------------------------------------------
    def n_primals(self) -> int:
        return len(self._cols)

    def n_constraints(self) -> int:
        return len(self._rows)

    def constraint_rows(self) -> np.ndarray:
        """For each row of the reduced NLP (Ipopt's g), its index in ``constraints`` (the model's rows)."""
        return self._rows.copy()

    def columns_of(self, component) -> np.ndarray:
        """The columns (Ipopt's x) of a Var component's entries, in the component's index order.

        Parameters
        ----------
        component : pyomo Var component (indexed or scalar), or its name on the model

        Returns
        -------
        ndarray of int
            One per entry: its column in the reduced NLP, -1 for an entry that is fixed or that
            the presolve eliminated (a defined variable).
        """
        comp = self.model.component(component) if isinstance(component, str) else component
        if not hasattr(self, "_column_of"):
            where = np.full(len(self.variables), -1)
            where[self._cols] = np.arange(len(self._cols))
            self._column_of = {id(v): int(where[i]) for i, v in enumerate(self.variables)}
        return np.array([self._column_of.get(id(v), -1) for v in comp.values()], dtype=int)

    def rows_of(self, component) -> np.ndarray:
        """The rows (Ipopt's g) of a Constraint component's entries, in the component's index order.

        Parameters
        ----------
        component : pyomo Constraint component (indexed or scalar), or its name on the model

        Returns
        -------
        ndarray of int
            One per entry: its row in the reduced NLP, -1 for an inactive entry or one the presolve
            turned into a bound or a definition.
        """
        comp = self.model.component(component) if isinstance(component, str) else component
        if not hasattr(self, "_row_of"):
            where = np.full(len(self.constraints), -1)
            where[self._rows] = np.arange(len(self._rows))
            self._row_of = {id(c): int(where[i]) for i, c in enumerate(self.constraints)}
        return np.array([self._row_of.get(id(c), -1) for c in comp.values()], dtype=int)

    def nnz_jacobian(self) -> int:
        return len(self._jac_rc[0])

    def nnz_hessian_lag(self) -> int:
        return len(self._hess_rc[0])

    def _var_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds (read from Pyomo once; ``refresh_parameters`` re-reads them)."""
        if not hasattr(self, "_lbx"):
            both = np.array([v.bounds for v in self.variables], dtype=float).reshape(-1, 2)
            self._lbx = np.where(np.isnan(both[:, 0]), -np.inf, both[:, 0])
            self._ubx = np.where(np.isnan(both[:, 1]), np.inf, both[:, 1])
        return self._lbx, self._ubx

    def primals_lb(self) -> np.ndarray:
        return self._reduced_bounds()[0]

    def primals_ub(self) -> np.ndarray:
        return self._reduced_bounds()[1]

    def _reduced_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds of the reduced NLP, tightened by the singleton rows (computed once per
        ``refresh_parameters``: they depend on the Params and bounds it re-reads)."""
        if self._reduced is None:
            self._reduced = self._tightened_bounds()
        return self._reduced[0].copy(), self._reduced[1].copy()

    def _tightened_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lb, ub = (b[self._cols] for b in self._var_bounds())
        if len(self._bound_rows):
            pool = self._pool(np.zeros(len(self.variables)))
            k = np.concatenate([b.values(fn, pool).ravel() for b, fn in self._offsets])
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
        """The rows' bounds now: the constant ones read once, the Param expressions evaluated."""
        if not hasattr(self, "_bound_split"):
            split = []
            for side, missing in ((0, -np.inf), (1, np.inf)):
                exprs = [e[side] for e in self._bound_exprs]
                moving = [i for i, e in enumerate(exprs) if e is not None and type(e) not in native_numeric_types]
                skip = set(moving)
                const = np.array([missing if e is None or i in skip else e for i, e in enumerate(exprs)], dtype=float)
                split.append((const, np.array(moving, dtype=int), [exprs[i] for i in moving]))
            self._bound_split = split
        out = []
        for const, moving, exprs in self._bound_split:
            values = const.copy()
            if len(moving):
                values[moving] = [pyo.value(e) for e in exprs]
            out.append(values)
        return out[0], out[1]

    def _evaluate_bounds(self) -> None:
        """Constraint bounds may be Param expressions: evaluate them now."""
        self._gl, self._gu = self._bounds_now()
        self._reduced = None

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

    def refresh_parameters(self, variables: list | None = None) -> None:
        """Re-read mutable Param values, variable bounds and the constraint bounds.

        ``variables``: re-read the bounds of these variables only (a receding-horizon step changes
        a few; re-reading all of them costs about 10 ms on a road horizon of 1400 columns).
        """
        self._p[:] = [float(pyo.value(q)) for q in self.params]
        if variables is None or not hasattr(self, "_lbx"):
            self.__dict__.pop("_lbx", None)
            self.__dict__.pop("_ubx", None)
        else:
            if not hasattr(self, "_variable_index"):
                self._variable_index = {id(v): i for i, v in enumerate(self.variables)}
            for v in variables:
                i = self._variable_index[id(v)]
                lo, hi = v.bounds
                self._lbx[i] = -np.inf if lo is None else lo
                self._ubx[i] = np.inf if hi is None else hi
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

    def evaluate_first_order(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The constraints, the objective's gradient and the Jacobian's values (in the order of
        ``evaluate_jacobian``'s entries) at the current primals, in one CasADi call.

        The three share the horizon's mapped templates' inputs, so one call spends less in the
        function's virtual machine than three (semitrailer horizon: 2.6 against 3.0 ms). The
        arrays are copies.
        """
        if "first_order" not in self._fns:
            self._fns["first_order"] = _buffered(self._first_order_function())
        g, grad, jac = self._fns["first_order"].call_all(self._x, self._p)
        return g.copy(), grad.copy(), jac.copy()

    def _first_order_function(self) -> ca.Function:
        parts = [self._fns[k].fn for k in ("g", "grad", "jac")]
        x, p = ca.MX.sym("x", parts[0].size1_in(0)), ca.MX.sym("p", parts[0].size1_in(1))
        return ca.Function("first_order", [x, p], [f(x, p) for f in parts])

    def compile_first_order(self, cache_dir: str | Path | None = None, compiler: str = "gcc",
                            flags: tuple[str, ...] = ("-O1",)) -> bool:  # fmt: skip
        """Evaluate ``evaluate_first_order`` by C code of its CasADi function, compiled once.

        The generated C is compiled to a shared library named by the SHA-256 of the source and the
        flags under ``cache_dir`` (default ``$XDG_CACHE_HOME/roundabout-ocp`` or
        ``~/.cache/roundabout-ocp``) and loaded from there by later calls (and processes) with the
        same function. Semitrailer road horizon (3250 columns): 1.4 against 2.6 ms per call, gcc
        -O1 about 40 s CPU (83 s wall at load 5) once (-O0 compiles in 14 s but runs no faster than the interpreter).

        Parameters
        ----------
        cache_dir : str or Path, optional
            Where the libraries are kept.
        compiler : str
            The C compiler's command.
        flags : tuple of str
            Its optimisation flags.

        Returns
        -------
        bool
            True if the compiled function is used; False (with one warning saying why) if the code
            could not be compiled or loaded: the interpreted function stays in use.
        """
        fn = self._first_order_function()
        try:
            library = _compiled(fn, Path(cache_dir) if cache_dir else _cache_dir(), compiler, tuple(flags))
            external = ca.external(fn.name(), str(library))
        except (OSError, RuntimeError, subprocess.SubprocessError) as exc:
            message = str(exc).strip().splitlines()
            warnings.warn(f"the first-order functions stay interpreted: {message[-1] if message else exc}",
                          RuntimeWarning, stacklevel=2)  # fmt: skip
            return False
        self._fns["first_order"] = _buffered(external)
        return True

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
            full[self._elim] = 0.0
            pool = self._pool(full)
            for d, fn in self._defs:
                full[d.cols] = d.block.values(fn, pool).ravel()
        return full

    def _pool(self, x_full: np.ndarray) -> np.ndarray:
        """Numeric pool (all variables, parameters, constants) in full numbering."""
        return np.concatenate([x_full, self._p, self._consts])

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
        grad, J = self._full_derivatives(self.full_primals(x))
        if len(self._elim):  # an eliminated column meets only its definition and kept rows
            rest = grad[self._elim] + J[self._rows][:, self._elim].T @ mult_g
            lam[self._def_rows] = -rest / np.asarray(J[self._def_rows, self._elim]).ravel()
        for r, c in zip(self._bound_rows, self._bound_cols, strict=True):
            column = J[:, c]
            others = column.indices != r
            lam[r] = -(grad[c] + column.data[others] @ lam[column.indices[others]]) / J[r, c]
        return lam

    def jacobian_at(self, x: np.ndarray) -> csc_matrix:
        """The Jacobian of every row of ``constraints`` in every column of ``variables`` (the model
        before presolve) at the reduced primal point ``x`` (an Ipopt answer), in CSC form."""
        return self._full_derivatives(self.full_primals(x))[1]

    def constraint_values_at(self, x: np.ndarray) -> np.ndarray:
        """The body of every row of ``constraints`` (the model before presolve; lo <= body <= hi)
        at the reduced primal point ``x``, evaluated by the rows' CasADi templates."""
        if not hasattr(self, "_row_fns"):
            self._row_fns = [(b, b.mapped(b.row)) for b in self._blocks]
        pool = self._pool(self.full_primals(x))
        out = np.empty(len(self.constraints))
        for b, fn in self._row_fns:
            out[b.rows()] = b.values(fn, pool).T.ravel()
        return out

    def _full_derivatives(self, x_full: np.ndarray):
        """Objective gradient and constraint Jacobian (CSC) of the model before presolve."""
        if not hasattr(self, "_kkt"):
            n_x = len(self.variables)
            self._kkt = [(b, jacobian_layout(b, b.offset, n_x)) for b in self._blocks]
            self._kkt_f = jacobian_layout(self._objective_block, 0, n_x)
        n_x, pool = len(self.variables), self._pool(x_full)

        def raw(block, lay):
            vals = block.values(lay.fn, pool).T.ravel()
            ok = lay.cols < n_x
            return vals[ok], lay.rows[ok], lay.cols[ok]

        parts = [raw(b, lay) for b, lay in self._kkt]
        vals, rows, cols = (np.concatenate([q[i] for q in parts]) for i in range(3))
        fv, _, fc = raw(self._objective_block, self._kkt_f)
        J = coo_matrix((vals, (rows, cols)), shape=(len(self.constraints), n_x)).tocsc()
        return np.bincount(fc, weights=fv, minlength=n_x), J

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


def _bounds(block: Block, datas: list) -> list[tuple]:
    """(lower, upper) of each row: the template's numbers if it has them (checked at
    both ends), else each constraint's own bound expressions."""
    if block.bounds is not None:
        ends = [
            datas[0].to_bounded_expression(evaluate_bounds=False)[::2],
            datas[-1].to_bounded_expression(evaluate_bounds=False)[::2],
        ]
        if all(tuple(e) == block.bounds for e in ends):
            return [block.bounds] * len(datas)
    return [d.to_bounded_expression(evaluate_bounds=False)[::2] for d in datas]


def _singleton(block: Block, n_x: int) -> tuple[int, float] | None:
    """(slot, c) if each row of ``block`` is c x_slot + k(p) with a constant c != 0."""
    if block.r != 1 or block.slots.numel() == 0:
        return None
    is_x = np.all(block.index < n_x, axis=1)
    mixed = np.any(block.index < n_x, axis=1) & ~is_x
    grad = ca.jacobian(block.row, block.slots)
    cols = np.asarray(grad.sparsity().get_col())
    hits = [k for k in range(grad.nnz()) if is_x[cols[k]]]
    if mixed.any() or len(hits) != 1 or not grad.nz[hits[0]].is_constant() or float(grad.nz[hits[0]]) == 0:
        return None
    return int(cols[hits[0]]), float(grad.nz[hits[0]])


def _uses(d: Definition, n_x: int) -> np.ndarray:
    """Variable positions a definition reads (its other slots)."""
    idx = np.delete(d.block.index, d.slot, axis=0)
    return idx[idx < n_x]


class _Graph:
    """The MX graph of g, f and the raw derivative entries, grown block by block over
    mapped templates; constant matrices (``Assembly``) sum the raw entries into the
    sparse patterns inside CasADi."""

    def __init__(self, n: int, n_p: int, m: int, consts: np.ndarray):
        self.n, self.m = n, m
        self.x, self.p = ca.MX.sym("x", n), ca.MX.sym("p", n_p)
        self.sigma, self.lam = ca.MX.sym("sigma"), ca.MX.sym("lam", m)
        self.pool = ca.vertcat(self.x, self.p, ca.DM(consts)) if len(consts) else ca.vertcat(self.x, self.p)
        self.g, self.links, self.f = [], [], ca.MX(0)
        self.jac, self.hess, self.grad = _Parts(), _Parts(), _Parts()

    def rows(self, b: Block, start: int) -> None:
        """Constraint rows start .. start + b.m of the reduced NLP."""
        args = b.gather(self.pool)
        self.g.append(ca.vec(b.mapped(b.row)(args)[:, : b.n]))
        self.jac.add(jacobian_layout(b, start, self.n), args)
        lay, w = hessian_layout(b, self.n)
        self.hess.add(lay, args, _padded(self.lam, start, b), weight=w)

    def objective(self, b: Block) -> None:
        args = b.gather(self.pool)
        self.f += b.mapped(b.row)(args)
        self.grad.add(jacobian_layout(b, 0, self.n), args)
        lay, w = hessian_layout(b, self.n)
        self.hess.add(lay, args, self.sigma, weight=w)

    def definition(self, b: Block, links: csr_matrix, cost: csr_matrix) -> None:
        """A defined variable's values, linked into rows (``links``) and the objective (``cost``)."""
        args = b.gather(self.pool)
        value = ca.vec(b.mapped(b.row)(args)[:, : b.n])
        lay = jacobian_layout(b, 0, self.n)
        if links.nnz:
            self.links.append(ca.mtimes(_dm(links), value))
            self.jac.add(lay, args, links=links)
        if cost.nnz:
            self.f += ca.mtimes(_dm(cost), value)
            self.grad.add(lay, args, links=cost)
        weight = ca.mtimes(_dm(links.T), self.lam) + self.sigma * _dm(cost.T)
        lay, w = hessian_layout(b, self.n)
        self.hess.add(lay, args, _padded(weight, 0, b), weight=w)

    def functions(self) -> tuple[dict, Assembly, Assembly]:
        n, x, p = self.n, self.x, self.p
        g = _cat(self.g)
        for linked in self.links:
            g += linked
        jac, hess, grad = self.jac.assemble(n), self.hess.assemble(n, lower=True), self.grad.assemble(n, dense=True)
        fns = {
            "f": _Buffered(ca.Function("f", [x, p], [self.f]), 1),
            "grad": _Buffered(ca.Function("grad", [x, p], [self.grad.values(grad)]), n),
            "g": _Buffered(ca.Function("g", [x, p], [ca.densify(g)]), self.m),
            "jac": _Buffered(ca.Function("jacobian_g", [x, p], [self.jac.values(jac)]), jac.size),
            "hess": _Buffered(
                ca.Function("hessian_lag", [x, p, self.sigma, self.lam], [self.hess.values(hess)]), hess.size
            ),
        }
        return fns, jac, hess


class _Parts:
    """Raw derivative entries of many layouts: MX pieces and where each entry goes."""

    def __init__(self):
        self.pieces, self.contrib, self.count = [], [], 0

    def add(self, lay: Layout, args, *extra, weight=None, links: csr_matrix | None = None) -> None:
        """Evaluate a layout on padded arguments; entries of padding indices go nowhere."""
        self.pieces.append(ca.vec(lay.fn(args, *extra)))
        if links is None:
            w = np.ones(len(lay.rows)) if weight is None else weight
            self.contrib.append((lay.rows, lay.cols, self.count + np.arange(len(lay.rows)), w))
        else:
            self.contrib.append(through(links, lay, self.count))
        self.count += self.pieces[-1].numel()

    def assemble(self, n: int, lower: bool = False, dense: bool = False) -> Assembly:
        rows, cols, raw, w = (np.concatenate([c[k] for c in self.contrib]) for k in range(4))
        ok = (cols < n) & ((rows < n) if lower else True)
        return Assembly(rows[ok], cols[ok], raw[ok], w[ok], self.count, n, dense=n if dense else None)

    def values(self, assembly: Assembly) -> ca.MX:
        return ca.densify(ca.mtimes(assembly.matrix, _cat(self.pieces)))


def _dm(matrix) -> ca.DM:
    """A scipy sparse matrix as a CasADi DM."""
    csc = matrix.tocsc()
    csc.sum_duplicates()
    return ca.DM(ca.Sparsity(csc.shape[0], csc.shape[1], csc.indptr.tolist(), csc.indices.tolist()), csc.data)


def _merge_by_size(blocks: list[Block]) -> list[Block]:
    """Merge blocks of equal size: one block per size."""
    sizes: dict[int, list[Block]] = {}
    for b in blocks:
        sizes.setdefault(b.n, []).append(b)
    return [merge(group) if len(group) > 1 else group[0] for group in sizes.values()]


def _padded(v: ca.MX, start: int, block: Block) -> ca.MX:
    """r x width matrix of a block's per-row values v[start + j r + i], padded."""
    idx = start + pad_columns(block.n)[None, :] * block.r + np.arange(block.r)[:, None]
    return ca.reshape(v[idx.T.ravel().tolist()], block.r, idx.shape[1])


def _segments(blocks: list[Block]) -> list[tuple[int, int]]:
    """(first, end) positions of each definition block's values in the vector of all."""
    ends = np.cumsum([b.n for b in blocks], dtype=int).tolist()
    return list(zip([0, *ends][: len(ends)], ends, strict=True))


def _cat(parts: list) -> ca.MX:
    return ca.vertcat(*parts) if parts else ca.MX(0, 1)


def _number(bound, missing: float) -> float:
    """A bound's value now (``missing`` if there is none)."""
    if bound is None:
        return missing
    return bound if type(bound) in native_numeric_types else pyo.value(bound)


def _is_zero(value) -> bool:
    return type(value) in native_numeric_types and value == 0


class _Buffered:
    """A CasADi Function called through persistent numpy buffers (no copies per call)."""

    def __init__(self, fn: ca.Function, *n_out: int):
        self.fn = fn
        self.buf, self.trigger = fn.buffer()
        self.outs = [np.zeros(n) for n in n_out]
        for i, out in enumerate(self.outs):
            self.buf.set_res(i, memoryview(out))
        self.out = self.outs[0]

    def __call__(self, *args: np.ndarray) -> np.ndarray:
        """The first output (the buffer itself)."""
        return self.call_all(*args)[0]

    def call_all(self, *args: np.ndarray) -> list[np.ndarray]:
        """Every output (the buffers themselves)."""
        for i, a in enumerate(args):
            self.buf.set_arg(i, memoryview(np.ascontiguousarray(a, dtype=float)))
        self.trigger()
        return self.outs


def _buffered(fn: ca.Function) -> _Buffered:
    return _Buffered(fn, *(fn.nnz_out(i) for i in range(fn.n_out())))


def _cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "roundabout-ocp"


def _compiled(fn: ca.Function, cache: Path, compiler: str, flags: tuple[str, ...]) -> Path:
    """The shared library of ``fn``'s C code in ``cache`` (compiled unless it is there)."""
    with tempfile.TemporaryDirectory() as tmp:
        gen = ca.CodeGenerator(f"{fn.name()}.c")
        gen.add(fn)
        path = Path(gen.generate(tmp + os.sep))
        text = path.read_bytes()
        key = hashlib.sha256(text + " ".join((compiler, *flags)).encode()).hexdigest()[:24]
        library = cache / f"{fn.name()}_{key}.so"
        if library.exists():
            return library
        cache.mkdir(parents=True, exist_ok=True)
        out = Path(tmp) / library.name
        run = subprocess.run([compiler, *flags, "-fPIC", "-shared", str(path), "-o", str(out)],
                             capture_output=True, text=True)  # fmt: skip
        if run.returncode != 0:
            raise RuntimeError(f"{compiler} failed: {run.stderr.strip() or run.returncode}")
        partial = cache / f".{library.name}.{os.getpid()}"
        partial.write_bytes(out.read_bytes())
        partial.replace(library)  # atomic: a concurrent process sees the whole library or none
    return library


def _emit(values: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    if out is None:
        return values.copy()
    np.copyto(out, values)
    return out
