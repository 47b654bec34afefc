"""Moving obstacles in the NLP: node-indexed disc centres, keep-out rows, the final-time fixed point.

Each moving obstacle i (``ocp.moving_obstacles[i]``, a ``model.scene.moving.MovingVehicle``) is
covered by its discs j (``MovingVehicle.cover``: they contain the rectangle). The model holds,
for an MPC to refill per horizon (``fill_moving`` does it from the obstacles' poses):

- ``m.moving_discs``: the Set of pairs (i, j);
- ``m.moving_cx[i, j, tau]``, ``m.moving_cy[i, j, tau]``: mutable Params, the centre of disc j of
  obstacle i at the node tau (indexed by ``m.tau`` like every node variable: tau_k = k / N), i.e.
  at t_k = t0 + tau_k Tf_ref;
- ``m.moving_vx[i, j, tau]``, ``m.moving_vy[i, j, tau]``: mutable Params, that centre's velocity (m/s);
- ``m.moving_R[i]``: mutable Param, disc radius + safety of obstacle i;
- ``m.moving_t0``: mutable Param, the time of node 0 (0 for the manoeuvre; an MPC horizon's start);
- ``m.moving_tf_ref``: mutable Param, the final time Tf_ref the centres were evaluated for.

Keep-out rows, at every node (the costates and the certificate read them as path-constraint
families, ``moving_rows``; the node time is the last index):

- the point-mass problem (no ``bodies``): ``m.moving_keep_out[i, j, t]``, |(x, y) - c|^2 >= R^2,
  family ``moving``;
- a vehicle with bodies: ``m.moving_<body>_keep_out[i, j, b, t]``, each of the body's cover discs b
  (``Body.cover`` with ``model.direct.bodies.disc_count``; offsets ``m.moving_<body>_ahead[b]``)
  against each obstacle disc, |c_body - c|^2 >= (r_body + R)^2, family ``<body>_moving``.

A free final time moves the node times t_k = tau_k Tf. Chosen approach: a fixed point on Tf
with a first-order term (docs/architecture.md, "Moving obstacles"). With Tf a variable the rows use
c_k + v_k tau_k (Tf - Tf_ref): exact at Tf = Tf_ref, with the exact derivative in Tf there (for
samples: the slope of the segment ahead of t_k). ``solve_moving`` refills the Params at the
solved Tf and re-solves warm until Tf moves less than ``SETTLE_TOL`` relative, Tf kept within a
trust region of ``TRUST`` around Tf_ref in each solve (outside it the first-order term is no
model); at that point the rows are the true obstacle's (to second order in the last change) and their Tf-derivative is
the true one, so the answer is a KKT point of the problem with the real, unstretched motion. With
a fixed Tf (energy) the rows are c_k alone and one solve is exact. The validation checks the
exact rectangles at the node times whatever the NLP did.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyomo.environ as pyo

from model.direct.bodies import disc_count
from model.direct.expressions import sympy_to_pyomo
from model.direct.families import transcription_of
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import WARM_OPTIONS, IpoptResult, run_ipopt
from model.problem.ocp import OCP
from model.vehicles import sym

SETTLE_TOL = 1e-6  # relative change of Tf below which the fixed point is reached
SETTLE_LIMIT = 20  # re-solves at most
TRUST = 0.2  # Tf may move by this share of Tf_ref in one solve of the fixed point


def add_moving_obstacles(m: pyo.ConcreteModel, ocp: OCP, soft: bool = False) -> None:
    """The Params and keep-out rows of the module docstring (nothing without moving obstacles).

    ``soft`` (``TranscriptionOptions.soft_penalty``): each row's margin r is lowered by a slack
    0 <= s <= r (metres), |c_body - c|^2 >= (r - s)^2, one slack Var per node for each obstacle (and
    body), ``m.moving_<body>_<i>_slack``, slack columns of the transcription (``model.direct.families``):
    the list the soft cost prices and the real-time iteration holds, as the road's body rows.

    Every rule uses only Pyomo components indexed by the rows' own indices, so that each row family
    is one CasADi template (``model.nlp.pyomo_sx``), not one expression walk per row.
    """
    if not ocp.moving_obstacles:
        return
    pairs = [(i, j) for i, ob in enumerate(ocp.moving_obstacles) for j in range(len(ob.cover()[0]))]
    m.moving_discs = pyo.Set(initialize=pairs, dimen=2)
    for name in ("cx", "cy", "vx", "vy"):
        m.add_component(f"moving_{name}", pyo.Param(m.moving_discs, m.tau, mutable=True, initialize=0.0))
    radius = {i: ob.cover()[1] + ob.safety for i, ob in enumerate(ocp.moving_obstacles)}
    m.moving_R = pyo.Param(pyo.RangeSet(0, len(radius) - 1), mutable=True, initialize=radius)
    m.moving_t0 = pyo.Param(mutable=True, initialize=0.0)
    m.moving_tf_ref = pyo.Param(mutable=True, initialize=float(pyo.value(m.tf)))
    fill_moving(m, ocp)
    centre = _centre(m)
    if ocp.bodies:
        _body_rows(m, ocp, centre, soft)
    else:
        _point_rows(m, ocp, centre, soft)


def _centre(m: pyo.ConcreteModel) -> Callable:
    """``(i, j, t) -> (x, y)``: the obstacle disc centre the rows use at node t (module docstring)."""
    free = m.tf.is_variable_type()

    def centre(i, j, t):
        if not free:
            return m.moving_cx[i, j, t], m.moving_cy[i, j, t]
        shift = t * (m.tf - m.moving_tf_ref)  # t is tau_k
        return m.moving_cx[i, j, t] + m.moving_vx[i, j, t] * shift, m.moving_cy[i, j, t] + m.moving_vy[i, j, t] * shift

    return centre


def _margin_slacks(m: pyo.ConcreteModel, ocp: OCP, tag: str, r_body: float, soft: bool) -> Callable:
    """``(i, t) -> s``: the slack lowering obstacle i's margin r_body + R_i at node t (zero if not ``soft``)."""
    if not soft:
        return lambda i, t: 0.0
    slacks = []
    for i, ob in enumerate(ocp.moving_obstacles):
        top = r_body + ob.cover()[1] + ob.safety
        var = pyo.Var(m.tau, bounds=(0.0, top), initialize=0.0)
        m.add_component(f"{tag}_{i}_slack", var)
        transcription_of(m).add_slack(var)
        slacks.append(var)
    return lambda i, t: slacks[i][t]


def _point_rows(m: pyo.ConcreteModel, ocp: OCP, centre: Callable, soft: bool) -> None:
    px, py = ocp.vehicle.position
    X, Y = m.component(px), m.component(py)
    slack = _margin_slacks(m, ocp, "moving", 0.0, soft)

    def rule(_m, i, j, t):
        cx, cy = centre(i, j, t)
        return (X[t] - cx) ** 2 + (Y[t] - cy) ** 2 >= (m.moving_R[i] - slack(i, t)) ** 2

    _register(m, "moving", "moving_keep_out", pyo.Constraint(m.moving_discs, m.tau, rule=rule), soft)


def _body_rows(m: pyo.ConcreteModel, ocp: OCP, centre: Callable, soft: bool) -> None:
    """Per body: its cover discs' offsets ahead of the axle (``m.moving_<body>_ahead[b]``) and the rows."""
    v = ocp.vehicle
    poses = v.body_poses()
    params = {sym(k): val for k, val in v.parameters().items()}
    for name, body in ocp.bodies.items():
        offsets, r_body = body.cover(disc_count(body.length, body.width))
        ahead = pyo.Param(pyo.RangeSet(0, len(offsets) - 1), initialize=dict(enumerate(map(float, offsets))))
        m.add_component(f"moving_{name}_ahead", ahead)
        slack = _margin_slacks(m, ocp, f"moving_{name}", float(r_body), soft)

        def rule(_m, i, j, b, t, pose=poses[name], ahead=ahead, r_body=r_body, slack=slack):
            x, y, h = (sympy_to_pyomo(e, {sym(s): m.component(s)[t] for s in v.states} | params) for e in pose)
            cx, cy = centre(i, j, t)
            bx, by = x + ahead[b] * pyo.cos(h), y + ahead[b] * pyo.sin(h)
            return (bx - cx) ** 2 + (by - cy) ** 2 >= (r_body + m.moving_R[i] - slack(i, t)) ** 2

        rows = pyo.Constraint(m.moving_discs, ahead.index_set(), m.tau, rule=rule)
        _register(m, f"{name}_moving", f"moving_{name}_keep_out", rows, soft)


def _register(m: pyo.ConcreteModel, family: str, tag: str, component: pyo.Constraint, soft: bool) -> None:
    m.add_component(tag, component)
    transcription_of(m).declare(family, "moving", component, "slack" if soft else "hard")


def moving_rows(m: pyo.ConcreteModel) -> list[tuple[str, pyo.Constraint]]:
    """(family, constraint) of every moving-obstacle row: family ``moving`` or ``<body>_moving``."""
    return transcription_of(m).rows_of_kind("moving")


def fill_moving(
    m: pyo.ConcreteModel, ocp: OCP, final_time: float | None = None, start_time: float | None = None
) -> None:
    """Set the centre and velocity Params at the node times t0 + tau_k Tf (defaults: the model's t0 and Tf).

    Also sets ``moving_tf_ref`` (and ``moving_t0``) to the values used. No-op without moving obstacles.
    """
    if not ocp.moving_obstacles:
        return
    tf = float(pyo.value(m.tf)) if final_time is None else float(final_time)
    t0 = float(pyo.value(m.moving_t0)) if start_time is None else float(start_time)
    fill_moving_at(m, ocp, t0 + np.array(m.nodes, dtype=float) * tf)
    m.moving_tf_ref.set_value(tf)  # exactly (the span of the times may differ in the last bit)
    m.moving_t0.set_value(t0)


def fill_moving_at(m: pyo.ConcreteModel, ocp: OCP, times: np.ndarray) -> None:
    """Set the centre and velocity Params at the given absolute node times (uniform, one per node).

    ``moving_t0`` becomes ``times[0]`` and ``moving_tf_ref`` the span ``times[-1] - times[0]``: a
    receding horizon's filler (``m.node_parameters``), called with the node times of every step.
    No-op without moving obstacles.
    """
    if not ocp.moving_obstacles:
        return
    times = np.asarray(times, dtype=float)
    if len(times) != len(m.nodes):
        raise ValueError(f"{len(times)} node times for {len(m.nodes)} nodes")
    m.moving_t0.set_value(float(times[0]))
    m.moving_tf_ref.set_value(float(times[-1] - times[0]))
    node = {t: k for k, t in enumerate(m.nodes)}
    arrays = [(ob.discs(times)[0], ob.disc_velocities(times)) for ob in ocp.moving_obstacles]
    for name, which, axis in (("cx", 0, 0), ("cy", 0, 1), ("vx", 1, 0), ("vy", 1, 1)):
        param = getattr(m, f"moving_{name}")
        # the Param's own keys only (no new index); unchecked: a float per key, 15x faster than one
        # validated assignment each (the MPC refills them every step: 22 of 93 ms per step, profiled)
        values = {(i, j, t): float(arrays[i][which][node[t], j, axis]) for i, j, t in param.keys()}
        param.store_values(values, check=False)


def solve_moving(
    m: pyo.ConcreteModel,
    ocp: OCP,
    nlp: CasadiNLP,
    options: dict | None = None,
    x0: np.ndarray | None = None,
    duals: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[IpoptResult, dict | None]:
    """Run Ipopt on the built model from ``x0`` (default: its values), warm with ``duals`` if given;
    with moving obstacles and a free Tf, to the fixed point.

    The fixed point: Tf is kept in the trust region ``Tf_ref / (1 + TRUST) <= Tf <= Tf_ref (1 + TRUST)``
    (the first-order term is a good model of the motion only near Tf_ref); after each solve the Params
    are refilled at the solved Tf (``fill_moving``) and Ipopt restarts warm, until Tf moves less than
    ``SETTLE_TOL`` relative. Tf's own bounds are restored at the end. Returns the last Ipopt result and
    ``{"settled", "resolves", "final_time_change"}`` (None when there is nothing to settle: no moving
    obstacle or a fixed Tf). A solve that does not converge ends the loop unsettled.
    """
    if ocp.moving_obstacles:
        nlp.refresh_parameters()  # the centres of this start (``fill_moving``)
    x0 = nlp.init_primals() if x0 is None else x0
    if not ocp.moving_obstacles or not m.tf.is_variable_type():
        return run_ipopt(nlp, options, x0=x0, duals=duals), None

    bounds, change = (m.tf.lb, m.tf.ub), np.inf
    try:
        for count in range(SETTLE_LIMIT + 1):
            ref = float(pyo.value(m.moving_tf_ref))
            m.tf.setlb(max(bounds[0], ref / (1 + TRUST)))
            m.tf.setub(ref * (1 + TRUST) if bounds[1] is None else min(bounds[1], ref * (1 + TRUST)))
            nlp.refresh_parameters()
            opts = {**(options or {}), **(WARM_OPTIONS if duals is not None else {})}
            res = run_ipopt(nlp, opts, x0=x0, duals=duals)
            nlp.load_primals(res.x)
            tf = float(pyo.value(m.tf))
            change = abs(tf - ref)
            if change <= SETTLE_TOL * max(1.0, tf):
                return res, {"settled": True, "resolves": count, "final_time_change": change}
            if res.status not in ("optimal", "acceptable"):
                break
            fill_moving(m, ocp, tf)
            x0, duals = res.x, (res.mult_g, res.mult_x_L, res.mult_x_U)
        return res, {"settled": False, "resolves": count, "final_time_change": change}
    finally:
        m.tf.setlb(bounds[0])
        m.tf.setub(bounds[1])
        nlp.refresh_parameters()


def note_settling(sol, settling: dict | None) -> None:
    """Record the fixed point in ``sol.timings`` and fail an optimal answer whose Tf did not settle."""
    if settling is None:
        return
    sol.timings["moving_fixed_point"] = settling
    if not settling["settled"] and sol.status == "optimal":
        sol.status = "moving_not_settled"
