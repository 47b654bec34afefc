"""The real-time iteration: one condensed SQP step per sample on the horizon's built NLP.

Diehl's real-time iteration (Diehl, Bock & Schloeder 2005) takes one Newton-type step per sample
from the shifted previous solution instead of solving to convergence: the horizon problem changes
little between samples, so one step tracks its solution. The step here is a sequential quadratic
program's on the reduced NLP of ``CasadiNLP`` (the bridge's CasADi functions: the constraints, their
Jacobian, the objective's gradient and Hessian, read through the NLP's public pynumero interface
and the accessors of named components):

    min_d  1/2 d' H d + grad' d   s.t.  lbg - g(x) <= J(x) d <= ubg - g(x),  lbx - x <= d <= ubx - x.

- H is the Hessian of the objective alone (a Gauss-Newton-type choice: the constraints' curvature
  left out keeps the QP convex; the horizon's objective is the energy, quadratic in the controls,
  plus a quadratic terminal penalty), evaluated once and again only when ``refresh_hessian`` is
  called (its Params changed), plus ``regularization`` times the identity on the QP's variables;
- condensing: the equality rows that define the dependent columns (the trapezoid rows, which give
  the states at nodes 1..N; the body-disc centres' definitions) are solved for them by one sparse LU,
  d_D = a + S z, so the QP's variables z are the independent columns only (controls, a free final
  time, the terminal slacks); columns fixed by their bounds (the start state) move to their bound;
- the keep-out and body-row slacks are held at their current values in the step, with one elastic
  variable sigma >= 0 shared by all their rows (priced at the slacks' largest price times the
  number of those rows, so the QP uses it only where the rows cannot be met; SNOPT's elastic mode
  in one variable); after the step each such row's own slack is raised by what the new point
  lacks (one Newton step of the row in its slack), so the point satisfies those rows as the
  NLP's soft rows do, at the price the NLP's objective sets;
- the dense QP (about n_controls (N + 1) + 2 n_states variables) is solved by a dense active-set
  solver of the casadi wheel (``casadi.conic``: qpOASES by default, with its MPC preset's settings,
  hot-started from the previous active set; or DAQP), called through persistent numpy buffers
  (``BufferedQP``: no conversion of the dense matrices per call);
- the objective's Hessian enters the condensing through its dense blocks at the free columns and
  the few dependent columns it touches, formed once per Hessian.

With ``solver="hpipm"`` the QP is not condensed: ``stagewise.StagewiseQP`` writes the same QP in
the OCP's stage layout for hpipm's Riccati-based interior point (measured slower on the road
cases: see that module).

The step is accepted by the controller when the new point satisfies the nonlinear constraints to
its tolerance (``MPC._violation``); otherwise the controller falls back to warm-started Ipopt.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from scipy.sparse import coo_matrix, csc_matrix
from scipy.sparse.linalg import splu

from model.direct.families import transcription_of
from model.nlp.casadi_nlp import CasadiNLP
from model.simulation.mpc.qp_buffer import BufferedQP
from model.simulation.mpc.stagewise import StagewiseQP

REPAIR_PASSES = 3  # evaluations of the soft rows when raising their slacks after a step
QP_SOLVERS = ("qpoases", "daqp", "hpipm")  # hpipm: the stagewise QP (``stagewise``), not condensed
# qpOASES dense, with the settings of its MPC preset (``Options::setToMPC``: no ramping, far bounds,
# no flipping bounds, no full linear-independence or zero-curvature tests, no drift correction, no
# refactorisation, no refinement steps). Measured on the road cases' recorded QP sequences: the
# same solutions (within 1e-12), the truck's worst QP 17 ms against 67 ms (CPU, load 5).
QPOASES_OPTIONS = {"printLevel": "none", "sparse": False, "hessian_type": "posdef", "enableRamping": False,
                   "enableFarBounds": True, "enableFlippingBounds": False, "enableFullLITests": False,
                   "enableNZCTests": False, "enableDriftCorrection": 0, "enableCholeskyRefactorisation": 0,
                   "numRefinementSteps": 0}  # fmt: skip

# qpOASES' message when the cap on working-set changes (its ``nWSR``) is reached
QPOASES_CAPPED = "Maximum number of working set recalculations"


@dataclass
class StepResult:
    """One real-time iteration: the new primal point, the QP's status, the time it took (s)."""

    x: np.ndarray
    success: bool
    status: str
    seconds: float
    step: float
    qp_iterations: int = -1
    qp_seconds: float = 0.0


class RealTimeIteration:
    """Condensed SQP steps on the horizon's built NLP (the QP solver created once).

    Parameters
    ----------
    model : pyo.ConcreteModel
        The horizon's model (``build_model`` with a ``Horizon``): its transcription
        (``model.direct.families``) says which rows are the dynamics and the definitions.
    nlp : CasadiNLP
        Its NLP.
    states : sequence of str
        The state names, in the transcription's order.
    solver : str
        A ``casadi.conic`` plug-in (``QP_SOLVERS``): a dense one on the condensed QP, or "hpipm".
    regularization : float
        The proximal term on every QP variable (in the NLP's own units).
    options : dict, optional
        Options of the QP plug-in (added to the defaults; hpipm's for "hpipm").
    controls : sequence of str, optional
        The control names (needed by the stagewise QP of "hpipm").
    """

    def __init__(self, model: pyo.ConcreteModel, nlp: CasadiNLP, states, solver: str = "qpoases",
                 regularization: float = 1e-6, options: dict | None = None, controls=None):  # fmt: skip
        if not ca.has_conic(solver):
            raise ValueError(f"casadi has no QP solver {solver!r}")
        self.nlp, self.delta, self.solver = nlp, float(regularization), solver
        self._partition(model, states)
        jac = nlp.evaluate_jacobian()
        self._jac_parts = self._split(jac.row, jac.col)
        self._elastic_entries(jac.row, jac.col)
        self.stagewise = None
        if solver == "hpipm":
            if controls is None:
                raise ValueError("the stagewise QP needs the control names")
            self.stagewise = StagewiseQP(model, nlp, states, controls, self.held, jac.row, jac.col, options)
        else:
            n_z = len(self.free) + 1  # the last: the elastic variable
            n_rows = len(self.rest) + len(self.bounded_dep)
            opts = {"error_on_fail": False}
            if solver == "qpoases":
                opts |= QPOASES_OPTIONS
            opts |= options or {}
            sp = {"h": ca.Sparsity.dense(n_z, n_z), "a": ca.Sparsity.dense(n_rows, n_z)}
            self.qp = BufferedQP(ca.conic("rti", solver, sp, opts))
        self._hz: np.ndarray | None = None
        self._h = None

    # -- structure ----------------------------------------------------------------------------
    def _partition(self, m: pyo.ConcreteModel, states) -> None:
        """Dependent columns D and their defining rows E; the free QP columns; the fixed ones; the
        other rows R."""
        nlp = self.nlp
        n, rows = nlp.n_primals(), nlp.n_constraints()
        record = transcription_of(m)
        dep_rows = [nlp.rows_of(row) for row in record.dynamics()]
        dep_cols = [nlp.columns_of(s)[1:] for s in states]
        for var, row in record.definitions:
            dep_cols.append(nlp.columns_of(var))
            dep_rows.append(nlp.rows_of(row))
        self.dep, self.eq = np.concatenate(dep_cols), np.concatenate(dep_rows)
        if np.any(self.dep < 0) or np.any(self.eq < 0) or len(self.dep) != len(self.eq):
            raise ValueError("the horizon's dynamics and definitions do not condense")
        held = [nlp.columns_of(v) for v in record.slack_columns + record.family_slacks("obstacle")]
        self.held = np.concatenate(held) if held else np.zeros(0, int)
        role = np.zeros(n, dtype=int)  # 0 free, 1 dependent, 2 held
        role[self.dep], role[self.held] = 1, 2
        self.others = np.flatnonzero(role != 1)  # free or held (or fixed by bounds)
        is_row = np.ones(rows, dtype=bool)
        is_row[self.eq] = False
        self.rest = np.flatnonzero(is_row)
        self._role = role
        self.free = np.flatnonzero(role == 0)  # the fixed ones among them are decided per step
        lb, ub = nlp.primals_lb()[self.dep], nlp.primals_ub()[self.dep]
        state_dep = np.concatenate(dep_cols[: len(states)])
        bounded = np.isin(self.dep, state_dep) & (np.isfinite(lb) | np.isfinite(ub))
        self.bounded_dep = np.flatnonzero(bounded)  # positions in dep

    def _split(self, rows: np.ndarray, cols: np.ndarray) -> dict:
        """For each block (rows E or R) x (columns D, other): which Jacobian entries fall in it and
        how they fill a fixed CSC pattern (entries, order, indices, indptr, shape)."""
        n, m = self.nlp.n_primals(), self.nlp.n_constraints()
        row_pos = np.full(m, -1)
        row_pos[self.eq], row_pos[self.rest] = np.arange(len(self.eq)), np.arange(len(self.rest))
        col_d, col_o = np.full(n, -1), np.full(n, -1)
        col_d[self.dep], col_o[self.others] = np.arange(len(self.dep)), np.arange(len(self.others))
        in_eq = np.zeros(m, dtype=bool)
        in_eq[self.eq] = True
        parts = {}
        for rname, rmask in (("E", in_eq[rows]), ("R", ~in_eq[rows])):
            for cname, cpos in (("D", col_d), ("O", col_o)):
                k = np.flatnonzero(rmask & (cpos[cols] >= 0))
                shape = (len(self.eq if rname == "E" else self.rest), len(self.dep if cname == "D" else self.others))
                pattern = coo_matrix((np.arange(1, len(k) + 1, dtype=float), (row_pos[rows[k]], cpos[cols[k]])),
                                     shape=shape).tocsc()  # fmt: skip
                pattern.sort_indices()
                if pattern.nnz != len(k):
                    raise ValueError("repeated entries in the Jacobian's pattern")
                order = k[pattern.data.astype(int) - 1]
                parts[rname + cname] = (order, pattern.indices.copy(), pattern.indptr.copy(), shape)
        return parts

    def _elastic_entries(self, rows: np.ndarray, cols: np.ndarray) -> None:
        """The Jacobian entries of the held slacks: their rows (positions in R and in g) and columns."""
        k = np.flatnonzero(np.isin(cols, self.held))
        if len(np.unique(rows[k])) != len(k):
            raise ValueError("a soft row with more than one slack")
        rest_pos = np.full(self.nlp.n_constraints(), -1)
        rest_pos[self.rest] = np.arange(len(self.rest))
        self._soft_k, self._soft_rows, self._soft_cols = k, rows[k], cols[k]
        self._soft_rest = rest_pos[rows[k]]

    def _block(self, data: np.ndarray, name: str) -> csc_matrix:
        order, indices, indptr, shape = self._jac_parts[name]
        return csc_matrix((data[order], indices, indptr), shape=shape)

    def _dense_free(self, data: np.ndarray, name: str, free_pos: np.ndarray) -> np.ndarray:
        """Block ``name``'s columns ``free_pos`` as a dense array, scattered straight from the
        Jacobian's values (the same array as slicing the sparse block and ``toarray``; the scatter
        indices are kept per set of free columns, which changes only when a bound fixes a column)."""
        key = (name, free_pos.tobytes())
        cache = self.__dict__.setdefault("_scatter", {})
        if key not in cache:
            order, indices, indptr, shape = self._jac_parts[name]
            col = np.repeat(np.arange(shape[1]), np.diff(indptr))
            where = np.full(shape[1], -1)
            where[free_pos] = np.arange(len(free_pos))
            keep = where[col] >= 0
            cache[key] = (indices[keep] * len(free_pos) + where[col[keep]], order[keep], (shape[0], len(free_pos)))
        target, source, shape = cache[key]
        out = np.zeros(shape[0] * shape[1])
        out[target] = data[source]
        return out.reshape(shape)

    # -- the objective's Hessian ------------------------------------------------------------------
    def refresh_hessian(self) -> None:
        """Evaluate the objective's Hessian again at the next step (after its Params changed)."""
        self._h = None

    def _hessian(self) -> csc_matrix:
        nlp = self.nlp
        nlp.set_obj_factor(1.0)
        nlp.set_duals(np.zeros(nlp.n_constraints()))
        lower = nlp.evaluate_hessian_lag()
        full = coo_matrix((lower.data, (lower.row, lower.col)), shape=lower.shape)
        off = coo_matrix((np.where(lower.row != lower.col, lower.data, 0.0), (lower.col, lower.row)), shape=lower.shape)
        return (full + off).tocsc()

    # -- a step ---------------------------------------------------------------------------------------
    def step(self, x: np.ndarray) -> StepResult:
        """One condensed SQP step from the primal point ``x`` (the problem's Params already set)."""
        t0 = time.perf_counter()
        nlp = self.nlp
        nlp.set_primals(x)
        if self._h is None:
            self._h = self._hessian()
            if self.stagewise is not None:
                self.stagewise.set_hessian(self._h, self.delta)
            else:
                self._hessian_blocks()
            nlp.set_primals(x)
        g, grad, data = nlp.evaluate_first_order()
        if self.stagewise is not None:
            return self._stagewise_step(x, g, grad, data, t0)
        lbx, ubx = nlp.primals_lb(), nlp.primals_ub()
        others = self.others
        fixed = (self._role[others] == 2) | (lbx[others] == ubx[others])
        d_other = np.where(fixed, np.where(self._role[others] == 2, 0.0, lbx[others] - x[others]), 0.0)
        free_pos = np.flatnonzero(~fixed)
        J_ED, J_EO = self._block(data, "ED"), self._block(data, "EO")
        J_RD, J_RO = self._block(data, "RD"), self._block(data, "RO")
        try:
            lu = splu(J_ED)
        except RuntimeError as exc:
            return StepResult(x, False, f"singular dynamics: {exc}", time.perf_counter() - t0, 0.0)
        J_EO_free = self._dense_free(data, "EO", free_pos)
        a = -lu.solve(g[self.eq] + J_EO @ d_other)
        S = -lu.solve(J_EO_free)
        A_rest = J_RD @ S + self._dense_free(data, "RO", free_pos)
        b_rest = g[self.rest] + J_RD @ a + J_RO @ d_other
        lba, uba = nlp.constraints_lb()[self.rest] - b_rest, nlp.constraints_ub()[self.rest] - b_rest
        bd = self.bounded_dep
        dep = self.dep[bd]
        A = np.vstack([A_rest, S[bd]])
        lba = np.concatenate([lba, lbx[dep] - x[dep] - a[bd]])
        uba = np.concatenate([uba, ubx[dep] - x[dep] - a[bd]])
        Hz, gz = self._condensed_cost(grad, S, a, d_other, free_pos)
        cols, width, big = others[free_pos], len(self.free), 1e20
        A_qp = np.zeros((A.shape[0], width + 1))
        A_qp[:, : len(free_pos)] = A
        A_qp[self._soft_rest, width] = data[self._soft_k]  # the elastic column: each soft row's slack coefficient
        gz[width] = float(np.max(grad[self.held], initial=0.0)) * len(self._soft_k)
        lbz = _pad_bounds(np.clip(lbx[cols] - x[cols], -big, big), width + 1)
        ubz = _pad_bounds(np.clip(ubx[cols] - x[cols], -big, big), width + 1)
        ubz[width] = big if len(self._soft_k) else 0.0
        t_qp = time.perf_counter()
        stats = self.qp(Hz, gz, A_qp, np.clip(lba, -big, big), np.clip(uba, -big, big), lbz, ubz)
        self.qp_seconds, self.prep_seconds = time.perf_counter() - t_qp, t_qp - t0
        zs = self.qp.x
        z, self.elastic = zs[: len(free_pos)], float(zs[width])
        d = np.zeros(len(x))
        d[others], d[cols], d[self.dep] = d_other, z, a + S @ z
        status = str(stats.get("return_status", ""))
        # a capped qpOASES homotopy (nWSR reached): the iterate solves an intermediate QP on the path
        # from the previous one; accepted here, the caller's violation test decides (real-time early stop)
        capped = self.solver == "qpoases" and status.startswith(QPOASES_CAPPED)
        ok = (bool(stats.get("success", False)) or capped) and bool(np.all(np.isfinite(d)))
        status = status or ("solved" if ok else "failed")
        size = float(np.max(np.abs(d), initial=0.0))
        iterations = int(stats.get("iter_count", -1) or -1)
        new = self._repair(x + d, data) if ok else x
        return StepResult(new, ok, status, time.perf_counter() - t0, size, iterations, self.qp_seconds)

    def _stagewise_step(self, x, g, grad, data, t0: float) -> StepResult:
        """The step by the stagewise QP (hpipm): no condensing."""
        price = float(np.max(grad[self.held], initial=0.0)) * len(self._soft_k)
        t_qp = time.perf_counter()
        d, stats = self.stagewise.direction(x, g, grad, data, price)
        self.qp_seconds, self.prep_seconds = time.perf_counter() - t_qp, t_qp - t0
        self.elastic = self.stagewise.elastic
        status = str(stats.get("return_status", ""))
        ok = bool(stats.get("success", False)) and bool(np.all(np.isfinite(d)))
        size = float(np.max(np.abs(d), initial=0.0))
        iterations = int(stats.get("iter_count", -1) or -1)
        new = self._repair(x + d, data) if ok else x
        return StepResult(new, ok, status or ("solved" if ok else "failed"), time.perf_counter() - t0, size,
                          iterations, self.qp_seconds)  # fmt: skip

    def _repair(self, x: np.ndarray, data: np.ndarray) -> np.ndarray:
        """Raise each soft row's slack by what ``x`` lacks on the row, within the slack's bounds.

        A row is met from below (``g >= lb``, the slack's coefficient positive) or from above (``g <= ub``,
        e.g. a moving obstacle's ``(r - s)^2 - d^2 <= 0``, coefficient negative). The coefficient is the
        Jacobian's at the step's start (``data``), then the secant through the row's last two values (the
        rows may be nonlinear in their slack). A slack shared by several rows is raised by the largest
        need among them; the rows are evaluated again, up to ``REPAIR_PASSES`` times, and a slack whose rows
        still lack then goes to its upper bound (where a keep-out row's margin is zero).
        """
        if not len(self._soft_k):
            return x
        nlp, cols = self.nlp, self._soft_cols
        slope = data[self._soft_k]
        lb, ub = nlp.constraints_lb()[self._soft_rows], nlp.constraints_ub()[self._soft_rows]
        top = nlp.primals_ub()[cols]
        out, before = x.copy(), None
        for rounds in range(REPAIR_PASSES + 1):
            nlp.set_primals(out)
            g = nlp.evaluate_constraints()[self._soft_rows]
            if before is not None:
                moved = out[cols] - before[1]
                slope = np.where(moved > 1e-12, (g - before[0]) / np.maximum(moved, 1e-12), slope)
            below = np.where(slope > 1e-12, np.maximum(lb - g, 0.0) / np.maximum(slope, 1e-12), 0.0)
            above = np.where(slope < -1e-12, np.maximum(g - ub, 0.0) / np.maximum(-slope, 1e-12), 0.0)
            need = np.maximum(below, above)
            if not np.any(need > 0):
                break
            raise_by = np.zeros(len(out))
            np.maximum.at(raise_by, cols, need)
            if rounds == REPAIR_PASSES:  # still lacking (a row flat in its slack near its root): the bound
                lacking = (raise_by[cols] > 0) & np.isfinite(top)
                out[cols[lacking]] = top[lacking]
                break
            before = (g, out[cols].copy())
            out[cols] = np.minimum(out[cols] + raise_by[cols], top)
        return out

    def _hessian_blocks(self) -> None:
        """The Hessian's dense blocks the condensing needs, once per Hessian: the dependent columns
        it touches (h: the terminal states, few), and its rows and columns there and at the free
        columns (the objective has no curvature in the other dependent columns)."""
        H, dep, free = self._h, self.dep, self.free
        touched = np.flatnonzero(np.diff(H[:, dep].tocsc().indptr) > 0)  # positions in dep
        self._h_dep = touched
        rows = dep[touched]
        self._H_hh = H[rows][:, rows].toarray()
        self._H_hf = H[rows][:, free].toarray()
        self._H_ff = H[free][:, free].toarray()

    def _condensed_cost(self, grad, S, a, d_other, free_pos) -> tuple[np.ndarray, np.ndarray]:
        """H_z = T' H T + delta I and g_z = T' (grad + H t) for d = T z + t (T: the identity at the
        free columns, S at the dependent ones)."""
        H, others, dep = self._h, self.others, self.dep
        cols = others[free_pos]
        t = np.zeros(H.shape[0])
        t[others], t[dep] = d_other, a
        g_full = grad + H @ t
        S_h = S[self._h_dep]
        at = np.searchsorted(self.free, cols)  # the step's QP columns among the free ones
        H_hf = self._H_hf[:, at]
        HT_h = self._H_hh @ S_h + H_hf  # rows of H T at the touched dependent columns
        Hz = S_h.T @ HT_h + H_hf.T @ S_h + self._H_ff[np.ix_(at, at)]
        Hz = (Hz + Hz.T) / 2 + self.delta * np.eye(len(cols))
        gz = S.T @ g_full[dep] + g_full[cols]
        n_z = len(self.free) + 1
        H_pad = np.eye(n_z)  # the QP's size is fixed: unused variables get a unit Hessian, zero bounds
        H_pad[: len(cols), : len(cols)] = Hz
        H_pad[-1, -1] = self.delta  # the elastic variable
        return H_pad, np.pad(gz, (0, n_z - len(cols)))


def _pad_bounds(b: np.ndarray, width: int) -> np.ndarray:
    """``b`` with zeros up to ``width`` (the padding variables are fixed at 0)."""
    return np.concatenate([b, np.zeros(width - len(b))])
