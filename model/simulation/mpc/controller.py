"""Nonlinear MPC: the scenario's own OCP re-solved at every sample, warm-started, in real time.

The horizon problem (``horizon.HorizonModel``, built once) is the transcription's receding-horizon
model (``model.direct.options``); the prediction model and the disturbance estimate are
``estimator.DisturbanceEstimator``; this module is the controller that joins them: a step only
changes the horizon's mutable Params (start, horizon length, terminal target, disturbance), solves
the built NLP and reads the plan out of the primal vector (no validation, no certificate: they
cost more than the solve).

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

Each step starts from the previous iterate interpolated onto the new grid in time (primal; its
tail beyond the old horizon continued by the prediction model) and from its multipliers moved the
same way (duals). With ``MPCSettings(realtime=True)`` a step is one real-time iteration
(``rti.RealTimeIteration``: one condensed SQP step on the built NLP's CasADi functions, the QP by a
dense active-set solver, hot-started from the previous step's active set), used when its point
satisfies the constraints to ``feasible_inf_pr``; otherwise, and with ``realtime=False`` (the class's
default), the step is warm-started Ipopt with an iteration cap and a wall-time budget.
``realtime=None`` (a scenario's ``[control]`` without ``realtime``: ``roundabout simulate``'s default)
takes the real-time iteration wherever it applies (``MPC.mpc_step`` says which, and why not).
A step stopped early (wall time,
iteration cap, or any other non-converged stop) whose iterate satisfies the constraints to
``feasible_inf_pr`` relative to the scene (``MPC._violation``) is used and counted as
``truncated``; only a step without such an iterate is ``failed``. The control sent is the plan's
mean over the sample it acts on (the plan's controls are piecewise linear between nodes, the plant
holds one value over the sample). In the last ``stop_samples`` samples, or when a step fails
(``failed``), the controller follows the last usable plan; after the plan's end it sends zero.

Offset-free MPC (by default for a fixed final time only, ``MPCSettings.offset_free``): see
``estimator``.
"""

from __future__ import annotations

import copy
import gc
import math
import time
from dataclasses import dataclass, field

import numpy as np

from model.direct.solution import Solution
from model.direct.solve import Start, load_start
from model.nlp.ipopt import IpoptResult
from model.problem.closed_loop import ControlSettings, Disturbance
from model.simulation.mpc.estimator import DisturbanceEstimator
from model.simulation.mpc.horizon import HorizonModel, Plan
from model.simulation.mpc.rti import RealTimeIteration

USABLE = ("optimal", "acceptable")
LIMIT_CODES = (-1, -4, -5)  # Ipopt: iteration limit, CPU time, wall time (-5 reads "solver_error" in ipopt.py)
# Why a horizon that is the whole remaining manoeuvre gets no real-time iteration by default: its condensed QP is
# dense in every remaining interval. Measured (examples/closed-loop-truck.toml, N = 50, nominal plant, load 8-9 on
# 2 cores): shrinking, the real-time iteration 99 ms mean / 184 ms worst per step, warm-started Ipopt 22 / 75 ms;
# receding over 40 samples, the real-time iteration 36 / 71 ms.
NOT_RECEDING = ("the horizon is the whole remaining manoeuvre, whose condensed QP is dense in every interval "
                "(measured slower than warm-started Ipopt)")  # fmt: skip


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
    realtime : bool or None
        True: a step is one real-time iteration (``rti.RealTimeIteration``: one condensed SQP step on
        the built NLP, the QP by ``qp_solver``), used when its point satisfies the constraints to
        ``feasible_inf_pr``; warm-started Ipopt is the fallback when it does not. False (the class's
        default): every step warm-started Ipopt. None (what ``[control]`` without ``realtime`` asks
        for): the real-time iteration wherever it applies, warm-started Ipopt where it does not, with
        the reason in ``MPC.mpc_step``: a horizon that is the whole remaining manoeuvre (``horizon =
        "shrinking"``, or a time problem with ``time_receding = False``), or a horizon problem the
        real-time iteration cannot build (the error of its construction).
    qp_solver : str
        The real-time iteration's QP solver (``rti.QP_SOLVERS``): "qpoases" or "daqp" on the
        condensed dense QP, "hpipm" on the uncondensed QP in the stage layout (``stagewise``;
        then ``qp_options`` are hpipm's).
    rti_regularization : float
        The real-time iteration's proximal weight on each QP variable. Measured on the road
        benchmark (bench_mpc_road.py, 2 samples per interval): 0.1 keeps every step a real-time
        iteration on the truck, the semitrailer and the crossing car; 1e-2 needs 1 Ipopt fallback
        on the truck and 4 on the semitrailer (2 failed, goal missed).
    qp_options : dict
        Options of the QP solver (``casadi.conic``'s plug-in options).
    rti_compiled : bool
        The real-time iteration evaluates the constraints, the gradient and the Jacobian by C code
        compiled with gcc and cached on disk (``CasadiNLP.compile_first_order``: about 40 s CPU once per
        horizon structure on the semitrailer, then 1.4 instead of 2.6 ms per step); if compiling
        fails, a warning and the interpreted functions.
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
    realtime: bool | None = False
    qp_solver: str = "qpoases"
    rti_regularization: float = 0.1
    qp_options: dict = field(default_factory=dict)
    rti_compiled: bool = False


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
    mpc_step : str
        What a step is: "real-time iteration", or "warm-started Ipopt (<why>)".
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
        intervals = int(solution.intervals) if self.shrinking else int(control.intervals)
        self.horizon_time = math.inf if self.shrinking else int(control.horizon) * self.dt
        if self.ocp.cost.free_final_time and not self.settings.time_receding:
            self.horizon_time = math.inf
        self.horizon = HorizonModel(self.ocp, intervals, self._scales(), self._cost_scales(), self.settings,
                                    self._path_length())  # fmt: skip
        free = self.ocp.cost.free_final_time
        self.offset_free = not free if self.settings.offset_free is None else self.settings.offset_free
        s = self.settings
        self.estimator = DisturbanceEstimator(self.ocp.vehicle, self.reference, self.offset_free, s.estimator_gain,
                                              s.disturbance_share, s.estimator_window)  # fmt: skip
        self.failed = self.truncated = False
        self.steps: list[dict] = []
        self.plan = self.warm = self._reference_plan()
        self._final_phase = False
        self.plan = self._solve(0.0, self.ocp.initial, record=False) or self.plan  # multipliers for step 1
        self.rti, why = None, self._not_realtime()
        if why is None:
            self.rti, why = self._build_rti()
        self.mpc_step = "real-time iteration" if self.rti is not None else f"warm-started Ipopt ({why})"
        kind = "offset-free mpc" if self.offset_free else "mpc"
        samples = control.interval_samples
        grid = f"{intervals} intervals" + (f" of {samples} samples" if samples > 1 else "")
        step = "real-time iteration" if self.rti is not None else "warm-started Ipopt"
        self.name = f"{kind} ({step}, {grid}, {control.horizon} horizon)"
        # The horizon was built with the collector paused: its ~10^6 objects sit in the youngest
        # generation, and the first collections in the loop would traverse them (measured: 1-6 s
        # pauses inside steps on the semitrailer's road horizon). One full collection now moves
        # them to the oldest generation, which the loop's allocations do not trigger.
        gc.collect()

    def _not_realtime(self) -> str | None:
        """Why the steps are not real-time iterations (None: they are, if the iteration builds)."""
        asked = self.settings.realtime
        if asked is False:
            return "realtime = false"
        if asked is None and math.isinf(self.horizon_time):
            whole = 'horizon = "shrinking"' if self.shrinking else "time_receding = False"
            return f"{whole}: {NOT_RECEDING}"
        return None

    def _build_rti(self) -> tuple[RealTimeIteration | None, str | None]:
        """The real-time iteration on the built horizon, its QP solver's first (cold) active set found
        before the loop; (None, why) where it cannot be built (any error of its construction: the
        condensing's ValueError, a missing QP solver, a horizon model it does not know) and was not
        asked for explicitly."""
        s = self.settings
        try:
            rti = RealTimeIteration(self.horizon.model, self.horizon.nlp, self.ocp.vehicle.states, s.qp_solver,
                                    s.rti_regularization, s.qp_options, self.ocp.vehicle.controls)  # fmt: skip
        except Exception as exc:  # noqa: BLE001 (not asked for by name: warm-started Ipopt, the reason recorded)
            if s.realtime:  # asked for by name: the error, as before
                raise
            return None, f"the real-time iteration cannot be built for this horizon: {type(exc).__name__}: {exc}"
        self._rti_key = None
        if s.rti_compiled:
            self.horizon.nlp.compile_first_order()
        rti.step(self.plan.x)
        return rti, None

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
        self.estimator.update(float(t), y)
        u = self._control(float(t), y, pending)
        self.estimator.record(float(t), y, pending[0] if len(pending) else u)
        return u

    @property
    def d_hat(self) -> np.ndarray:
        """The current disturbance estimate on the state rates (``estimator.d_hat``)."""
        return self.estimator.d_hat

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
        return self.estimator.predict(y, pending, self.dt, substeps)

    # -- internals -----------------------------------------------------------------------
    def _follow(self, start: float) -> np.ndarray:
        """The current plan's mean controls over [start, start + dt]; zero (clipped) after its end."""
        controls = self.ocp.vehicle.controls
        if start >= self.plan.times[-1] - 1e-12:
            return np.array([float(np.clip(0.0, *self.ocp.bounds[c])) for c in controls])
        return np.array([self.plan.mean(c, start, start + self.dt) for c in controls])

    def _solve(self, start: float, state: dict[str, float], record: bool = True) -> Plan | None:
        """Set up and solve the horizon from ``state`` at ``start``; the new plan, or None if it failed."""
        t0, c0 = time.perf_counter(), time.process_time()
        if not all(math.isfinite(v) for v in state.values()):
            raise ValueError("the measured state is not finite")
        length, free = self._horizon(start)
        target, weights = self._target(start + length, final=free or self._final_phase)
        hm = self.horizon
        times = start + np.linspace(0.0, length, hm.n + 1)
        hm.set_problem(state, length, free, target, weights, self.d_hat, times)
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
        self._rti_attempt = None
        if record and self.rti is not None:
            plan = self._realtime(start, length, free, (target, weights), x0, duals, (t0, c0))
            if plan is not None:
                return plan
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
                               "cpu_seconds": time.process_time() - c0,
                               "iterations": res.iterations, "status": res.status, "code": res.code,
                               "limit": res.code in LIMIT_CODES, "horizon": length, "used": plan is not None,
                               "truncated": self.truncated, "violation": violation,
                               "inf_pr": res.log[-1][2] if res.log else math.nan,
                               "d_hat": self.d_hat.tolist(), "realtime": False,
                               "rti": self._rti_attempt})  # fmt: skip
        return plan

    def _realtime(self, start: float, length: float, free: bool, goal: tuple, x0: np.ndarray, duals: tuple | None,
                  clocks: tuple[float, float]) -> Plan | None:  # fmt: skip
        """One real-time iteration from ``x0``: the plan if its point is usable, else None (the caller
        falls back to Ipopt; the attempt is recorded in the step's ``rti`` entry)."""
        key = (free, tuple(goal[1].values()))
        if key != self._rti_key:  # the objective's Params changed: its Hessian with them
            self.rti.refresh_hessian()
            self._rti_key = key
        step = self.rti.step(x0)
        violation = self._violation(step.x)
        self._rti_attempt = {"status": step.status, "seconds": step.seconds, "violation": violation,
                             "qp_iterations": step.qp_iterations}  # fmt: skip
        if not step.success or violation > self.settings.feasible_inf_pr:
            return None
        hm = self.horizon
        empty = np.zeros(0)
        mult = duals if duals is not None else (empty, empty, empty)
        length = hm.horizon_length(step.x, length)
        times = start + np.linspace(0.0, length, hm.n + 1)
        values = {name: step.x[cols].copy() for name, cols in hm.node_cols.items()}
        plan = Plan(times, step.x.copy(), *(np.asarray(z).copy() for z in mult), values)
        self.warm = plan
        self.truncated = False
        if free:
            self.final_time = float(times[-1])
        self.steps.append({"t": start, "seconds": time.perf_counter() - clocks[0], "iterations": 1,
                           "cpu_seconds": time.process_time() - clocks[1], "status": step.status,
                           "code": 0, "limit": False, "horizon": length, "used": True, "truncated": False,
                           "violation": violation, "d_hat": self.d_hat.tolist(), "realtime": True,
                           "qp_iterations": step.qp_iterations, "qp_seconds": step.qp_seconds,
                           "rti_seconds": step.seconds})  # fmt: skip
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
        tail = [x := self.estimator.rk4(x, u, h) for _ in range(extra)]
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
        energy = self.ocp.cost.energy.integral(ref, self.ocp.vehicle.controls)  # the horizon's energy: its weights
        return self.final_time, max(energy, 1e-9)


__all__ = ["MPC", "MPCSettings"]
