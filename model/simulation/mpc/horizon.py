"""The horizon problem of the MPC: the scenario's own OCP built once with the transcription's options.

``HorizonModel`` asks ``build_model`` for the receding-horizon model (``model.direct.options``):
soft keep-out and road-body rows priced per metre, a rate disturbance ``d_hat`` per state, a soft
terminal target and the horizon's objective. A step changes only mutable Params (start, duration,
target, weights, the disturbance, the node times and whatever time-varying data is indexed by
node: ``set_problem``), re-reads them into the CasADi NLP and solves from a warm start.

Where each primal column and each row sits in time (``TimeLayout``) is read from the NLP's
accessors of named components (``CasadiNLP.columns_of``, ``rows_of``): warm starts move a vector
laid out like the horizon onto a shifted grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np
import pyomo.environ as pyo

from model.direct.families import transcription_of
from model.direct.moving import fill_moving_at
from model.direct.options import Horizon, TranscriptionOptions
from model.direct.resolve import WARM_OPTIONS
from model.direct.solve import paused_gc
from model.direct.transcription import build_model
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import IpoptResult, run_ipopt
from model.problem.ocp import OCP


@dataclass
class Plan:
    """One solved horizon: node times (absolute), the NLP's primal and dual vectors."""

    times: np.ndarray
    x: np.ndarray
    mult_g: np.ndarray
    mult_x_L: np.ndarray
    mult_x_U: np.ndarray
    values: dict[str, np.ndarray]

    def mean(self, name: str, start: float, end: float) -> float:
        """The mean of a node variable (piecewise linear in time) over [start, end], clipped to the plan."""
        a, b = max(start, self.times[0]), min(end, self.times[-1])
        if b <= a:
            return float(np.interp(a, self.times, self.values[name]))
        inside = self.times[(self.times > a) & (self.times < b)]
        ts = np.concatenate([[a], inside, [b]])
        return float(np.trapezoid(np.interp(ts, self.times, self.values[name]), ts) / (b - a))


class HorizonModel:
    """The horizon OCP built once: Params for the start, the horizon length and the terminal target.

    Parameters
    ----------
    ocp : OCP
        The scenario's problem (not modified).
    intervals : int
        Trapezoid intervals of the horizon.
    scales : dict
        Scale of each state's terminal error (m for positions, rad for angles).
    cost_scales : tuple of float
        (final time, energy) that normalise the cost to about 1.
    settings : MPCSettings
        The penalty weights (``terminal_l1``, ``terminal_quadratic``, ``obstacle_l1``, ``time_energy``).
    path_length : float
        The reference's path length (m): normalises the keep-out slacks.

    Attributes
    ----------
    model : pyo.ConcreteModel
        The horizon's Pyomo model (``m.node_time`` and ``m.node_parameters``: the hook for data
        that varies along the horizon, filled by ``set_problem`` from the node times).
    nlp : CasadiNLP
    columns, rows : TimeLayout
        Where each primal column and each row of the reduced NLP sits in the horizon.
    node_cols : dict of str to ndarray
        The columns of each state and control at the nodes.
    """

    def __init__(self, ocp: OCP, intervals: int, scales: dict[str, float], cost_scales: tuple[float, float],
                 settings, path_length: float):  # fmt: skip
        self.ocp, self.n, self.settings = ocp, intervals, settings
        self.states, self.controls = ocp.vehicle.states, ocp.vehicle.controls
        self.free_time = ocp.cost.free_final_time
        self.scales = np.array([scales[k] for k in self.states])
        horizon = Horizon(scales=dict(scales), time_scale=cost_scales[0], energy_scale=cost_scales[1],
                          terminal_l1=settings.terminal_l1, terminal_quadratic=settings.terminal_quadratic)  # fmt: skip
        options = TranscriptionOptions(soft_penalty=settings.obstacle_l1 / path_length, rate_disturbance=True,
                                       horizon=horizon)  # fmt: skip
        with paused_gc():
            self.model = build_model(ocp, intervals, passing=None, options=options)
            self.nlp = CasadiNLP(self.model)
        if ocp.moving_obstacles:  # their disc centres at the horizon's absolute node times, every step
            self.model.node_parameters.append(partial(fill_moving_at, self.model, ocp))
        self._layout()

    def _layout(self) -> None:
        """Where each primal column and each row of the reduced NLP sits in time (fraction of the horizon)."""
        nlp, m, n = self.nlp, self.model, self.n
        col_frac, row_frac = np.full(nlp.n_primals(), np.nan), np.full(nlp.n_constraints(), np.nan)
        for kind, where, out in ((pyo.Var, nlp.columns_of, col_frac), (pyo.Constraint, nlp.rows_of, row_frac)):
            for comp in m.component_objects(kind, active=True if kind is pyo.Constraint else None, descend_into=True):
                for data, j in zip(comp.values(), where(comp), strict=True):
                    if j >= 0:
                        out[j] = node_fraction(data, n)
        self.columns, self.rows = TimeLayout(col_frac, n), TimeLayout(row_frac, n)
        self.node_cols = {name: nlp.columns_of(name) for name in (*self.states, *self.controls)}
        if any(np.any(c < 0) for c in self.node_cols.values()):
            raise RuntimeError("a state or control node left the NLP")
        self.tf_col = int(nlp.columns_of(m.tf)[0]) if self.free_time else None
        record = transcription_of(m)
        self.above_cols, self.below_cols = (nlp.columns_of(v) for v in record.family_slacks("terminal"))
        self.keep_out_cols = nlp.columns_of(record.family_slacks("obstacle")[0]).reshape(-1, len(m.nodes))

    # -- a step -----------------------------------------------------------------------------
    def set_problem(self, start: dict[str, float], length: float, free: bool, target: dict[str, float],
                    weights: dict[str, float], disturbance: np.ndarray | None = None,
                    times: np.ndarray | None = None) -> None:  # fmt: skip
        """Initial state, horizon length (a fixed value, or a guess if ``free``), terminal target, the
        disturbance on the state rates (state order; None: zero) and the node times (absolute
        seconds; None: 0 .. length): ``m.node_time`` and every ``m.node_parameters`` filler get them."""
        m = self.model
        d = np.zeros(len(self.states)) if disturbance is None else disturbance
        for name, val in zip(self.states, d, strict=True):
            m.d_hat[name].set_value(float(val))
        for name, val in start.items():
            lo, hi = self.ocp.bounds.get(name, (-math.inf, math.inf))
            transcription_of(m).initial[name].set_value(min(max(val, lo), hi))
        for name in self.states:
            m.target[name] = target[name]
            m.target_weight[name] = weights[name]
        if self.free_time:  # a fixed horizon's running cost is the energy alone; a free one's the time
            m.tf.setlb(1e-3 if free else length)
            m.tf.setub(None if free else length)
            m.time_weight.set_value(1.0 if free else 0.0)
            m.energy_weight.set_value(self.settings.time_energy if free else 1.0)
        else:
            m.tf.set_value(length)
        self.set_node_times(np.linspace(0.0, length, self.n + 1) if times is None else np.asarray(times))
        self.nlp.refresh_parameters(variables=[m.tf] if self.free_time else [])  # tf: the only bounds that move

    def set_node_times(self, times: np.ndarray) -> None:
        """The hook for time-varying data: ``m.node_time`` per node, then each ``m.node_parameters``
        filler (node-indexed mutable Params such as a moving obstacle's centre) with ``times``."""
        m = self.model
        for t, value in zip(m.nodes, times, strict=True):
            m.node_time[t].set_value(float(value))
        for fill in m.node_parameters:
            fill(times)

    def fill_slacks(self, x: np.ndarray) -> None:
        """Set the terminal and keep-out slacks of a primal vector to match its node values (in place)."""
        m = self.model
        end = np.array([x[self.node_cols[k][-1]] for k in self.states])
        target = np.array([float(m.target[k].value) for k in self.states])
        err = (end - target) / self.scales
        x[self.above_cols] = np.maximum(err, 0.0) + 1e-8
        x[self.below_cols] = np.maximum(-err, 0.0) + 1e-8
        px, py = self.ocp.vehicle.position
        X, Y = x[self.node_cols[px]], x[self.node_cols[py]]
        for i, cols in zip(m.obstacle_set, self.keep_out_cols, strict=True):
            R = float(m.obstacle_R[i].value)
            dist = np.hypot(X - float(m.obstacle_cx[i].value), Y - float(m.obstacle_cy[i].value))
            x[cols] = np.clip(R - dist, 0.0, R) + 1e-8

    def solve(self, x0: np.ndarray, duals: tuple | None, options: dict) -> IpoptResult:
        """Run Ipopt on the built NLP from ``x0`` (and the multipliers ``duals``)."""
        opts = {**(WARM_OPTIONS if duals is not None else {}), **options}
        return run_ipopt(self.nlp, opts, x0=x0, duals=duals)

    def violation(self, x: np.ndarray) -> float:
        """The largest violation of a row's bounds at the primal vector ``x`` (absolute units)."""
        nlp = self.nlp
        nlp.set_primals(x)
        g = nlp.evaluate_constraints()
        return float(np.max(np.maximum(nlp.constraints_lb() - g, g - nlp.constraints_ub()), initial=0.0))

    def horizon_length(self, x: np.ndarray, fixed: float) -> float:
        """The horizon's length in a primal vector (the fixed value unless the final time is free)."""
        return float(x[self.tf_col]) if self.tf_col is not None and self.free_time else fixed


def node_fraction(data, n: int) -> float:
    """A variable's or row's place in the horizon in [0, 1]; NaN for one not tied to a node.

    Parameters
    ----------
    data : pyomo VarData or ConstraintData
        An entry of a horizon model's component.
    n : int
        Intervals of the horizon (the trapezoid rows k = 1..N sit at k / N).
    """
    comp = data.parent_component()
    if not comp.is_indexed():
        return math.nan
    idx = data.index()
    tau = idx[-1] if isinstance(idx, tuple) else idx
    tau_indexed = any(getattr(s, "local_name", "") == "tau" for s in comp.index_set().subsets())
    if tau_indexed:
        return float(tau)
    if isinstance(tau, int) and len(comp) == n:  # the trapezoid rows k = 1..N
        return tau / n
    return math.nan


class TimeLayout:
    """Where the entries of a vector laid out like the horizon (primals, rows) sit in time.

    Parameters
    ----------
    fractions : ndarray
        Each entry's place in the horizon in [0, 1] (node k at k / N), NaN if not tied to a node.
    n : int
        Intervals of the horizon.

    Entries of one component are consecutive and ordered by node (Pyomo's order, kept by the
    NLP's reduction): runs of consecutive nodes are found once, and an entry's neighbour at
    node j is the entry of its own run at that node (clipped to the run).
    """

    def __init__(self, fractions: np.ndarray, n: int):
        self.n = n
        self.tied = np.flatnonzero(~np.isnan(fractions))
        k = np.rint(fractions[self.tied] * n).astype(int)
        new_run = np.ones(len(k), dtype=bool)
        new_run[1:] = (np.diff(self.tied) != 1) | (np.diff(k) != 1)
        run = np.cumsum(new_run) - 1
        firsts = np.flatnonzero(new_run)
        lasts = np.append(firsts[1:] - 1, len(k) - 1)
        self.first, self.last = self.tied[firsts][run], self.tied[lasts][run]
        self.k0 = k[firsts][run]
        self.k = k

    def move(self, vector: np.ndarray, old: np.ndarray, new: np.ndarray) -> np.ndarray:
        """``vector`` on the uniform grid ``old`` (node times) moved onto the uniform grid ``new``.

        Tied entries are interpolated linearly in time and held beyond the old grid's ends;
        the others keep their value.
        """
        out = vector.copy()
        times = new[0] + self.k / self.n * (new[-1] - new[0])
        pos = np.clip((times - old[0]) / max(old[-1] - old[0], 1e-12) * self.n, 0, self.n)
        lo = np.minimum(np.floor(pos).astype(int), self.n - 1)
        w = pos - lo
        src_lo = np.clip(self.first + lo - self.k0, self.first, self.last)
        src_hi = np.clip(self.first + lo + 1 - self.k0, self.first, self.last)
        out[self.tied] = (1 - w) * vector[src_lo] + w * vector[src_hi]
        return out
