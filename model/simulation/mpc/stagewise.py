"""The real-time iteration's QP in the OCP's stage layout, solved by hpipm (no condensing).

The step's QP of ``rti.RealTimeIteration`` written stage by stage for a structure-exploiting
interior-point solver (casadi's ``hpipm`` conic plug-in, a Riccati recursion: its cost per
iteration grows with N, not with the number of rows times the number of free columns):

- stage k's state s_k = (x_k, u_k, c): the states and controls at node k and the columns carried
  through every stage (the free final time: its rows and its Hessian entries sit in every
  stage); stage k's control v_k = (u_{k+1}, sigma_k) and, at the last interval, the last stage's
  extra columns (the terminal slacks, sigma_N), which s_N repeats;
- the trapezoid row of interval k, E_k dx_k + J_k ds_{k-1} + F_k du_k + g_k = 0, solved for dx_k
  (one small dense solve per stage), gives hpipm's gap rows s_k = A s_{k-1} + B v_{k-1} + b;
- the body-disc centres (``point_definitions``: one row with a diagonal coefficient each) are
  substituted into the rows that use them, which then depend on one stage's s_k alone;
- the soft rows' slacks are held, as in the condensed step; each stage has its own elastic
  variable sigma_k >= 0 at the price of the condensed step's single one.

Every product of the assembly has a fixed pattern, precomputed once: a step scatters the
Jacobian's values with ``numpy.bincount`` and solves the N small systems in one batched call.

Measured on the road cases (issue 19; benchmarks/bench_mpc_road.py ``--qp-solver hpipm``): the
step agrees with the condensed qpOASES step (to about 1e-3 of the step on the truck, 7e-4 m on the
semitrailer), but the interior point needs 20-40 iterations of ~0.5 ms on the semitrailer's stages
(nx 8, nu 3, ng 37), about 15-18 ms a step against the hot-started active set's ~9 ms mean; its
"speed" modes stop at the minimum step length unless the zero-width boxes (the start state, a
fixed final time) and the terminal equality rows are opened (option ``widen``), and a capped
iteration count leaves steps the violation test rejects. An option, not the default.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pyomo.environ as pyo
from scipy.sparse import coo_matrix, csc_matrix

from model.direct.families import transcription_of
from model.nlp.casadi_nlp import CasadiNLP
from model.simulation.mpc.qp_buffer import BufferedQP

BIG = 1e8  # hpipm's infinity (its interface's ``inf`` option)
HPIPM_OPTIONS = {"mode": "robust", "iter_max": 40}


class StagewiseQP:
    """The SQP step's QP of a horizon NLP in hpipm's stage layout (the pattern fixed once).

    Parameters
    ----------
    model : pyo.ConcreteModel
        The horizon's model (its transcription's trapezoid rows and point definitions).
    nlp : CasadiNLP
    states, controls : sequence of str
    held : ndarray of int
        Columns held in the step (the soft rows' slacks).
    rows, cols : ndarray of int
        The Jacobian's pattern (``evaluate_jacobian``'s entries).
    options : dict, optional
        hpipm options (added to ``HPIPM_OPTIONS``; ``mode``, ``iter_max``, ``res_*_max``...), and
        ``widen``: open zero-width boxes and equality rows by this much (default 0: as they are).

    Raises
    ------
    ValueError
        If the horizon does not have the stage structure (a row across stages other than the
        dynamics, a chained or non-diagonal definition).
    """

    def __init__(self, model: pyo.ConcreteModel, nlp: CasadiNLP, states, controls, held: np.ndarray,
                 rows: np.ndarray, cols: np.ndarray, options: dict | None = None):  # fmt: skip
        self.nlp = nlp
        n, m = nlp.n_primals(), nlp.n_constraints()
        X = np.array([nlp.columns_of(s) for s in states]).T  # (N+1, ns)
        U = np.array([nlp.columns_of(c) for c in controls]).T
        self.N, self.ns, self.nc = X.shape[0] - 1, X.shape[1], U.shape[1]
        N = self.N
        record = transcription_of(model)
        dyn = np.array([nlp.rows_of(row) for row in record.dynamics()]).T  # (N, ns)
        defs = [(nlp.columns_of(v), nlp.rows_of(r)) for v, r in record.definitions]
        P = np.concatenate([d[0] for d in defs]) if defs else np.zeros(0, int)
        P_rows = np.concatenate([d[1] for d in defs]) if defs else np.zeros(0, int)
        if np.any(X < 0) or np.any(U < 0) or np.any(dyn < 0) or np.any(P < 0) or np.any(P_rows < 0):
            raise ValueError("the horizon's states, controls or definitions left the NLP")
        stage = np.full(n, -1)
        stage[X.ravel()] = np.repeat(np.arange(N + 1), self.ns)
        stage[U.ravel()] = np.repeat(np.arange(N + 1), self.nc)
        kind = np.zeros(n, dtype=int)  # 0 staged, 1 definition, 2 held, 3 other
        kind[P], kind[held] = 1, 2
        others = np.flatnonzero((stage < 0) & (kind == 0))
        kind[others] = 3
        is_dyn = np.zeros(m, dtype=bool)
        is_dyn[dyn.ravel()] = True
        row_of_def = np.full(n, -1)
        row_of_def[P] = P_rows
        is_def = np.zeros(m, dtype=bool)
        is_def[P_rows] = True
        # the definitions' stages (from the staged columns of their rows)
        k_def = np.flatnonzero(is_def[rows])
        def_stage = np.full(m, -1)
        staged = stage[cols[k_def]] >= 0
        np.maximum.at(def_stage, rows[k_def][staged], stage[cols[k_def]][staged])
        stage[P] = def_stage[P_rows]
        if np.any(stage[P] < 0):
            raise ValueError("a point definition without a state")
        # the other columns: carried through every stage, or extras of the last stage
        in_dyn = np.zeros(n, dtype=bool)
        in_dyn[cols[is_dyn[rows]]] = True
        row_lo, row_hi = np.full(m, N + 1), np.full(m, -1)
        ks = np.flatnonzero(stage[cols] >= 0)
        np.minimum.at(row_lo, rows[ks], stage[cols[ks]])
        np.maximum.at(row_hi, rows[ks], stage[cols[ks]])
        early = np.zeros(n, dtype=bool)
        ko = np.flatnonzero((kind[cols] == 3) & (row_lo[rows] < N))
        early[cols[ko]] = True
        carried = others[in_dyn[others] | early[others]]
        extra = others[~(in_dyn[others] | early[others])]
        self.carried, self.extra = carried, extra
        rest = np.flatnonzero(~is_dyn & ~is_def)
        bad = rest[(row_hi[rest] >= 0) & (row_lo[rest] != row_hi[rest])]
        if len(bad):
            raise ValueError(f"{len(bad)} rows couple two stages outside the dynamics")
        touches_extra = np.zeros(m, dtype=bool)
        touches_extra[rows[np.isin(cols, extra)]] = True
        row_stage = np.where(row_hi >= 0, row_hi, np.where(touches_extra, N, 0))
        self._layout(N, len(carried), len(extra))
        # position of a column's copy in stage k (staged: its own stage; carried: any stage)
        self._pos_in_stage = self._stage_positions(X, U, carried, extra)
        self.X, self.U, self.P, self.held, self.stage = X, U, P, held, stage
        self._P_rows = P_rows
        self._dynamics_pattern(rows, cols, dyn, stage, kind)
        self._definitions_pattern(rows, cols, P, row_of_def, kind)
        self._rows_pattern(rows, cols, rest, row_stage, kind)
        self._build_solver(options)

    # -- layout -------------------------------------------------------------------------------
    def _layout(self, N: int, n_carry: int, n_extra: int) -> None:
        ns, nc = self.ns, self.nc
        self.nx = [ns + nc + n_carry] * N + [ns + nc + n_carry + n_extra + 1]
        self.nu = [nc + 1] * (N - 1) + [nc + 1 + n_extra + 1] + [0]
        off, s_off, v_off = 0, [], []
        for k in range(N + 1):
            s_off.append(off)
            off += self.nx[k]
            v_off.append(off)
            off += self.nu[k]
        self.s_off, self.v_off, self.nv = np.array(s_off), np.array(v_off), off

    def _stage_positions(self, X, U, carried, extra):
        """A function (column, stage) -> its QP variable in that stage (vectorised; a staged column
        only in its own stage, a carried one in any, an extra one in the last)."""
        n = self.nlp.n_primals()
        self._local = np.full(n, -1)  # offset inside s_k
        self._local[X] = np.arange(self.ns)[None, :]
        self._local[U] = self.ns + np.arange(self.nc)[None, :]
        self._local[carried] = self.ns + self.nc + np.arange(len(carried))
        self._local[extra] = self.ns + self.nc + len(carried) + np.arange(len(extra))
        return lambda c, k: self.s_off[k] + self._local[c]

    # -- patterns ---------------------------------------------------------------------------
    def _dynamics_pattern(self, rows, cols, dyn, stage, kind) -> None:
        """Where each dynamics entry goes: E (x_k), F (u_k) or J (s_{k-1}) of its interval."""
        N, ns, nc = self.N, self.ns, self.nc
        nS = self.nx[0]
        interval = np.full(self.nlp.n_constraints(), -1)
        interval[dyn.ravel()] = np.repeat(np.arange(N), ns)
        eq_index = np.full(self.nlp.n_constraints(), -1)
        eq_index[dyn.ravel()] = np.tile(np.arange(ns), N)
        k = np.flatnonzero(interval[rows] >= 0)
        r, c = rows[k], cols[k]
        j, i = interval[r], eq_index[r]
        st = stage[c]
        local = self._local[c]
        is_carry = np.isin(c, self.carried)
        if np.any(kind[c] == 1) or np.any(kind[c] == 2) or np.any(np.isin(c, self.extra)):
            raise ValueError("a dynamics row uses a definition, a slack or a terminal column")
        width = nS + nc + 1
        self._dyn_k = k
        new = (st == j + 1) & ~is_carry
        target = np.where(new & (local < ns), (j * ns + i) * ns + local, -1)  # E
        self._E_k, self._E_t = k[target >= 0], target[target >= 0]
        f = new & (local >= ns)
        self._F_k, self._F_t = k[f], ((j * ns + i) * width + nS + (local - ns))[f]
        prev = ((st == j) & ~is_carry) | is_carry
        if np.any(~(new | prev)):
            raise ValueError("a dynamics row reaches beyond its interval")
        self._J_k, self._J_t = k[prev], ((j * ns + i) * width + local)[prev]
        self._dyn_rows = dyn  # (N, ns)
        self._width = width

    def _definitions_pattern(self, rows, cols, P, row_of_def, kind) -> None:
        """dP = m + M ds: the definitions' diagonal and their entries on staged or carried columns."""
        n = self.nlp.n_primals()
        is_P = np.zeros(n, dtype=bool)
        is_P[P] = True
        def_col = np.full(self.nlp.n_constraints(), -1)
        def_col[row_of_def[P]] = P
        k = np.flatnonzero(def_col[rows] >= 0)
        p = def_col[rows[k]]
        diag = cols[k] == p
        if np.count_nonzero(diag) != len(P) or np.any(np.isin(kind[cols[k][~diag]], (1, 2))):
            raise ValueError("a point definition that is not diagonal in its own column")
        self._diag_k = np.empty(n, dtype=int)
        self._diag_k[p[diag]] = k[diag]
        off = k[~diag]
        self._M_k, self._M_p = off, p[~diag]  # M[p, s] = -J_D[p, s] / diag[p]
        self._M_pos = self._pos_in_stage(cols[off], self.stage[p[~diag]])
        self._M_row = rows[off]

    def _rows_pattern(self, rows, cols, rest, row_stage, kind) -> None:
        """The other rows (hpipm's lincons): direct entries, entries through a definition, sigma."""
        N = self.N
        m = self.nlp.n_constraints()
        order = np.lexsort((rest, row_stage[rest]))
        rest = rest[order]
        self.ng = np.bincount(row_stage[rest], minlength=N + 1)
        lin_row = np.full(m, -1)  # the QP row of each rest row
        first = np.zeros(N + 1, dtype=int)  # the first lincon row of each stage in the QP
        r_off = 0
        for k in range(N + 1):
            first[k] = r_off + (self.nx[k + 1] if k < N else 0)
            r_off = first[k] + self.ng[k]
        self.na = r_off
        within = np.arange(len(rest)) - np.concatenate([[0], np.cumsum(self.ng)])[row_stage[rest]]
        lin_row[rest] = first[row_stage[rest]] + within
        self._rest, self._lin_row, self._row_stage = rest, lin_row[rest], row_stage
        k = np.flatnonzero(lin_row[rows] >= 0)
        c = cols[k]
        direct = (kind[c] == 0) | (kind[c] == 3)
        sk = row_stage[rows[k]]
        self._D_k = k[direct]
        self._D_ij = (lin_row[rows[k[direct]]], self._pos_in_stage(c[direct], sk[direct]))
        soft = kind[c] == 2
        sig = np.where(sk < N, self.v_off[np.minimum(sk, N - 1)] + self.nc, self.s_off[N] + self.nx[N] - 1)
        self._S_k = k[soft]
        self._S_ij = (lin_row[rows[k[soft]]], sig[soft])
        self._soft_rows = rows[k[soft]]
        through = np.flatnonzero(kind[c] == 1)
        # entries through a definition: (rest entry on p) x (M entries of p)
        by_p = {}
        for e, p in enumerate(self._M_p):
            by_p.setdefault(int(p), []).append(e)
        pr_k, pr_e = [], []
        for t in through:
            for e in by_p.get(int(c[t]), []):
                pr_k.append(k[t])
                pr_e.append(e)
        pr_k, pr_e = np.array(pr_k, dtype=int), np.array(pr_e, dtype=int)
        self._T_k, self._T_e = pr_k, pr_e
        self._T_ij = (lin_row[rows[pr_k]], self._M_pos[pr_e])
        self._Tm_k = k[through]  # rest entries on a definition: the constant J_RP m
        self._Tm_row = lin_row[rows[k[through]]]
        self._Tm_p = c[through]

    def _build_solver(self, options: dict | None) -> None:
        N, ns, nc, nS = self.N, self.ns, self.nc, self.nx[0]
        gap_first = np.zeros(N, dtype=int)
        r_off = 0
        for k in range(N):
            gap_first[k] = r_off
            r_off += self.nx[k + 1] + self.ng[k]
        self._gap_first = gap_first
        # dense gap blocks of x-rows: J (s_{k-1}) and F (u part of v_{k-1}); -I on s_k
        kk, ir, jc = np.meshgrid(np.arange(N), np.arange(ns), np.arange(nS), indexing="ij")
        self._Adyn_J = (gap_first[kk] + ir, self.s_off[kk] + jc)
        kk2, ir2, jc2 = np.meshgrid(np.arange(N), np.arange(ns), np.arange(nc), indexing="ij")
        self._Adyn_F = (gap_first[kk2] + ir2, self.v_off[kk2] + jc2)
        const_i, const_j, const_v = [], [], []
        for k in range(N):
            g0, nxt = gap_first[k], self.nx[k + 1]
            for i in range(nxt):  # -I on s_{k+1}
                const_i.append(g0 + i)
                const_j.append(self.s_off[k + 1] + i)
                const_v.append(-1.0)
            for i in range(nc):  # u_{k+1} = v_k's u part
                const_i.append(g0 + ns + i)
                const_j.append(self.v_off[k] + i)
                const_v.append(1.0)
            for i in range(nS - ns - nc):  # carried: c_{k+1} = c_k
                const_i.append(g0 + ns + nc + i)
                const_j.append(self.s_off[k] + ns + nc + i)
                const_v.append(1.0)
            if k == N - 1:  # the last stage's extras and sigma_N, from v_{N-1}
                for i in range(self.nx[N] - nS):
                    const_i.append(g0 + nS + i)
                    const_j.append(self.v_off[k] + nc + 1 + i)
                    const_v.append(1.0)
        self._const = (np.array(const_i), np.array(const_j), np.array(const_v))
        parts = [self._Adyn_J, self._Adyn_F, (self._const[0], self._const[1]), self._D_ij, self._S_ij, self._T_ij]
        ii = np.concatenate([p[0].ravel() for p in parts])
        jj = np.concatenate([p[1].ravel() for p in parts])
        pattern = coo_matrix((np.ones(len(ii)), (ii, jj)), shape=(self.na, self.nv)).tocsc()
        pattern.sum_duplicates()
        pattern.sort_indices()
        lookup = csc_matrix((np.arange(1, pattern.nnz + 1, dtype=float), pattern.indices, pattern.indptr),
                            shape=pattern.shape)  # fmt: skip
        self._A_target = (np.asarray(lookup[ii, jj]).ravel() - 1).astype(int)
        self._A_sp = ca.Sparsity(self.na, self.nv, pattern.indptr.tolist(), pattern.indices.tolist())
        self._A_nnz = pattern.nnz
        sizes = np.cumsum([0] + [p[0].size for p in parts])
        self._A_slices = [slice(sizes[i], sizes[i + 1]) for i in range(len(parts))]
        self._H_sp = None
        self._options = {**HPIPM_OPTIONS, **(options or {})}
        self.widen = float(self._options.pop("widen", 0.0))

    # -- the Hessian (once per objective) ---------------------------------------------------------
    def set_hessian(self, H: csc_matrix, delta: float) -> None:
        """The objective's Hessian in the stage layout, plus ``delta`` on the controls, the carried
        and extra columns and each sigma (the condensed step's proximal term)."""
        Hc = H.tocoo()
        keep = (self._local[Hc.row] >= 0) & (self._local[Hc.col] >= 0)
        r, c, v = Hc.row[keep], Hc.col[keep], Hc.data[keep]
        sr, sc = self.stage[r], self.stage[c]
        k = np.where(sr >= 0, sr, np.where(sc >= 0, sc, 0))
        k = np.where(np.isin(r, self.extra) | np.isin(c, self.extra), self.N, k)
        if np.any((sr >= 0) & (sc >= 0) & (sr != sc)):
            raise ValueError("the objective couples two stages")
        i, j = self._pos_in_stage(r, k), self._pos_in_stage(c, k)
        reg = [self._pos_in_stage(self.U.ravel(), np.repeat(np.arange(self.N + 1), self.nc))]
        reg.append(self._pos_in_stage(self.carried, 0))
        reg.append(self._pos_in_stage(self.extra, self.N))
        reg.append(np.append(self.v_off[: self.N] + self.nc, self.s_off[self.N] + self.nx[self.N] - 1))
        reg = np.concatenate(reg)
        # every variable gets a diagonal entry (hpipm's Riccati recursion needs R > 0 on v)
        diag = np.arange(self.nv)
        ii = np.concatenate([i, reg, diag])
        jj = np.concatenate([j, reg, diag])
        vv = np.concatenate([v, np.full(len(reg), delta), np.full(self.nv, 1e-10)])
        Hq = coo_matrix((vv, (ii, jj)), shape=(self.nv, self.nv)).tocsc()
        Hq.sum_duplicates()
        Hq.sort_indices()
        sp = ca.Sparsity(self.nv, self.nv, Hq.indptr.tolist(), Hq.indices.tolist())
        if self._H_sp is None or sp != self._H_sp:
            self._H_sp = sp
            opts = {"N": self.N, "nx": self.nx, "nu": self.nu, "ng": self.ng.tolist(), "inf": BIG,
                    "error_on_fail": False, "hpipm": self._options}  # fmt: skip
            qp = ca.conic("rti_stagewise", "hpipm", {"h": sp, "a": self._A_sp}, opts)
            self.qp = BufferedQP(qp, every_input=True)
        self._H_vals = Hq.data.copy()

    # -- a step -----------------------------------------------------------------------------
    def direction(self, x, g, grad, data, price: float) -> tuple[np.ndarray, dict]:
        """The step d (all NLP columns; the held ones 0) and the QP's stats."""
        nlp, N, ns, nc = self.nlp, self.N, self.ns, self.nc
        lbx, ubx = nlp.primals_lb(), nlp.primals_ub()
        # definitions: dP = m + M ds
        diag = data[self._diag_k[self.P]]
        inv = np.zeros(nlp.n_primals())
        inv[self.P] = 1.0 / diag
        m_P = np.zeros(nlp.n_primals())
        m_P[self.P] = -g[self._P_rows] * inv[self.P]
        M_vals = -data[self._M_k] * inv[self._M_p]
        # dynamics: one batched solve
        width = self._width
        E = np.zeros(N * ns * ns)
        E[self._E_t] = data[self._E_k]
        rhs = np.zeros(N * ns * width)
        rhs[self._F_t] = data[self._F_k]
        rhs[self._J_t] = data[self._J_k]
        rhs = rhs.reshape(N, ns, width)
        rhs[:, :, -1] = g[self._dyn_rows]
        sol = np.linalg.solve(E.reshape(N, ns, ns), rhs)
        nS = self.nx[0]
        contrib = np.concatenate([-sol[:, :, :nS].ravel(), -sol[:, :, nS:nS + nc].ravel(), self._const[2],
                                  data[self._D_k], data[self._S_k],
                                  data[self._T_k] * M_vals[self._T_e]])  # fmt: skip
        a = np.bincount(self._A_target, weights=contrib, minlength=self._A_nnz)
        # row bounds: gap rows E^-1 g (x part), 0; lincons lb - g - J_RP m
        lba, uba = np.zeros(self.na), np.zeros(self.na)
        gap_x = (self._gap_first[:, None] + np.arange(ns)[None, :]).ravel()
        lba[gap_x] = uba[gap_x] = sol[:, :, -1].ravel()
        shift = np.bincount(self._Tm_row, weights=data[self._Tm_k] * m_P[self._Tm_p], minlength=self.na)
        b = g[self._rest] + shift[self._lin_row]
        lba[self._lin_row] = np.maximum(nlp.constraints_lb()[self._rest] - b, -BIG)
        uba[self._lin_row] = np.minimum(nlp.constraints_ub()[self._rest] - b, BIG)
        # gradient, bounds
        q = np.zeros(self.nv)
        lb, ub = np.full(self.nv, -BIG), np.full(self.nv, BIG)
        XU = np.concatenate([self.X, self.U], axis=1)
        stages = np.repeat(np.arange(N + 1), ns + nc)
        pos = self._pos_in_stage(XU.ravel(), stages)
        cols = XU.ravel()
        for c, p in ((cols, pos), (self.carried, self._pos_in_stage(self.carried, 0)),
                     (self.extra, self._pos_in_stage(self.extra, N))):  # fmt: skip
            q[p] = grad[c]
            lb[p] = np.clip(lbx[c] - x[c], -BIG, BIG)
            ub[p] = np.clip(ubx[c] - x[c], -BIG, BIG)
        q += np.bincount(self._M_pos, weights=grad[self._M_p] * M_vals, minlength=self.nv)
        sig = np.append(self.v_off[:N] + nc, self.s_off[N] + self.nx[N] - 1)
        q[sig] = price
        lb[sig], ub[sig] = 0.0, (BIG if len(self._S_k) else 0.0)
        if self.widen:  # zero-width boxes and equality rows opened by +-widen (an interior for the IPM)
            lo_g, hi_g = lba[self._lin_row], uba[self._lin_row]
            for lo, hi in ((lb, ub), (lo_g, hi_g)):
                same = hi - lo <= 0.0
                lo[same] -= self.widen
                hi[same] += self.widen
            lba[self._lin_row], uba[self._lin_row] = lo_g, hi_g
        stats = self.qp(self._H_vals, q, a, lba, uba, lb, ub)
        z = self.qp.x
        d = np.zeros(nlp.n_primals())
        d[cols] = z[pos]
        d[self.carried] = z[self._pos_in_stage(self.carried, 0)]
        d[self.extra] = z[self._pos_in_stage(self.extra, N)]
        fixed = lbx == ubx
        d[fixed] = (lbx - x)[fixed]
        d[self.P] = m_P[self.P] + np.bincount(self._M_p, weights=M_vals * z[self._M_pos],
                                              minlength=nlp.n_primals())[self.P]  # fmt: skip
        d[self.held] = 0.0
        self.elastic = float(np.max(z[sig], initial=0.0))
        return d, stats
