"""Prototype (issue 21 item 2): bodies in any corridor through the curvilinear frame of the route.

The search of map scenarios (``model.search.maps``, ``OCP.solve``'s default for a ``map_route``) runs it;
docs/map-corridor.md says what was tried and measured. The formulation, for every body's cover disc j at node k:

- the frame: the route's centre line resampled and smoothed (``model.scene.curvilinear.frame``);
- the corridor's lateral extents w_left(s), w_right(s) along the frame's normals, each the least
  value within ``window`` metres along the line (``conservative``);
- the disc centre's arclength s_kj is the nearest-point projection of a previous trajectory
  (first the centre-line guess), held fixed in the NLP; with c, n the frame's point and normal there,
  the row ``-w_right(s_kj) + r <= n . (p_kj - c) <= w_left(s_kj) - r`` is linear in the centre;
- solve, project the answer's disc centres again, rebuild and re-solve from the answer until the
  projections move less than ``tol`` metres (sequential convex-style updates of the strips).

``arclength=True`` (the arclength grid, docs/map-corridor.md): node k's reference point on the frame's normal at
the fixed arclength s_k (``node_arclengths``, ``add_node_rows``), the time free per interval
(``TranscriptionOptions.free_grid``), the rows next to a fixed pose widened to take it in (``fixed_ends``) and
the controls' jumps priced (``SMOOTHING``), so that a node's station no longer moves when Tf does.

Each answer is validated as every answer is (dynamics, bounds, boundary values), and its bodies
as exact rectangles in the shapely corridor at the nodes (``exact_clearance``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pyomo.environ as pyo
import shapely

from model.analysis.bodies import substeps
from model.analysis.maps import map_clearances
from model.analysis.validation import interval_clearances, one_step_columns
from model.direct.bodies import TIGHT_COVER_SLACK, _pose_point, disc_count
from model.direct.options import TranscriptionOptions
from model.direct.solution import Solution
from model.direct.solve import Start, expired, finish, load_start, paused_gc, wall_time_options
from model.direct.transcription import build_model
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import run_ipopt
from model.problem.ocp import OCP
from model.scene.curvilinear import Frame, conservative, disc_extents, frame, lateral_extents
from model.scene.geometry import clearance
from model.vehicles import integrated_speed

MARGIN = 0.5  # m added to each disc's radius for the window of ``conservative``
OPEN_END = 15.0  # m: how far the strips' corridor continues beyond the route's end edges (``open_ends``)
CRACK = 1e-3  # m: the caps overlap the corridor by this much
CURVED_WINDOW = 1.5  # the curved strips' bounds: the least over this many trust radii of arclength either side
FLAT = 1e-6  # 1/m: a frame curvature below this is a straight line (the curved row is the linear one)
DISC_RESOLUTION = 0.05  # m: the ``disc`` strips' bounds are multiples of this (``disc_extents``'s step)
CHAIN = 10.0  # m: on a looped route a node's discs project within this arclength of the previous node's
STEP_CAP = 30.0  # s: the longest interval of the arclength grid (a stop to turn the wheels fits; a crawl does not)
MIN_WALL_TIME = 0.5  # s: a strip solve begun before the deadline runs at least this long (of its clock)


@dataclass
class Strips:
    """The frame, and per body its cover (offsets, radius) and the allowed lateral offsets of its disc
    centres at the frame's samples (``lower`` <= offset <= ``upper``, m, > 0 left)."""

    frame: Frame
    covers: dict[str, tuple[np.ndarray, float]]
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]


@dataclass
class Iterate:
    """One solve of the sequence: its answer and how far the projections moved after it."""

    solution: Solution
    moved: float
    exact_clearance: float
    seconds: float
    narrow_rows: int = 0
    violation: tuple[float, float] | None = None  # relaxed: (sum, largest) of the strip slacks, m


@dataclass
class Result:
    iterates: list[Iterate] = field(default_factory=list)

    @property
    def solution(self) -> Solution:
        return self.iterates[-1].solution


def strips(
    ocp: OCP, step: float = 0.25, sigma: float = 2.0, margin: float = MARGIN, slack: float = TIGHT_COVER_SLACK,
    method: str = "disc", resolution: float = DISC_RESOLUTION,
) -> Strips:  # fmt: skip
    """The frame of ``ocp.map_route`` and each body's allowed lateral offsets in its corridor.

    ``method``: "disc" (``disc_extents``: a disc centred anywhere on the normal between the frame and
    the bound lies in the corridor, the bound a multiple of ``resolution`` m) or "ray" (``lateral_extents``
    less the radius, the least within the radius + ``margin`` m along the line). ``slack``: each body's cover
    discs reach at most this fraction of its half-width beyond its sides (``disc_count``; 3 %: with the roads'
    10 % the SU-30 did not converge on Thiergarten's 3 m lanes, docs/map-corridor.md).
    """
    route = ocp.map_route
    fr = frame(route.line.points, step=step, sigma=sigma, chain=CHAIN if route.loops else None)
    covers, lower, upper = {}, {}, {}
    for name, body in ocp.bodies.items():
        offsets, radius = body.cover(disc_count(body.length, body.width, slack))
        covers[name] = (np.asarray(offsets, float), float(radius))
        if method == "disc":
            left, right = disc_extents(open_ends(route, route.corridor(name)), fr, float(radius), resolution)
            upper[name], lower[name] = left, -right
            bad = (left < 0) | (right < 0)
            upper[name][bad], lower[name][bad] = 0.0, 1.0  # lower > upper: the disc does not fit there
        elif method == "ray":
            wl, wr = lateral_extents(route.corridor(name), fr)
            upper[name] = conservative(fr, wl, radius + margin) - radius
            lower[name] = radius - conservative(fr, wr, radius + margin)
        else:
            raise ValueError(f"method must be 'disc' or 'ray', got {method!r}")
    return Strips(fr, covers, lower, upper)


def open_ends(route, corridor, reach: float = OPEN_END):
    """The corridor continued ``reach`` metres beyond the route's two end edges (from_lanelet's start,
    to_lanelet's end), so that those edges, across the route, do not narrow the strips of the discs
    near the start and goal (a cover disc reaches beyond its rectangle's ends; the rectangles
    themselves are checked against the corridor as it is)."""
    caps = []
    for lanelet_id, first in ((route.from_lanelet, True), (route.to_lanelet, False)):
        lanelet = route.map.lanelet(lanelet_id)
        i = 0 if first else -1
        a, b = np.asarray(lanelet.left_vertices[i], float), np.asarray(lanelet.right_vertices[i], float)
        cv = np.asarray(lanelet.center_vertices, float)
        out = cv[0] - cv[1] if first else cv[-1] - cv[-2]
        out = reach * out / np.linalg.norm(out)
        caps.append(shapely.Polygon([a, b, b + out, a + out]).buffer(CRACK, join_style="mitre"))
    return shapely.union_all([corridor, *caps])


def disc_centres(ocp: OCP, columns: dict[str, np.ndarray], covers) -> dict[str, np.ndarray]:
    """Centres (nodes, discs, 2) of each body's cover discs along a trajectory."""
    v, poses, out = ocp.vehicle, ocp.vehicle.body_poses(), {}
    for name, (offsets, _) in covers.items():
        x, y, h = v.state_function(list(poses[name]))(columns)
        out[name] = np.stack([x[:, None] + offsets * np.cos(h)[:, None], y[:, None] + offsets * np.sin(h)[:, None]], -1)
    return out


def projections(ocp: OCP, columns: dict[str, np.ndarray], st: Strips, between: bool = False) -> dict[str, np.ndarray]:
    """Arclength (nodes, discs) of each disc centre's nearest point on the frame; ``between``: also, as
    ``name + BETWEEN``, of the disc centres at ``between_states``."""
    out = {name: st.frame.project(c) for name, c in disc_centres(ocp, columns, st.covers).items()}
    if between:
        mid = disc_centres(ocp, between_states(columns, ocp.vehicle.states), st.covers)
        out |= {name + BETWEEN: st.frame.project(c) for name, c in mid.items()}
    return out


def between_states(columns: dict[str, np.ndarray], names) -> dict[str, np.ndarray]:
    """The states (N + 1) at the middle of each interval: entry k the mean of nodes k - 1 and k (entry 0 node 0's)."""
    return {k: np.concatenate([columns[k][:1], (columns[k][:-1] + columns[k][1:]) / 2]) for k in names}


def fixed_nodes(ocp: OCP, intervals: int) -> dict[str, tuple[int, ...]]:
    """Per body, the nodes (0 and/or ``intervals``) at which the boundary values fix its pose.

    A body's pose is fixed at the start (goal) when every state its pose depends on has an initial
    (final) value; there its exact rectangle was checked inside the corridor when the scenario was
    read (``model.problem.maps``) and is checked again by the validation, so the strips, which are
    conservative (a disc anywhere between the frame and the offset), need not hold there: at
    Kackertstrasse the SU-30's goal on lane 19 lies 0.395 m outside its front disc's strip.
    """
    states, out = set(ocp.vehicle.states), {}
    for name, pose in ocp.vehicle.body_poses().items():
        used = {str(sym) for expr in pose for sym in getattr(expr, "free_symbols", ())} & states
        out[name] = tuple(k for k, given in ((0, ocp.initial), (intervals, ocp.final)) if used <= set(given))
    return out


BETWEEN = " between"  # the key suffix of a body's midpoint arclengths in ``s_fixed`` (``between_states``)


def add_strip_constraints(m: pyo.ConcreteModel, ocp: OCP, st: Strips, s_fixed: dict[str, np.ndarray],
                          trust: float | None = None, relax: bool = False, curved: bool = False,
                          ends: dict[str, np.ndarray] | None = None,
                          margins: dict[str, np.ndarray] | None = None) -> None:  # fmt: skip
    """For every body, disc and node: the disc centre in the strip at its fixed arclength (linear rows).

    No rows at the nodes where the boundary values fix the body's pose (``fixed_nodes``).
    Where ``s_fixed`` has the key ``name + BETWEEN`` (arclengths (N + 1, discs) of the discs at the states
    ``between_states``): the same rows for the disc centres at the mean of each interval's two node states
    (row k for the interval k - 1 .. k; row 0 unused), the midpoints the validation's linear sub-steps pass.
    ``trust`` (m): also keep each disc centre within that distance of its fixed arclength along the
    frame's tangent there, a trust region in which the strip stands for the corridor.
    ``ends`` (the arclength grid, ``fixed_ends``): per body the disc centres (2, discs, 2) of its poses at the
    start and the goal; the rows at the node next to a fixed pose (1, N - 1) are widened to take in that pose's
    own offset (measured on the neighbour's normal). On the arclength grid that node lies a fixed arclength
    step (about 1 m) from the fixed pose, which may itself lie outside its conservative strip (Thiergarten
    51 -> 108, SU-30: the start's rear disc 0.148 m outside at node 1, every solve infeasible); on the time
    grid that node can come as close to the fixed pose as it needs.
    ``margins`` (``back_offs``): per body, metres (N + 1) by which its node rows are narrowed on both sides (at
    most to the strip's middle).
    ``relax``: each strip row gets a slack (m, >= 0, on both sides), collected in ``m.strip_slacks``.
    ``curved``: the lateral offset measured from the frame's osculating circle at the fixed arclength
    (``curved_offset``) instead of along its normal line, so that a disc sliding along the tangent keeps
    its offset from the curving lane; with ``trust`` the bounds are then the least over the arclengths the
    trust region reaches (``CURVED_WINDOW`` x ``trust`` either side).
    """
    fixed = fixed_nodes(ocp, len(m.nodes) - 1)
    before = dict(zip(m.nodes, [m.nodes[0], *m.nodes[:-1]], strict=True))

    def mean(state, t):
        return (m.component(state)[before[t]] + m.component(state)[t]) / 2

    for name in st.covers:
        widen = None if ends is None else ends[name]
        margin = None if margins is None else margins.get(name)
        _body_strips(m, ocp, st, name, s_fixed[name], "", None, fixed[name], trust, relax, curved, widen, margin)
        if name + BETWEEN in s_fixed:
            _body_strips(m, ocp, st, name, s_fixed[name + BETWEEN], "_between", mean, (0,), trust, relax, curved)


def _body_strips(m: pyo.ConcreteModel, ocp: OCP, st: Strips, name: str, s: np.ndarray, suffix: str, value,
                 skip: tuple[int, ...], trust: float | None, relax: bool, curved: bool,
                 ends: np.ndarray | None = None, margin: np.ndarray | None = None) -> None:  # fmt: skip
    """One body's strip rows (``add_strip_constraints``) at the arclengths ``s`` (N + 1, discs), the disc
    centres taken at the states ``value`` (``_pose_point``), named with ``suffix``, skipping the nodes ``skip``
    (``ends``: the fixed poses' disc centres, their neighbours' rows widened; ``margin``: the rows narrowed;
    see ``add_strip_constraints``)."""
    offsets, _ = st.covers[name]
    c, tangent, n = st.frame.at(s)
    upper, lower = st.upper[name], st.lower[name]
    if curved and trust is not None:
        upper = conservative(st.frame, upper, CURVED_WINDOW * trust)
        lower = -conservative(st.frame, -lower, CURVED_WINDOW * trust)
    kappa = st.frame.curvature(s) if curved else None
    hi = np.interp(s, st.frame.s, upper)
    lo = np.interp(s, st.frame.s, lower)
    if ends is not None:
        last = len(s) - 1
        for k in skip:  # the fixed poses' neighbours
            near, row = (1, ends[0]) if k == 0 else (last - 1, ends[1])
            off = np.einsum("jd,jd->j", n[near], row - c[near])
            hi[near], lo[near] = np.maximum(hi[near], off), np.minimum(lo[near], off)
    if margin is not None:
        cut = np.clip(np.minimum(margin[:, None], (hi - lo) / 2), 0.0, None)
        hi, lo = hi - cut, lo + cut
    narrow = lo > hi  # the strip is narrower than the disc there: its centre line, and the validation judges
    lo[narrow] = hi[narrow] = (lo[narrow] + hi[narrow]) / 2
    m.narrow_rows = getattr(m, "narrow_rows", 0) + int(narrow.sum())
    pose = ocp.vehicle.body_poses()[name]
    for j, offset in enumerate(offsets):
        centre = _pose_point(m, ocp, pose, float(offset), 0.0, value)
        slack = None
        if relax:  # two slacks: the disc centre may leave the strip to the left or to the right
            slack = tuple(pyo.Var(m.nodes, bounds=(0.0, None), initialize=0.0) for _ in range(2))
            m.add_component(f"slack_left_{name}_{j}{suffix}", slack[0])
            m.add_component(f"slack_right_{name}_{j}{suffix}", slack[1])
            m.strip_slacks = [*getattr(m, "strip_slacks", []), *slack]
        bend = None if kappa is None else (tangent[:, j], kappa[:, j])
        rule = _strip_rule(m, centre, c[:, j], n[:, j], lo[:, j], hi[:, j], slack, skip, bend)
        m.add_component(f"strip_{name}_{j}{suffix}", pyo.Constraint(m.nodes, rule=rule))
        if trust is not None:
            bound = np.full(len(s), float(trust))
            rule = _strip_rule(m, centre, c[:, j], tangent[:, j], -bound, bound, skip=() if value is None else skip)
            m.add_component(f"trust_{name}_{j}{suffix}", pyo.Constraint(m.nodes, rule=rule))


def _strip_rule(m: pyo.ConcreteModel, centre, c: np.ndarray, n: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                slack=None, skip: tuple[int, ...] = (), bend: tuple[np.ndarray, np.ndarray] | None = None):  # fmt: skip
    """The rule ``lo_k <= n_k . (centre(t_k) - c_k) <= hi_k`` over the nodes t_k but those in ``skip`` (with
    the pair of slacks ``slack``: ``- left[t] + right[t]`` added to the middle term). ``bend``: the
    tangents and curvatures at c_k; the middle term is then ``curved_offset`` instead."""
    index = {t: k for k, t in enumerate(m.nodes)}

    def rule(_m, t):
        k = index[t]
        if k in skip:
            return pyo.Constraint.Skip
        x, y = centre(t)
        lateral = n[k, 0] * (x - c[k, 0]) + n[k, 1] * (y - c[k, 1])
        if bend is not None and abs(bend[1][k]) > FLAT:
            along = bend[0][k, 0] * (x - c[k, 0]) + bend[0][k, 1] * (y - c[k, 1])
            lateral = curved_offset(along, lateral, float(bend[1][k]), pyo.sqrt)
        if slack is not None:
            lateral = lateral - slack[0][t] + slack[1][t]
        return (float(lo[k]), lateral, float(hi[k]))

    return rule


def curved_offset(along, across, kappa: float, sqrt=np.sqrt):
    """Signed offset (m, > 0 left) of a point from the circle of curvature ``kappa`` (1/m, > 0 left) that
    touches the frame at c with tangent t, normal n: ``along`` = t . (p - c), ``across`` = n . (p - c).

    ``R - |p - o|`` with o = c + n / kappa, R = 1 / kappa, written without R so that it tends to ``across``
    as kappa -> 0: ``(2 across - kappa (along^2 + across^2)) / (1 + sqrt((1 - kappa across)^2 + (kappa along)^2))``.
    ``sqrt``: numpy's or Pyomo's (the expression is then a Pyomo expression).
    """
    num = 2 * across - kappa * (along**2 + across**2)
    return num / (1 + sqrt((1 - kappa * across) ** 2 + (kappa * along) ** 2))


def node_arclengths(ocp: OCP, intervals: int, st: Strips) -> np.ndarray:
    """s_0 .. s_N (m): equal steps of the frame's arclength from the projection of the route's start to
    that of its goal (the nodes of the centre-line start, and of the arclength grid)."""
    route = ocp.map_route
    s0, s1 = float(st.frame.project(np.array(route.start()[:2]))), float(st.frame.project(np.array(route.goal()[:2])))
    return np.linspace(s0, s1, intervals + 1)


def add_node_rows(m: pyo.ConcreteModel, ocp: OCP, st: Strips, s_nodes: np.ndarray) -> None:
    """The arclength grid: ``t(s_k) . (p_k - c(s_k)) = 0`` at the inner nodes k = 1 .. N - 1 (``m.node_arclength``).

    p_k is the vehicle's reference point (``Vehicle.position``: the rear axle of the rigid truck and of the
    tractor), c and t the frame's point and tangent at the fixed arclength s_k: node k lies on the frame's
    normal at s_k (linear rows). The end nodes' positions are the boundary values (s_0, s_N their projections).
    Each step of the model's free grid is at most ``STEP_CAP`` s: on N = 200 from an interpolated answer,
    unbounded steps let Ipopt converge to a crawl (two steps of 350-410 s at speeds of mm/s, Tf 880 s).
    """
    c, tangent, _ = st.frame.at(np.asarray(s_nodes, float))
    X, Y = (m.component(name) for name in ocp.vehicle.position)
    index = {t: k for k, t in enumerate(m.nodes)}
    last = len(m.nodes) - 1

    def rule(_m, t):
        k = index[t]
        if k in (0, last):
            return pyo.Constraint.Skip
        return tangent[k, 0] * (X[t] - c[k, 0]) + tangent[k, 1] * (Y[t] - c[k, 1]) == 0.0

    m.node_arclength = pyo.Constraint(m.nodes, rule=rule)
    for k in m.step:
        m.step[k].setub(STEP_CAP)


def fixed_ends(ocp: OCP, start: Start, st: Strips) -> dict[str, np.ndarray]:
    """Per body the disc centres (2, discs, 2) at the start and the goal: the boundary values where given,
    else the start's end nodes (those poses are not fixed: ``fixed_nodes`` leaves them out)."""
    cols = {}
    for k in ocp.vehicle.states:
        ends = np.asarray(start.values[k], float)[[0, -1]].copy()
        ends[0] = ocp.initial.get(k, ends[0])
        ends[1] = ocp.final.get(k, ends[1])
        cols[k] = ends
    return disc_centres(ocp, cols, st.covers)


SMOOTHING = 0.1  # s: the arclength grid's weight on the controls' jumps (``control_jumps``)


def control_jumps(m: pyo.ConcreteModel, ocp: OCP):
    """sum_k sum_c ((u_c,k - u_c,k-1) / range_c)^2 / step_k over a free grid's intervals (a Pyomo expression).

    Weighted by ``SMOOTHING`` it is added to what the arclength grid's solves minimise (``strip_objective``), not
    to the problem's objective. Without it the arclength grid's answers chatter: the speed jumps between 0 and its
    bound from node to node (Thiergarten 106 -> 108, SU-30, N = 100) where the wheels turn, the trapezoid rule's
    error exploited (the answer re-integrated per interval drifts 0.068 m from the next node, the independent
    check's limit 0.05 m). ``range_c`` is the control's bound range (1 where unbounded)."""
    nodes, terms = m.nodes, []
    for c in ocp.vehicle.controls:
        lo, hi = ocp.bounds.get(c, (None, None))
        scale = (hi - lo) if lo is not None and hi is not None and hi > lo else 1.0
        u = m.component(c)
        pairs = enumerate(zip(nodes[:-1], nodes[1:], strict=True), start=1)
        terms += [((u[b] - u[a]) / scale) ** 2 / m.step[k] for k, (a, b) in pairs]
    return pyo.quicksum(terms)


def centre_line_start(ocp: OCP, intervals: int, st: Strips, speed_fraction: float = 0.5) -> Start:
    """The reference point driven along the frame from the start to the goal at constant speed."""
    v = ocp.vehicle
    r = v.roles
    s = node_arclengths(ocp, intervals, st)
    s0, s1 = float(s[0]), float(s[-1])
    speed = speed_fraction * ocp.bounds[r.speed][1]
    tf = ocp.final_time or (s1 - s0) / speed
    p, t, _ = st.frame.at(s)
    theta = np.unwrap(np.arctan2(t[:, 1], t[:, 0]))
    theta += ocp.initial[r.heading] - theta[0]
    kappa = np.gradient(theta, s)
    times = np.linspace(0.0, tf, intervals + 1)
    values = {r.x: p[:, 0], r.y: p[:, 1], r.heading: theta}
    values |= integrated_speed(v, np.full(intervals + 1, (s1 - s0) / tf), times, {}, {})  # v; a, j = 0
    if r.steering is not None:
        d = v.parameter_values().get("wheelbase", 1.0)
        phi = np.clip(np.arctan(d * kappa), *ocp.bounds.get(r.steering, (-1.0, 1.0)))
        values[r.steering] = phi
        values[r.steering_rate] = np.gradient(phi, times)
    for trailer in r.trailers:
        values[trailer] = theta.copy()
    values = {k: a for k, a in values.items() if k in v.states + v.controls}
    return Start(values=values, final_time=tf, times=times)


def exact_clearance(ocp: OCP, columns: dict[str, np.ndarray], dense: bool = False) -> float:
    """The least signed clearance (m) of the exact body rectangles in their corridors over the nodes
    (``dense``: at the sub-steps between them, the states interpolated linearly as the validation does)."""
    v, poses, worst = ocp.vehicle, ocp.vehicle.body_poses(), np.inf
    states = substeps(columns, v.states) if dense else columns
    for name, body in ocp.bodies.items():
        x, y, h = v.state_function(list(poses[name]))(states)
        region = ocp.map_route.corridor(name)
        worst = min(worst, min(clearance(region, c) for c in body.corners(x, y, h)))
    return float(worst)


def strip_objective(m: pyo.ConcreteModel, ocp: OCP, smoothing: float = 0.0, relax: bool = False,
                    penalty: float | None = None):
    """What a strip solve minimises (None: the problem's own, ``m.objective``).

    ``smoothing`` > 0 (the arclength grid): the problem's objective plus ``smoothing`` times ``control_jumps``.
    ``relax``: instead the strips' summed slack (plus 1e-4 m per second of a free Tf); with ``penalty`` (per m of
    slack) the objective so far plus ``penalty`` times the summed slack (an exact L1 penalty: where the strips can
    be met and ``penalty`` exceeds their multipliers the answer is the plain one).
    """
    goal = m.objective.expr + smoothing * control_jumps(m, ocp) if smoothing > 0.0 else None
    if not relax:
        return goal
    total = pyo.quicksum(v[t] for v in m.strip_slacks for t in m.nodes)
    if penalty is not None:
        return (m.objective.expr if goal is None else goal) + penalty * total
    time_price = 1e-4 * m.tf if ocp.cost.free_final_time else 0.0
    return total + time_price


def minimise_instead(m: pyo.ConcreteModel, goal) -> None:
    """The strip solve's one objective swap: ``goal`` minimised (``m.search_objective``) in place of the problem's
    own ``m.objective``, which stays as it is, deactivated: the objective ``finish`` reports (for the time
    objective Tf, whatever the solve minimised). Nothing where ``goal`` is None."""
    if goal is None:
        return
    m.objective.deactivate()
    m.search_objective = pyo.Objective(expr=goal, sense=pyo.minimize)


def _violation(m: pyo.ConcreteModel) -> tuple[float, float]:
    values = [pyo.value(v[t]) for v in m.strip_slacks for t in m.nodes]
    return float(sum(values)), float(max(values))


def solve_map(ocp: OCP, intervals: int = 60, iterations: int = 8, tol: float = 0.05, options: dict | None = None,
              st: Strips | None = None, trust: float | None = None, relax: bool = False, start: Start | None = None,
              deadline: float | None = None, curved: bool = False, arclength: bool = False, between: bool = False,
              penalty: float | None = None, on_iterate: Callable[[Iterate], None] | None = None,
              margins: dict[str, np.ndarray] | None = None, clock: str = "wall") -> Result:  # fmt: skip
    """The sequence of strip solves from the centre-line start (see the module docstring); ``trust``
    and ``curved`` as in ``add_strip_constraints``. ``arclength``: the nodes fixed to the arclengths
    ``node_arclengths`` (``add_node_rows``) and the time free per interval (``TranscriptionOptions.free_grid``).
    ``between``: strip rows also at each interval's mid-state (``add_strip_constraints``, ``BETWEEN``).
    ``margins``: the node rows narrowed by these (``back_offs``), the same in every solve of the sequence.
    ``relax``: the minimal-violation sequence instead (the strip
    rows widened by slacks, their sum minimised plus 1e-4 m per second of Tf, as the roads'
    ``diagnosis``); ``Iterate.violation`` is the sum and the largest slack. ``relax`` with ``penalty``
    (per m): the problem's objective plus ``penalty`` times the summed slack (``strip_objective``). The
    reported ``objective`` is always the problem's own (for the time objective Tf, on either grid).

    ``start``: the first solve's start (default ``centre_line_start``; its projections fix the first
    strips). ``deadline``, an instant of ``clock`` (``model.direct.solve.CLOCKS``: "wall", ``time.monotonic()``, or
    "cpu", ``time.process_time()``): each Ipopt run gets the time left as ``max_wall_time`` (``max_cpu_time``), at
    least ``MIN_WALL_TIME`` (``wall_time_options``), and no solve begins after it. ``on_iterate``: called with each
    Iterate.
    """
    st = st or strips(ocp)
    start = start or centre_line_start(ocp, intervals, st)
    s_fixed = projections(ocp, start.values, st, between)
    result = Result()
    for k in range(iterations):
        if k and expired(deadline, clock):  # a solve begun before the deadline runs (at least MIN_WALL_TIME)
            break
        timed = wall_time_options(dict(options or {}), deadline, MIN_WALL_TIME, clock)
        it, s_new = _strip_solve(ocp, intervals, st, s_fixed, start, trust, relax, timed, curved, arclength, between,
                                 penalty, margins)  # fmt: skip
        result.iterates.append(it)
        if on_iterate is not None:
            on_iterate(it)
        sol = it.solution
        if sol.status not in ("optimal", "acceptable", "validation_failed"):
            break
        start, s_fixed = answer_start(ocp, sol), s_new
        if it.moved < tol:
            break
    return result


BACK_OFF = 0.005  # m: the clearance ``back_offs`` aims the bodies' integrated motion at


def back_offs(ocp: OCP, columns: dict[str, np.ndarray], aim: float = BACK_OFF) -> dict[str, np.ndarray]:
    """Per body, margins (N + 1, m) for ``add_strip_constraints``: where an interval's motion, integrated from its
    node with the controls linear (``one_step``, as the validation's ``dense_clearance`` takes it), takes the
    body's exact rectangle out of the corridor, the depth plus ``aim`` at both of the interval's nodes (the larger
    of two intervals' at a shared node); zero elsewhere. {} if no interval leaves the corridor or the integration
    fails. Thiergarten 51 -> 90, SU-30, once round the ring, N = 200: the rectangle inside at every node (+0.003 m
    at node 198), 0.021 m outside at the end of interval 197, where the speed jumps from 0 to 5.1 m/s in 0.32 s
    and the integrated motion ends 0.024 m from the node."""
    paths = one_step_columns(ocp, columns)
    if paths is None:
        return {}
    out = {}
    for name, clear in interval_clearances(ocp, paths, map_clearances).items():
        worst = clear.min(axis=1)  # along each interval, its end included
        short = np.where(worst < 0.0, aim - worst, 0.0)
        if np.any(short > 0):
            out[name] = np.maximum(np.append(short, 0.0), np.insert(short, 0, 0.0))
    return out


def largest_back_off(margins: dict[str, np.ndarray]) -> float:
    """The largest of ``back_offs``' margins (m)."""
    return max(float(np.max(a)) for a in margins.values())


def answer_start(ocp: OCP, sol: Solution) -> Start:
    """A start from an answer: its states, controls, Tf and node times."""
    cols = {k: np.asarray(sol.columns[k]) for k in ocp.vehicle.states + ocp.vehicle.controls}
    return Start(values=cols, final_time=sol.final_time, times=np.asarray(sol.columns["t"], float))


def _strip_solve(ocp: OCP, intervals: int, st: Strips, s_fixed: dict[str, np.ndarray], start: Start,
                 trust: float | None, relax: bool, options: dict, curved: bool = False,
                 arclength: bool = False, between: bool = False, penalty: float | None = None,
                 margins: dict[str, np.ndarray] | None = None) -> tuple[Iterate, dict[str, np.ndarray]]:  # fmt: skip
    """One solve with the strips at the fixed projections ``s_fixed``, from ``start``; and its answer's projections
    (``arclength``: on the arclength grid; ``between``: with the mid-state rows; see ``solve_map``)."""
    t0 = time.perf_counter()
    with paused_gc():
        m = build_model(ocp, intervals, options=TranscriptionOptions(free_grid=True) if arclength else None)
        if arclength:
            add_node_rows(m, ocp, st, node_arclengths(ocp, intervals, st))
        ends = fixed_ends(ocp, start, st) if arclength else None
        add_strip_constraints(m, ocp, st, s_fixed, trust, relax, curved, ends, margins)
        minimise_instead(m, strip_objective(m, ocp, SMOOTHING if arclength else 0.0, relax, penalty))
        load_start(m, start)
        nlp = CasadiNLP(m)
        res = run_ipopt(nlp, options, x0=nlp.init_primals())
        sol = finish(ocp, m, nlp, res, "ccw", {}, analyse=True)
    cols = {k: np.asarray(sol.columns[k]) for k in ocp.vehicle.states + ocp.vehicle.controls}
    s_new = projections(ocp, cols, st, between)
    moved = max(float(np.max(np.abs(s_new[b] - s_fixed[b]))) for b in s_new)
    violation = _violation(m) if relax else None
    return Iterate(sol, moved, exact_clearance(ocp, cols), time.perf_counter() - t0, getattr(m, "narrow_rows", 0),
                   violation), s_new  # fmt: skip
