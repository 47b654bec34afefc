"""Nonlinear MPC: the scenario's own OCP re-solved at every sample, warm-started, in real time.

One Pyomo/CasADi model of the horizon is built at construction (``HorizonModel``); a step only
changes its mutable Params (start, horizon length, terminal target), runs Ipopt on the built NLP
and reads the plan out of the primal vector (no validation, no certificate: they cost more than
the solve).

The horizon problem (``horizon`` intervals, or the scenario's own N when "shrinking"):

- the scenario's dynamics (trapezoid), bounds and output bounds, from the measured state
  predicted through the controls still in the actuator's delay line (nominal model, RK4);
- the horizon is ``horizon * sample_time`` while that ends before the final time Tf (receding;
  terminal target: the reference optimum's state at the horizon's end; cost: the energy), then
  the time left, Tf - t - delay (shrinking; target: the scenario's final conditions);
- energy objective: the cost is the energy throughout;
- time objective: once the horizon reaches Tf, the scenario's own minimum-time problem from where
  the vehicle is, the final time free (so the loop reaches the goal when the plant is slower than
  the model: ``final_time`` then moves later), plus ``time_energy`` times the normalised energy as
  a regulariser of the singular arcs. ``MPCSettings(time_receding=False)`` solves that free-time
  problem from the first step (measured in benchmarks/bench_mpc.py: as robust, fewer iterations,
  a later arrival under a speed loss);
- terminal targets are soft: an exact L1 penalty (plus a small quadratic) on scaled errors, so a
  reachable target is met as a hard constraint would be and an unreachable one is no infeasibility;
- keep-out discs and road-body constraints are soft too: slacks in metres with an exact L1 penalty.

The pass-direction constraint is left out: the warm start and the terminal targets keep the
vehicle on the reference's side of the obstacle, and a sign constraint on the swept angle must
not make a disturbed step infeasible.

Each step starts Ipopt from the previous iterate interpolated onto the new grid in time (primal;
its tail beyond the old horizon continued by the nominal model) and from its multipliers moved the
same way (duals), with an iteration cap and a wall-time budget. A step stopped early (wall time,
iteration cap, or any other non-converged stop) whose iterate satisfies the constraints to
``feasible_inf_pr`` relative to the scene (``MPC._violation``) is used and counted as
``truncated``; only a step without such an iterate is ``failed``. The control sent is the plan's
mean over the sample it acts on (the plan's controls are piecewise linear between nodes, the plant
holds one value over the sample). In the last ``stop_samples`` samples, or when a step fails
(``failed``), the controller follows the last usable plan; after the plan's end it sends zero.

Offset-free MPC (Pannocchia & Rawlings 2003; Maeder, Borrelli & Morari 2009; by default for a
fixed final time only, ``MPCSettings.offset_free``): the prediction model
is x' = f(x, u) + d with a constant disturbance d on the rates of the position and heading states
(mutable Params of the built model, so the CasADi NLP is built once). At each sample d is updated
from the prediction error over the last ``estimator_window`` samples: x_pred is the measurement
then, carried to now under the controls applied since by f + d_hat (RK4); with h that time,
d_hat <- d_hat + alpha (y - x_pred) / h, each component saturated at ``disturbance_share`` of the
largest rate of that state along the reference. A window of 1 is the one-step error; the default 3
divides the measurement noise in (y - x_pred) / h by 3 (real truck: 3 cm of noise at 0.1 s is
0.4 m/s in a one-step rate, as large as the crosswind), measured to end closer on both study
geometries (alpha 0.3 / 0.5, window 1 / 3). The same model f + d_hat predicts through the pending
(delayed) controls and continues a plan's tail. Undisturbed, the prediction error is the
integrator's only, and d_hat stays ~0.
"""

from __future__ import annotations

import copy
import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import pyomo.environ as pyo

from model.direct.resolve import WARM_OPTIONS
from model.direct.solution import Solution
from model.direct.solve import Start, load_start, paused_gc
from model.direct.transcription import build_model
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import IpoptResult, run_ipopt
from model.problem.closed_loop import ControlSettings, Disturbance
from model.problem.ocp import OCP

USABLE = ("optimal", "acceptable")
LIMIT_CODES = (-1, -4, -5)  # Ipopt: iteration limit, CPU time, wall time (-5 reads "solver_error" in ipopt.py)


@dataclass(frozen=True)
class MPCSettings:
    """Tuning of the controller (the defaults are the measured real-time choice).

    Attributes
    ----------
    ipopt : dict
        Ipopt options of a step (added to ``WARM_OPTIONS`` and the project's defaults).
    stop_samples : float
        Follow the last plan instead of re-solving when less than this many samples remain.
    terminal_l1, terminal_quadratic : float
        Weights of the scaled terminal error (per state; the cost is normalised to about 1).
    free_terminal : float
        Relative weight of a state the scenario leaves free at the end (pulled weakly towards
        the reference's final value, so that the problem stays bounded).
    obstacle_l1 : float
        Weight per metre of keep-out or road violation per node, relative to the path length.
    time_energy : float
        For the time objective, the weight of the (normalised) energy beside the final time.
    feasible_inf_pr : float
        A step stopped before convergence is still used (``truncated``) if its largest constraint
        violation, relative to the scene's size (``max(1, path length)``), is below this.
    time_receding : bool
        Time objective: receding horizon with the reference as terminal target until the horizon
        reaches Tf (else the free-final-time problem over the whole remaining manoeuvre).
    warm_from_iterate : bool
        Start the next step from a failed step's iterate (Ipopt's iterations carry over, as in a
        real-time iteration) rather than from the last usable plan.
    budget : float
        Ipopt's wall-time limit per step as a fraction of the sample time.
    offset_free : bool or None
        Estimate a constant disturbance on the position and heading rates and predict with it.
        None (default): for a fixed final time only. With a free final time a speed loss only delays
        the arrival, and the additive estimate, which does not vanish as u1 -> 0 at the goal,
        delays it more (time-real-s1, 5 % slower, 0.02 rad of steering bias: arrival at 6.0 s with
        the estimate against 5.25 s without, the optimum's 5.0 s).
    estimator_gain : float
        The filter gain alpha of the disturbance estimate (0 < alpha <= 1).
    disturbance_share : float
        Saturation of each estimated rate, as a share of that state's largest rate on the reference.
    estimator_window : int
        Samples of the prediction error: the measurement this many samples back is carried to now
        through the controls applied since, and the error divided by that time (1: the one-step
        error; more averages measurement noise, at the price of a lag).
    """

    ipopt: dict = field(
        default_factory=lambda: {
            "tol": 1e-6,
            "acceptable_tol": 1e-4,
            "acceptable_iter": 2,
            "max_iter": 60,
            "mu_init": 1e-5,
        }
    )
    stop_samples: float = 1.5
    terminal_l1: float = 100.0
    terminal_quadratic: float = 10.0
    free_terminal: float = 1e-3
    obstacle_l1: float = 100.0
    time_energy: float = 1e-2
    feasible_inf_pr: float = 1e-4
    time_receding: bool = True
    warm_from_iterate: bool = True
    budget: float = 0.8
    offset_free: bool | None = None
    estimator_gain: float = 0.5
    disturbance_share: float = 0.3
    estimator_window: int = 3


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
    path_length : float
        The reference's path length (m): normalises the keep-out slacks.
    """

    def __init__(self, ocp: OCP, intervals: int, scales: dict[str, float], cost_scales: tuple[float, float],
                 settings: MPCSettings, path_length: float):  # fmt: skip
        self.ocp, self.n, self.settings = ocp, intervals, settings
        self.states, self.controls = ocp.vehicle.states, ocp.vehicle.controls
        self.free_time = ocp.cost.free_final_time
        self.scales = np.array([scales[k] for k in self.states])
        with paused_gc():
            m = build_model(ocp, intervals, passing=None, relax=True)
            self._soften(m, scales, cost_scales, path_length)
            self._add_disturbance(m)
            self.model = m
            self.nlp = CasadiNLP(m)
        self._layout()

    # -- construction -------------------------------------------------------------------
    def _soften(self, m: pyo.ConcreteModel, scales: dict, cost_scales: tuple[float, float], length: float) -> None:
        """Replace the objective, the final conditions and the keep-out rows by their soft forms."""
        for comp in (m.objective, getattr(m, "violation", None), *(m.component(f"final_{k}") for k in self.ocp.final)):
            if comp is not None:
                comp.deactivate()
        slacks = self._soft_keep_out(m)
        slacks += [v[t] for v in getattr(m, "slacks", []) for t in m.nodes]  # road bodies (relax=True)
        penalty = self._soft_target(m, scales)
        m.time_weight = pyo.Param(mutable=True, initialize=1.0 if self.free_time else 0.0)
        m.energy_weight = pyo.Param(mutable=True, initialize=self.settings.time_energy if self.free_time else 1.0)
        m.mpc_objective = pyo.Objective(
            expr=m.time_weight * m.tf / cost_scales[0]
            + m.energy_weight * _energy(m, self.ocp) / cost_scales[1]
            + penalty
            + self.settings.obstacle_l1 / length * pyo.quicksum(slacks),
            sense=pyo.minimize,
        )

    def _add_disturbance(self, m: pyo.ConcreteModel) -> None:
        """dX/dtau = Tf (f(X, U) + d_hat): a mutable Param d_hat per state (zero: the nominal model)."""
        m.d_hat = pyo.Param(list(self.states), mutable=True, initialize=0.0)
        for name in self.states:
            ode = m.component(f"ode_{name}")
            for t in ode:
                lhs, rhs = ode[t].expr.args
                ode[t].set_value(lhs == rhs + m.tf * m.d_hat[name])

    def _soft_keep_out(self, m: pyo.ConcreteModel) -> list:
        """|p - c| >= R - s with a slack 0 <= s <= R (metres) per obstacle and node; the slacks."""
        m.obstacle.deactivate()
        px, py = self.ocp.vehicle.position
        X, Y = m.component(px), m.component(py)
        m.keep_out_slack = pyo.Var(m.obstacle_set, m.tau, bounds=lambda _m, i, t: (0.0, pyo.value(m.obstacle_R[i])),
                                   initialize=0.0)  # fmt: skip

        def keep_out(_m, i, t):
            gap = m.obstacle_R[i] - m.keep_out_slack[i, t]
            return (X[t] - m.obstacle_cx[i]) ** 2 + (Y[t] - m.obstacle_cy[i]) ** 2 >= gap**2

        m.soft_obstacle = pyo.Constraint(m.obstacle_set, m.tau, rule=keep_out)
        return [m.keep_out_slack[i, t] for i in m.obstacle_set for t in m.tau]

    def _soft_target(self, m: pyo.ConcreteModel, scales: dict):
        """(X_k(end) - target_k) / scale_k = above_k - below_k; the weighted L1 + quadratic penalty."""
        s = self.settings
        m.state_set = pyo.Set(initialize=list(self.states), ordered=True)
        m.target = pyo.Param(m.state_set, mutable=True, initialize=0.0)
        m.target_weight = pyo.Param(m.state_set, mutable=True, initialize=1.0)
        m.above = pyo.Var(m.state_set, bounds=(0.0, None), initialize=0.0)
        m.below = pyo.Var(m.state_set, bounds=(0.0, None), initialize=0.0)
        end = m.nodes[-1]

        def terminal(_m, k):
            return (m.component(k)[end] - m.target[k]) / scales[k] == m.above[k] - m.below[k]

        m.terminal = pyo.Constraint(m.state_set, rule=terminal)
        return sum(
            m.target_weight[k] * (s.terminal_l1 * (m.above[k] + m.below[k])
                                  + s.terminal_quadratic * (m.above[k] - m.below[k]) ** 2)
            for k in self.states
        )  # fmt: skip

    def _layout(self) -> None:
        """Where each primal column and each row of the reduced NLP sits in time (fraction of the horizon)."""
        nlp, n = self.nlp, self.n
        saved = [v.value for v in nlp.variables]
        for i, v in enumerate(nlp.variables):
            v.set_value(float(i), skip_validation=True)
        cols = np.rint(nlp.init_primals()).astype(int)
        for v, val in zip(nlp.variables, saved, strict=True):
            v.set_value(val, skip_validation=True)
        self.columns = TimeLayout(np.array([_fraction(nlp.variables[c], n) for c in cols]), n)
        rows = nlp.constraint_rows()  # the reduced NLP's rows among nlp.constraints
        self.rows = TimeLayout(np.array([_fraction(nlp.constraints[r], n) for r in rows]), n)
        position = {id(v): j for j, v in enumerate(nlp.variables[c] for c in cols)}
        self.node_cols = {
            name: np.array([position[id(self.model.component(name)[t])] for t in self.model.nodes])
            for name in (*self.states, *self.controls)
        }
        self.tf_col = position.get(id(self.model.tf)) if self.free_time else None
        m = self.model
        self.above_cols = np.array([position[id(m.above[k])] for k in self.states])
        self.below_cols = np.array([position[id(m.below[k])] for k in self.states])
        self.keep_out_cols = np.array([[position[id(m.keep_out_slack[i, t])] for t in m.nodes] for i in m.obstacle_set],
                                      dtype=int).reshape(-1, len(m.nodes))  # fmt: skip

    # -- a step -----------------------------------------------------------------------------
    def set_problem(self, start: dict[str, float], length: float, free: bool, target: dict[str, float],
                    weights: dict[str, float], disturbance: np.ndarray | None = None) -> None:  # fmt: skip
        """Initial state, horizon length (a fixed value, or a guess if ``free``), terminal target and
        the disturbance on the state rates (state order; None: zero)."""
        m = self.model
        d = np.zeros(len(self.states)) if disturbance is None else disturbance
        for name, val in zip(self.states, d, strict=True):
            m.d_hat[name].set_value(float(val))
        for name, val in start.items():
            lo, hi = self.ocp.bounds.get(name, (-math.inf, math.inf))
            m.component(f"initial_{name}_value").set_value(min(max(val, lo), hi))
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
        self.nlp.refresh_parameters()

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


def _fraction(data, n: int) -> float:
    """A variable's or row's place in the horizon in [0, 1]; NaN for one not tied to a node."""
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


def _energy(m: pyo.ConcreteModel, ocp: OCP):
    """1/2 integral of the squared controls by the trapezoid rule (the energy objective's own sum)."""
    if not ocp.cost.free_final_time:
        return m.objective.expr
    nodes, n = m.nodes, len(m.nodes) - 1

    def rate(t):
        return sum(m.component(c)[t] ** 2 for c in ocp.vehicle.controls) / 2

    inner = pyo.quicksum(rate(t) for t in nodes[1:-1])
    return m.tf / n * (inner + (rate(nodes[0]) + rate(nodes[-1])) / 2)


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


class MPC:
    """Nonlinear MPC of a scenario around its open-loop optimum (implements ``Controller``).

    Parameters
    ----------
    solution : Solution
        The open-loop optimum (``ocp.solve``): the problem, its reference trajectory and final time.
    control : ControlSettings
        Sample time and horizon (samples, or "shrinking": the scenario's N up to the final time).
    disturbance : Disturbance
        Only the delay is used (it is known); the rest is what feedback (and, with
        ``offset_free``, the disturbance estimate) must reject.
    settings : MPCSettings, optional

    Attributes
    ----------
    name : str
    failed : bool
        The last step had no usable plan and the previous plan was followed.
    truncated : bool
        The last step's solve stopped early (time or iteration limit) with a usable iterate.
    d_hat : ndarray
        The current disturbance estimate on the state rates (state order; zero where not estimated).
    final_time : float
        When the current plan arrives (the reference's final time, or later for the time objective).
    steps : list of dict
        Per step: t, seconds, iterations, status, horizon length, used, truncated, the relative
        constraint violation of the iterate and the disturbance estimate used.

    Examples
    --------
    >>> mpc = MPC(ocp.solve(), ControlSettings(0.1, 40))          # doctest: +SKIP
    >>> u = mpc.make_step(0.0, y0, np.zeros((0, 2)))               # doctest: +SKIP
    """

    def __init__(self, solution: Solution, control: ControlSettings | None = None,
                 disturbance: Disturbance | None = None, settings: MPCSettings | None = None):  # fmt: skip
        control, disturbance = control or ControlSettings(), disturbance or Disturbance()
        self.ocp = copy.copy(solution.ocp)
        self.dt = float(control.sample_time)
        self.delay = control.delay_samples(disturbance)
        self.settings = settings or MPCSettings()
        self.reference = {k: np.asarray(v, dtype=float) for k, v in solution.columns.items()}
        self.final_time = float(solution.final_time)
        self.shrinking = control.horizon == "shrinking"
        intervals = int(solution.intervals) if self.shrinking else int(control.horizon)
        self.horizon_time = math.inf if self.shrinking else intervals * self.dt
        if self.ocp.cost.free_final_time and not self.settings.time_receding:
            self.horizon_time = math.inf
        self.horizon = HorizonModel(self.ocp, intervals, self._scales(), self._cost_scales(), self.settings,
                                    self._path_length())  # fmt: skip
        self.rhs = self.ocp.vehicle.rhs_function()
        self.d_hat = np.zeros(len(self.ocp.vehicle.states))
        self.d_bound = self._disturbance_bound()
        self._history: deque[tuple[float, np.ndarray, np.ndarray]] = deque(maxlen=self.settings.estimator_window)
        free = self.ocp.cost.free_final_time
        self.offset_free = not free if self.settings.offset_free is None else self.settings.offset_free
        kind = "offset-free mpc" if self.offset_free else "mpc"
        self.name = f"{kind} (warm-started Ipopt, {intervals} intervals, {control.horizon} horizon)"
        self.failed = self.truncated = False
        self.steps: list[dict] = []
        self.plan = self.warm = self._reference_plan()
        self._final_phase = False
        self.plan = self._solve(0.0, self.ocp.initial, record=False) or self.plan  # multipliers for step 1

    # -- the Controller protocol ---------------------------------------------------------
    def make_step(self, t: float, y: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """The control to send at ``t`` (acting over one sample after the pending ones).

        Parameters
        ----------
        t : float
            Sample instant (s).
        y : ndarray
            Measured state in the model's order.
        pending : ndarray, shape (k, n_controls)
            Controls sent and not yet applied, oldest first.

        Returns
        -------
        ndarray, shape (n_controls,)
            The plan's mean control over the sample it acts on.
        """
        pending = np.asarray(pending, dtype=float).reshape(-1, len(self.ocp.vehicle.controls))
        y = np.asarray(y, dtype=float)
        self._estimate(float(t), y)
        u = self._control(float(t), y, pending)
        applied = pending[0] if len(pending) else u
        if np.all(np.isfinite(y)):  # (t, y, the control applied over the sample from t)
            self._history.append((float(t), y.copy(), applied.copy()))
        return u

    def _control(self, t: float, y: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """Solve from the state predicted through ``pending`` (or follow the plan near its end)."""
        start_time = t + len(pending) * self.dt
        state = self.predict(y, pending)
        self.truncated = False
        if self.final_time - start_time < self.settings.stop_samples * self.dt:
            self.failed = False
            return self._follow(start_time)
        try:
            plan = self._solve(start_time, dict(zip(self.ocp.vehicle.states, state, strict=True)))
        except Exception as exc:  # noqa: BLE001 (a step never crashes the loop: it follows the last plan)
            self.steps.append({"t": start_time, "status": f"error: {type(exc).__name__}: {exc}", "used": False})
            plan = None
        self.failed = plan is None
        if plan is not None:
            self.plan = plan
        return self._follow(start_time)

    def predict(self, y: np.ndarray, pending: np.ndarray, substeps: int = 10) -> np.ndarray:
        """The prediction model's state (f + d_hat) after the pending controls (RK4, ``substeps`` per sample)."""
        x = y.copy()
        for u in pending:
            x = self._carry(x, u, self.dt, substeps)
        return x

    def _carry(self, x: np.ndarray, u: np.ndarray, duration: float, substeps: int = 10) -> np.ndarray:
        """``x`` after ``duration`` with ``u`` held (RK4 of f + d_hat)."""
        for _ in range(substeps):
            x = self._rk4(x, u, duration / substeps)
        return x

    def _rk4(self, x: np.ndarray, u: np.ndarray, h: float) -> np.ndarray:
        """One classical Runge-Kutta step of the prediction model f(x, u) + d_hat."""
        k1 = self._rate(x, u)
        k2 = self._rate(x + h / 2 * k1, u)
        k3 = self._rate(x + h / 2 * k2, u)
        k4 = self._rate(x + h * k3, u)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def _rate(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return self.rhs(x, u) + self.d_hat

    # -- the disturbance estimate ----------------------------------------------------------
    def _estimate(self, t: float, y: np.ndarray) -> None:
        """d_hat <- sat(d_hat + alpha (y - x_pred) / h): the prediction error over the last
        ``estimator_window`` samples (x_pred: the measurement then, carried by f + d_hat)."""
        if not self.offset_free or not self._history or not np.all(np.isfinite(y)):
            return
        x, h = self._history[0][1], t - self._history[0][0]
        if h <= 1e-12:
            return
        ends = [s[0] for s in list(self._history)[1:]] + [t]
        for (t0, _, applied), t1 in zip(self._history, ends, strict=True):
            x = self._carry(x, applied, t1 - t0)
        step = self.settings.estimator_gain * (y - x) / h
        self.d_hat = np.clip(self.d_hat + np.where(self.d_bound > 0, step, 0.0), -self.d_bound, self.d_bound)

    def _disturbance_bound(self) -> np.ndarray:
        """Per state: ``disturbance_share`` x its largest rate on the reference for the position and
        heading states, 0 (not estimated) for the others."""
        v, ref = self.ocp.vehicle, self.reference
        estimated = [s in v.position or s.startswith("theta") for s in v.states]
        rates = [np.max(np.abs(np.gradient(ref[s], ref["t"]))) if ref["t"].size > 1 else 0.0 for s in v.states]
        return np.where(estimated, self.settings.disturbance_share * np.asarray(rates, dtype=float), 0.0)

    # -- internals -----------------------------------------------------------------------
    def _follow(self, start: float) -> np.ndarray:
        """The current plan's mean controls over [start, start + dt]; zero (clipped) after its end."""
        controls = self.ocp.vehicle.controls
        if start >= self.plan.times[-1] - 1e-12:
            return np.array([float(np.clip(0.0, *self.ocp.bounds[c])) for c in controls])
        return np.array([self.plan.mean(c, start, start + self.dt) for c in controls])

    def _solve(self, start: float, state: dict[str, float], record: bool = True) -> Plan | None:
        """Set up and solve the horizon from ``state`` at ``start``; the new plan, or None if it failed."""
        t0 = time.perf_counter()
        if not all(math.isfinite(v) for v in state.values()):
            raise ValueError("the measured state is not finite")
        length, free = self._horizon(start)
        target, weights = self._target(start + length, final=free or self._final_phase)
        hm = self.horizon
        hm.set_problem(state, length, free, target, weights, self.d_hat)
        times = start + np.linspace(0.0, length, hm.n + 1)
        prev = self.warm
        x0 = hm.columns.move(prev.x, prev.times, times)
        known, values = self._extended(prev, times[-1])
        for name, cols in hm.node_cols.items():  # node values: interpolated in time, the start measured
            x0[cols] = np.interp(times, known, values[name])
        for name, val in state.items():
            x0[hm.node_cols[name][0]] = val
        if hm.tf_col is not None:
            x0[hm.tf_col] = length
        hm.fill_slacks(x0)
        duals = None
        if len(prev.mult_g):
            bounds = [hm.columns.move(z, prev.times, times) for z in (prev.mult_x_L, prev.mult_x_U)]
            duals = (hm.rows.move(prev.mult_g, prev.times, times), *bounds)
        options = {**self.settings.ipopt, **({"max_wall_time": self.settings.budget * self.dt} if record else {})}
        res = hm.solve(x0, duals, options)
        converged = res.status in USABLE
        violation = self._violation(res.x)
        ok = converged or violation <= self.settings.feasible_inf_pr
        self.truncated = ok and not converged
        iterate = self._plan(res, start, hm.horizon_length(res.x, length))
        if np.all(np.isfinite(res.x)) and (ok or self.settings.warm_from_iterate):
            self.warm = iterate  # the next step continues from here, converged or not
        plan = iterate if ok else None
        if plan is not None and free:
            self.final_time = float(plan.times[-1])
        if record:
            self.steps.append({"t": start, "seconds": time.perf_counter() - t0, "ipopt_seconds": res.seconds,
                               "iterations": res.iterations, "status": res.status, "code": res.code,
                               "limit": res.code in LIMIT_CODES, "horizon": length, "used": plan is not None,
                               "truncated": self.truncated, "violation": violation,
                               "inf_pr": res.log[-1][2] if res.log else math.nan,
                               "d_hat": self.d_hat.tolist()})  # fmt: skip
        return plan

    def _violation(self, x: np.ndarray) -> float:
        """The iterate's largest constraint violation relative to the scene (``max(1, path length)``);
        infinite for a non-finite iterate."""
        if not np.all(np.isfinite(x)):
            return math.inf
        return self.horizon.violation(x) / max(1.0, self._path_length())

    def _extended(self, plan: Plan, until: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The plan's node times and values, continued to ``until`` by the nominal model with its last
        controls held (the shifted horizon's new tail)."""
        times, values = plan.times, plan.values
        h = (times[-1] - times[0]) / (len(times) - 1)
        extra = int(math.ceil((until - times[-1]) / h - 1e-9)) if h > 0 else 0
        if extra <= 0:
            return times, values
        v = self.ocp.vehicle
        u = np.array([values[c][-1] for c in v.controls])
        x = np.array([values[k][-1] for k in v.states])
        tail = [x := self._rk4(x, u, h) for _ in range(extra)]
        out = {k: np.append(values[k], [p[i] for p in tail]) for i, k in enumerate(v.states)}
        out |= {c: np.append(values[c], np.full(extra, values[c][-1])) for c in v.controls}
        return np.append(times, times[-1] + h * np.arange(1, extra + 1)), out

    def _horizon(self, start: float) -> tuple[float, bool]:
        """(length, free): the receding horizon while it ends before the final time, then the time left
        (free for the time objective)."""
        left = self.final_time - start
        if not self._final_phase and self.horizon_time < left - 1e-9:
            return self.horizon_time, False
        self._final_phase = True
        return left, self.ocp.cost.free_final_time

    def _target(self, end: float, final: bool) -> tuple[dict[str, float], dict[str, float]]:
        """Terminal target and weights: the reference at ``end``, or the scenario's final values."""
        ref = self.reference
        at_end = {k: float(np.interp(end, ref["t"], ref[k])) for k in self.ocp.vehicle.states}
        if not final:
            return at_end, dict.fromkeys(at_end, 1.0)
        target = {k: self.ocp.final.get(k, float(ref[k][-1])) for k in at_end}
        weights = {k: 1.0 if k in self.ocp.final else self.settings.free_terminal for k in at_end}
        return target, weights

    def _plan(self, res: IpoptResult, start: float, length: float) -> Plan:
        hm = self.horizon
        values = {name: res.x[cols].copy() for name, cols in hm.node_cols.items()}
        times = start + np.linspace(0.0, length, hm.n + 1)
        return Plan(times, res.x.copy(), res.mult_g.copy(), res.mult_x_L.copy(), res.mult_x_U.copy(), values)

    def _reference_plan(self) -> Plan:
        """The open-loop optimum as a plan on the horizon's layout (no multipliers); auxiliary node
        variables (body disc centres) follow it, slacks start at zero."""
        hm, ref = self.horizon, self.reference
        length = min(self.horizon_time, self.final_time)
        times = np.linspace(0.0, length, hm.n + 1)
        values = {name: np.interp(times, ref["t"], ref[name]) for name in hm.node_cols}
        load_start(hm.model, Start(values, length if hm.free_time else None))
        x = hm.nlp.init_primals()
        for name, cols in hm.node_cols.items():
            x[cols] = values[name]
        if hm.tf_col is not None:
            x[hm.tf_col] = length
        empty = np.zeros(0)
        return Plan(times, x, empty, empty, empty, values)

    def _scales(self) -> dict[str, float]:
        """Terminal error scales: the path length for positions, 1 rad for the rest."""
        length = self._path_length()
        return {k: length if k in self.ocp.vehicle.position else 1.0 for k in self.ocp.vehicle.states}

    def _path_length(self) -> float:
        ref = self.reference
        px, py = self.ocp.vehicle.position
        return max(float(np.sum(np.hypot(np.diff(ref[px]), np.diff(ref[py])))), 1e-6)

    def _cost_scales(self) -> tuple[float, float]:
        ref = self.reference
        energy = float(np.trapezoid(sum(ref[c] ** 2 for c in self.ocp.vehicle.controls) / 2, ref["t"]))
        return self.final_time, max(energy, 1e-9)


__all__ = ["MPC", "HorizonModel", "MPCSettings", "Plan", "TimeLayout"]
