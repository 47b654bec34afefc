"""The Pyomo.dae model of an OCP, generated from its SymPy definition.

Time is normalised, tau = t / Tf in [0, 1]; each state X has a DerivativeVar
dX/dtau tied to Tf * f(X, U) at every node, and ``dae.trapezoid`` adds
X_{k+1} = X_k + h/2 (f_k + f_{k+1}) (h = Tf / N). Controls live at the nodes.
The energy objective is the paper's eq. (32), the trapezoid sum of a running-cost
variable defined at each node as Tf L(U) (like dX, a defined variable the NLP
presolve eliminates again); the time objective is Tf, or the same trapezoid sum of
Tf (1 + w u2^2) with a steering weight w. A bounded lateral acceleration (a function of
state and control, ``Vehicle.lateral_acceleration``) is a path constraint at every node.
"""

from __future__ import annotations

import math

import numpy as np
import pyomo.environ as pyo
from pyomo.dae import ContinuousSet, DerivativeVar

import model.direct.trapezoid  # noqa: F401  (registers dae.trapezoid)
from model.direct.bodies import DEFAULT_FORMULATION, add_body_constraints
from model.direct.expressions import sympy_to_pyomo
from model.direct.families import open_transcription, transcription_of
from model.direct.moving import add_moving_obstacles
from model.direct.options import Horizon, TranscriptionOptions
from model.problem.costs import Energy
from model.problem.ocp import OCP
from model.vehicles import sym

RELAXED_TIME_WEIGHT = 1e-4  # m of summed slack per second of a free Tf in the minimal-violation model
MIN_STEP = 1e-3  # s: the least step of a free grid (``TranscriptionOptions.free_grid``)


def build_model(
    ocp: OCP,
    intervals: int,
    passing: str | None = None,
    relax: bool = False,
    formulation: str = DEFAULT_FORMULATION,
    options: TranscriptionOptions | None = None,
) -> pyo.ConcreteModel:
    """The discretised Pyomo model of ``ocp`` on ``intervals`` uniform trapezoid steps.

    ``relax``: the minimal-violation model of a road problem: the body constraints get slacks and
    the objective is their sum (see ``model.direct.bodies``). ``formulation``: the bodies' NLP
    formulation on a road (``model.direct.bodies.FORMULATIONS``; the model records it as
    ``m.body_formulation``).
    ``options``: soft keep-out and body rows, the rate disturbance, a receding horizon
    (``model.direct.options``). A horizon model has a node-time hook for time-varying data:
    ``m.node_time[t]``, a mutable Param per node (the node's absolute time, 0 .. Tf until its user
    sets it), and ``m.node_parameters``, a list of callables ``fill(times)`` that a component with
    node-indexed mutable Params appends; the controller calls each with the node times of every
    step before it re-reads the parameters.
    """
    opts = options or TranscriptionOptions()
    soft = opts.soft_penalty is not None
    v = ocp.vehicle
    m = pyo.ConcreteModel(name=ocp.name)
    record = open_transcription(m, v.states, v.controls)
    m.tau = ContinuousSet(bounds=(0, 1))
    for name in v.states + v.controls:
        m.add_component(name, pyo.Var(m.tau, bounds=ocp.bounds.get(name, (None, None))))
    for name in v.states:
        m.add_component(f"d{name}", DerivativeVar(m.component(name), wrt=m.tau))
    _add_final_time(m, ocp, intervals if opts.free_grid else None, opts.horizon is not None)
    _add_dynamics(m, ocp, opts.rate_disturbance)
    _add_boundary_conditions(m, ocp, final=opts.horizon is None)
    steps = getattr(m, "step", None)
    pyo.TransformationFactory("dae.trapezoid").apply_to(m, wrt=m.tau, nfe=intervals, steps=steps)
    m.nodes = list(m.tau)
    for name in v.states:  # the trapezoid rows dae.trapezoid names d<state>_trapezoid (model.direct.trapezoid)
        record.declare(f"dynamics_{name}", "dynamics", m.component(f"d{name}_trapezoid"))
    if steps is not None:
        m.tf = pyo.Expression(expr=pyo.quicksum(steps[k] for k in steps))
    _add_output_bounds(m, ocp)
    _add_path_bounds(m, ocp)
    _add_obstacle_data(m, ocp)
    if not soft:
        _add_obstacle_rows(m, ocp)
    add_body_constraints(m, ocp, relax or soft, formulation)
    add_moving_obstacles(m, ocp, soft)
    if passing in ("ccw", "cw") and ocp.obstacles:
        _add_pass_direction(m, ocp, passing)
    if opts.horizon is not None:
        _add_horizon(m, ocp, opts.horizon, opts.soft_penalty)
        return m
    _add_objective(m, ocp)
    if soft:  # the soft rows after the objective's: the column order of the MPC's model before the options
        _add_obstacle_rows(m, ocp, soft=True)
        m.objective.set_value(m.objective.expr + _soft_cost(m, opts.soft_penalty))
    elif relax and record.slack_columns:
        m.objective.deactivate()
        m.slack_total = pyo.Expression(expr=pyo.quicksum(v[t] for v in record.slack_columns for t in m.nodes))
        # a free Tf has no price in the violation: without one it drifted to 1e3-1e6 s ("at t = 2951418 s")
        time = RELAXED_TIME_WEIGHT * m.tf if ocp.cost.free_final_time else 0.0
        m.violation = pyo.Objective(expr=m.slack_total + time, sense=pyo.minimize)
    return m


def _add_final_time(m: pyo.ConcreteModel, ocp: OCP, free_grid: int | None = None, horizon: bool = False) -> None:
    """``m.tf``: a Var (free final time) or a mutable Param; ``free_grid`` (N): instead a Var ``m.step`` per
    interval (``m.tf``, their sum, is added after the discretisation)."""
    if free_grid is not None:
        if not ocp.cost.free_final_time or horizon:
            raise ValueError("a free grid needs a free final time and no receding horizon")
        guess = (ocp.final_time or float(free_grid)) / free_grid
        m.step = pyo.Var(pyo.RangeSet(1, free_grid), bounds=(MIN_STEP, None), initialize=guess)
    elif ocp.cost.free_final_time:
        m.tf = pyo.Var(bounds=(1e-3, None), initialize=ocp.final_time or 1.0)
    else:
        m.tf = pyo.Param(mutable=True, initialize=ocp.final_time)


def _add_dynamics(m: pyo.ConcreteModel, ocp: OCP, disturbance: bool = False) -> None:
    """dX/dtau = Tf f(X, U) per state; ``disturbance``: Tf (f(X, U) + d_hat[X]), ``d_hat`` mutable (0).
    On a free grid dX = f(X, U) (the steps are in the trapezoid rows, ``_time_scale``)."""
    v = ocp.vehicle
    if disturbance:
        m.d_hat = pyo.Param(list(v.states), mutable=True, initialize=0.0)
    params = {sym(k): val for k, val in v.parameters().items()}
    rhs = v.rhs(numeric=False)

    comps = [(sym(n), m.component(n)) for n in v.states + v.controls]

    def env(t):
        return {s: comp[t] for s, comp in comps} | params

    for name, f in zip(v.states, rhs, strict=True):
        derivative = m.component(f"d{name}")

        def rule(_m, t, f=f, dv=derivative, name=name):
            rate = sympy_to_pyomo(f, env(t))
            scale = _time_scale(m)
            return dv[t] == (scale * rate + scale * m.d_hat[name] if disturbance else scale * rate)

        m.add_component(f"ode_{name}", pyo.Constraint(m.tau, rule=rule))


def _time_scale(m: pyo.ConcreteModel):
    """dt/dtau in the rates: Tf, or 1 on a free grid (whose steps are seconds)."""
    return 1.0 if hasattr(m, "step") else m.tf


def _add_boundary_conditions(m: pyo.ConcreteModel, ocp: OCP, final: bool = True) -> None:
    """X(0) = initial and (if ``final``) X(1) = final, each value a mutable Param."""
    ends = (("initial", ocp.initial, 0), ("final", ocp.final, 1)) if final else (("initial", ocp.initial, 0),)
    for where, values, t in ends:
        for name, val in values.items():
            par = pyo.Param(mutable=True, initialize=float(val))
            m.add_component(f"{where}_{name}_value", par)
            m.add_component(f"{where}_{name}", pyo.Constraint(expr=m.component(name)[t] == par))
            if where == "initial":
                transcription_of(m).initial[name] = par


def _add_output_bounds(m: pyo.ConcreteModel, ocp: OCP) -> None:
    """lower <= g(x) <= upper at every node for each bounded output g (e.g. the articulation angle)."""
    v = ocp.vehicle
    comps = [(sym(n), m.component(n)) for n in v.states]
    params = {sym(k): val for k, val in v.parameters().items()}
    for name, expr in v.outputs().items():
        if name not in ocp.bounds:
            continue
        lo, hi = ocp.bounds[name]

        def rule(_m, t, expr=expr, lo=lo, hi=hi):
            return pyo.inequality(lo, sympy_to_pyomo(expr, {s: c[t] for s, c in comps} | params), hi)

        m.add_component(f"bound_{name}", pyo.Constraint(m.tau, rule=rule))
        transcription_of(m).declare(name, "bound", m.component(f"bound_{name}"))  # mu_<output> in the costates


def _add_path_bounds(m: pyo.ConcreteModel, ocp: OCP) -> None:
    """lower <= g(x, u) <= upper for each bounded function of state and control (lateral acceleration).

    At every node, and at every interval's midpoint on the quadratic the trapezoid rule implies,
    x(t_k + h/2) = x_k + h/8 (3 f_k + f_{k+1}) with the controls' mean: a product such as
    u1^2 tan(phi) of two linear pieces can exceed its node values between them (by 20 % on a
    bang-bang road solve at N = 60), which the validation measures on the dense re-integration.
    """
    v = ocp.vehicle
    params = {sym(k): val for k, val in v.parameters().items()}
    n = len(m.nodes) - 1
    tp = m.tau_points
    for name, expr in v.path_outputs().items():
        if name not in ocp.bounds:
            continue
        lo, hi = ocp.bounds[name]

        def node_env(t):
            return {sym(c): m.component(c)[t] for c in v.states + v.controls} | params

        def mid_env(k):
            a, b = tp[k - 1], tp[k]

            def eighth(s):  # (h/8) (3 f_a + f_b), the dX per tau (uniform) or per second (free grid)
                rise = 3 * m.component(f"d{s}")[a] + m.component(f"d{s}")[b]
                return rise / (8 * n) if not hasattr(m, "step") else m.step[k] * rise / 8

            states = {sym(s): m.component(s)[a] + eighth(s) for s in v.states}
            return states | {sym(c): (m.component(c)[a] + m.component(c)[b]) / 2 for c in v.controls} | params

        def rule(_m, t, expr=expr, lo=lo, hi=hi):
            return pyo.inequality(lo, sympy_to_pyomo(expr, node_env(t)), hi)

        def mid_rule(_m, k, expr=expr, lo=lo, hi=hi):
            return pyo.inequality(lo, sympy_to_pyomo(expr, mid_env(k)), hi)

        m.add_component(f"bound_{name}", pyo.Constraint(m.tau, rule=rule))
        m.add_component(f"bound_{name}_midpoint", pyo.Constraint(pyo.RangeSet(1, n), rule=mid_rule))
        for row in (m.component(f"bound_{name}"), m.component(f"bound_{name}_midpoint")):
            transcription_of(m).declare(name, "path", row)


def _add_obstacle_data(m: pyo.ConcreteModel, ocp: OCP) -> None:
    """Each obstacle's centre and keep-out radius R as mutable Params."""
    m.obstacle_set = pyo.RangeSet(0, len(ocp.obstacles) - 1) if ocp.obstacles else pyo.Set(initialize=[])
    m.obstacle_cx = pyo.Param(m.obstacle_set, mutable=True, initialize=lambda _m, i: ocp.obstacles[i].center[0])
    m.obstacle_cy = pyo.Param(m.obstacle_set, mutable=True, initialize=lambda _m, i: ocp.obstacles[i].center[1])
    m.obstacle_R = pyo.Param(m.obstacle_set, mutable=True, initialize=lambda _m, i: ocp.obstacles[i].keep_out)


def _add_obstacle_rows(m: pyo.ConcreteModel, ocp: OCP, soft: bool = False) -> None:
    """dist^2 >= R^2 at every node (smooth).

    ``soft``: dist^2 >= (R - s)^2 with a slack ``keep_out_slack`` 0 <= s <= R (metres) per obstacle
    and node.
    """
    px, py = ocp.vehicle.position
    X, Y = m.component(px), m.component(py)
    if soft:
        m.keep_out_slack = pyo.Var(m.obstacle_set, m.tau, initialize=0.0,
                                   bounds=lambda _m, i, t: (0.0, pyo.value(m.obstacle_R[i])))  # fmt: skip

    def rule(_m, i, t):
        gap = m.obstacle_R[i] - m.keep_out_slack[i, t] if soft else m.obstacle_R[i]
        return (X[t] - m.obstacle_cx[i]) ** 2 + (Y[t] - m.obstacle_cy[i]) ** 2 >= gap**2

    m.obstacle = pyo.Constraint(m.obstacle_set, m.tau, rule=rule)
    transcription_of(m).declare("obstacle", "obstacle", m.obstacle, "slack" if soft else "hard",
                                m.keep_out_slack if soft else None)  # fmt: skip


def _soft_cost(m: pyo.ConcreteModel, penalty: float):
    """``penalty`` times the summed keep-out and body-row slacks (metres) over all nodes."""
    record = transcription_of(m)
    obstacle = record.families.get("obstacle")
    slacks = [v[i, t] for v in (obstacle.slacks if obstacle else []) for i in m.obstacle_set for t in m.tau]
    slacks += [v[t] for v in record.slack_columns for t in m.nodes]
    return penalty * pyo.quicksum(slacks)


def _add_horizon(m: pyo.ConcreteModel, ocp: OCP, horizon: Horizon, soft_penalty: float | None) -> None:
    """The receding horizon's soft terminal target, objective and node-time hook (``options.Horizon``)."""
    spent = energy(m, ocp)
    if soft_penalty is not None:
        _add_obstacle_rows(m, ocp, soft=True)
    m.state_set = pyo.Set(initialize=list(ocp.vehicle.states), ordered=True)
    m.target = pyo.Param(m.state_set, mutable=True, initialize=0.0)
    m.target_weight = pyo.Param(m.state_set, mutable=True, initialize=1.0)
    m.above = pyo.Var(m.state_set, bounds=(0.0, None), initialize=0.0)
    m.below = pyo.Var(m.state_set, bounds=(0.0, None), initialize=0.0)
    end, scales = m.nodes[-1], horizon.scales

    def terminal(_m, k):
        return (m.component(k)[end] - m.target[k]) / scales[k] == m.above[k] - m.below[k]

    m.terminal = pyo.Constraint(m.state_set, rule=terminal)
    record = transcription_of(m)
    for column in (m.above, m.below):
        record.declare("terminal", "terminal", m.terminal if column is m.above else None, "slack", column)
    penalty = sum(
        m.target_weight[k] * (horizon.terminal_l1 * (m.above[k] + m.below[k])
                              + horizon.terminal_quadratic * (m.above[k] - m.below[k]) ** 2)
        for k in m.state_set
    )  # fmt: skip
    m.time_weight = pyo.Param(mutable=True, initialize=1.0 if ocp.cost.free_final_time else 0.0)
    m.energy_weight = pyo.Param(mutable=True, initialize=1.0)
    cost = m.time_weight * m.tf / horizon.time_scale + m.energy_weight * spent / horizon.energy_scale + penalty
    m.objective = pyo.Objective(expr=cost + _soft_cost(m, soft_penalty) if soft_penalty is not None else cost,
                                sense=pyo.minimize)  # fmt: skip
    tf = float(pyo.value(m.tf))
    m.node_time = pyo.Param(m.tau, mutable=True, initialize=lambda _m, t: t * tf)
    m.node_parameters = []


def _add_pass_direction(m: pyo.ConcreteModel, ocp: OCP, passing: str) -> None:
    """Signed angle swept around the first obstacle, step by step.

    The half-angle form 2 atan(cross / (|a||b| + dot)) is exact in (-pi, pi), also for
    steps wider than 90 degrees on coarse grids.

    Each step's angle is a defined variable (one templated constraint per step, which
    the NLP presolve eliminates again); their sum must be >= 0 (ccw) or <= 0 (cw), bounds that
    are mutable Params (``set_pass_direction``), so one built model serves both directions.
    """
    px, py = ocp.vehicle.position
    X, Y, tp = m.component(px), m.component(py), m.tau_points
    m.steps = pyo.RangeSet(1, len(m.nodes) - 1)
    m.sweep = pyo.Var(m.steps, initialize=0.0)

    cx, cy = m.obstacle_cx[0], m.obstacle_cy[0]

    def rule(_m, k):
        ax, ay = X[tp[k - 1]] - cx, Y[tp[k - 1]] - cy
        bx, by = X[tp[k]] - cx, Y[tp[k]] - cy
        norms = pyo.sqrt((ax**2 + ay**2) * (bx**2 + by**2))  # > 0 outside the obstacle
        return m.sweep[k] == 2 * pyo.atan((ax * by - ay * bx) / (norms + ax * bx + ay * by))

    m.sweep_step = pyo.Constraint(m.steps, rule=rule)
    total = pyo.quicksum(m.sweep[k] for k in m.steps)
    m.pass_lower = pyo.Param(mutable=True, initialize=0.0)
    m.pass_upper = pyo.Param(mutable=True, initialize=0.0)
    m.pass_direction = pyo.Constraint(expr=pyo.inequality(m.pass_lower, total, m.pass_upper))
    set_pass_direction(m, passing)


PASS_BOUNDS = {"ccw": (0.0, math.inf), "cw": (-math.inf, 0.0)}
"""The bounds of the swept angle's sum for each pass direction."""


def set_pass_direction(m: pyo.ConcreteModel, passing: str) -> None:
    """Make a model built with a pass direction (``build_model``'s ``passing`` "ccw" or "cw") pass the other way,
    or the same; an NLP of it reads the new bounds on ``refresh_parameters``."""
    m.pass_lower.set_value(PASS_BOUNDS[passing][0])
    m.pass_upper.set_value(PASS_BOUNDS[passing][1])


def _add_objective(m: pyo.ConcreteModel, ocp: OCP) -> None:
    """The trapezoid sum of Tf L(U) over the nodes / N; Tf itself where L = 1 (the plain time cost)."""
    v = ocp.vehicle
    L = ocp.cost.lagrangian(v)
    if ocp.cost.free_final_time and L == 1:
        m.objective = pyo.Objective(expr=m.tf + _rate_penalty(m, ocp), sense=pyo.minimize)
        return
    n = len(m.nodes) - 1
    total = _running_cost_sum(m, ocp, L)
    expr = total / n + _rate_penalty(m, ocp) if ocp.cost.free_final_time else total / n
    m.objective = pyo.Objective(expr=expr, sense=pyo.minimize)


def _running_cost_sum(m: pyo.ConcreteModel, ocp: OCP, L):
    """The running-cost variables ``running_cost[t] == Tf L(U[t])`` (defined: the NLP presolve
    eliminates them again) and their trapezoid sum (times N)."""
    v = ocp.vehicle
    m.running_cost = pyo.Var(m.tau, initialize=0.0)

    def rule(_m, t):
        return m.running_cost[t] == _time_scale(m) * sympy_to_pyomo(L, {sym(c): m.component(c)[t] for c in v.controls})

    m.running_cost_rate = pyo.Constraint(m.tau, rule=rule)
    return _trapezoid_sum(m, lambda t: m.running_cost[t])


def energy(m: pyo.ConcreteModel, ocp: OCP):
    """The energy E = integral of 1/2 sum_i w_i u_i^2 dt as a Pyomo expression (trapezoid rule).

    For an energy objective, the objective's own sum: the running-cost variables Tf L(U) of the
    cost's Lagrangian, with its ``weights`` (added here if the model has none yet, as in a horizon
    model); for any other cost, the trapezoid sum of Tf L_E(U) with unit weights (``Energy()``).
    """
    v, n = ocp.vehicle, len(m.nodes) - 1
    if isinstance(ocp.cost, Energy):
        if not hasattr(m, "running_cost"):
            return _running_cost_sum(m, ocp, ocp.cost.lagrangian(v)) / n
        return _trapezoid_sum(m, lambda t: m.running_cost[t]) / n
    L = Energy().lagrangian(v)

    def rate(t):
        return _time_scale(m) * sympy_to_pyomo(L, {sym(c): m.component(c)[t] for c in v.controls})

    return _trapezoid_sum(m, rate) / n


def _trapezoid_sum(m: pyo.ConcreteModel, rate):
    """sum_k rate(t_k) with half weights at both ends (the trapezoid rule on the nodes, times N); on a free
    grid N times sum_k step_k (rate(t_{k-1}) + rate(t_k)) / 2, the trapezoid rule on its steps."""
    nodes = m.nodes
    if hasattr(m, "step"):
        n = len(nodes) - 1
        pairs = enumerate(zip(nodes[:-1], nodes[1:], strict=True), start=1)
        return n * pyo.quicksum(m.step[k] * (rate(a) + rate(b)) / 2 for k, (a, b) in pairs)
    return pyo.quicksum(rate(t) for t in nodes[1:-1]) + (rate(nodes[0]) + rate(nodes[-1])) / 2


def _rate_penalty(m: pyo.ConcreteModel, ocp: OCP):
    """eps * sum_k |u_{k+1} - u_k|^2 / h over all controls (h = Tf / N, a free grid's own steps); 0 if eps = 0."""
    eps = float(getattr(ocp.cost, "rate_penalty", 0.0) or 0.0)
    if eps == 0.0:
        return 0
    nodes = m.nodes
    n = len(nodes) - 1
    if hasattr(m, "step"):  # a free grid: each jump over its own step
        pairs = enumerate(zip(nodes[:-1], nodes[1:], strict=True), start=1)
        return eps * sum(
            sum((m.component(c)[b] - m.component(c)[a]) ** 2 for c in ocp.vehicle.controls) / m.step[k]
            for k, (a, b) in pairs
        )
    jumps = sum(
        (m.component(c)[b] - m.component(c)[a]) ** 2
        for c in ocp.vehicle.controls
        for a, b in zip(nodes[:-1], nodes[1:], strict=True)
    )
    return eps * n / m.tf * jumps


def grid(m: pyo.ConcreteModel) -> list[float]:
    """Node times in seconds, t_k = k Tf / N (a free grid: the sums of its steps)."""
    if hasattr(m, "step"):
        return [0.0, *np.cumsum([float(pyo.value(m.step[k])) for k in m.step]).tolist()]
    n = len(m.nodes) - 1
    tf = float(pyo.value(m.tf))
    return [k * tf / n for k in range(n + 1)]
