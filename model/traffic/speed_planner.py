"""The ``qp`` speed planner: path-velocity decomposition, an s-t occupancy graph and a piecewise-jerk QP.

``[traffic] speed_planner = "qp"`` (docs/traffic-format.md) lets the autopilot choose its speed along
the plan's path by this planner instead of the rule-based profiles (``model.traffic.autopilot``).
Each step, from the truck's path length ``s0`` along the plan's path (the reference point's) and its
speed:

1. *s-t occupancy*: every other vehicle near enough is predicted over ``OCCUPANCY_HORIZON`` seconds (the
   QP's horizon; with a shorter one, at its last instant the truck must still be able to stop before
   what then occupies the path ahead: a linear row, ``SpeedPlanner.solve``'s ``stop``; the autopilot's
   5 s so was measured worse, benchmarks/traffic-planner.md) as the autopilot predicts it
   (``Autopilot.predicted``); on a grid of the truck's path lengths ahead
   (``GRID`` m apart) the truck's bodies at each path length are compared with each prediction at
   each instant: where the exact rectangle distance is below the autopilot's own threshold
   (``safety_distance`` + the prediction margin of that instant, + ``BUFFER``) the cell is occupied
   (``occupancy``; a vehicle whose heading there is within ``ALONG`` of the path's drives along it).
2. *sides* (``guide``): the fastest profile the limits allow is pulled back behind the first occupied
   cell it would reach (and every earlier instant with it: s never decreases; the later ones start
   again from there at most as fast as from rest), until it crosses no occupied cell: the truck passes
   what it can clear and yields to the rest. The give-way rule: before the line, a pull-back for a
   vehicle not driving along the path (circulating, crossing) that would leave the truck past the line
   leaves it at the line for as long as that vehicle occupies the path beyond the line: the entering
   truck gives way to circulating traffic unless it can clear before it, and never waits in the ring
   for it; a vehicle driving along the path ahead (a leader) is followed into the ring. Per instant
   the free interval around the guide is the QP's corridor (``corridor``).
3. *follower*: a vehicle driving along the truck's path that is behind the truck now and occupies the
   cell just below the corridor (``followers``) must be able to stop behind the truck braking at
   ``FOLLOWER_DECEL`` while the truck brakes at its own ``leader_decel``:
   s(t) - lower(t) + v(t)^2 / (2 b_l) >= v_f^2 / (2 b_f), v(t)^2 replaced by its tangent at the previous
   solution's speed (a conservative linear constraint).
4. *QP* (piecewise jerk, casadi's qpOASES): variables s, v, a at the instants ``qp_grid`` (the step,
   then every ``QP_SAMPLE``; the corridor's instants carried onto them soundly, ``coarse``); v and s
   integrate a linear-in-time acceleration; bounds 0 <= v <= vmax(s) (the plan's speed at that path
   length, the speed bound and sqrt(a_lat_max / |kappa|), evaluated at the previous solution's path
   lengths and re-solved once at the new ones if they differ by more than ``VMAX_TOL``), the
   acceleration and jerk bounds (the scenario's ``[vehicle.longitudinal]``, else the rule-based
   driver's: +-``RATE_SLOPE`` times the plan's top speed, no jerk bound); the corridor and follower
   constraints soft (slacks at ``SLACK_WEIGHT`` per metre); objective: the distance travelled
   (``PROGRESS_WEIGHT``, linear: a quadratic tracking of vmax alone spreads a stop over the horizon,
   creeping early, where the latest braking loses less time), the speed's distance to vmax,
   acceleration and jerk.

The autopilot then checks the QP's profile with its own checks (least predicted distance, SUMO's
junction rule if on, follower braking) and falls back to its rule-based profiles when it fails
(counted in the summary's ``decisions``: ``qp`` against the others).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from model.analysis.bodies import rectangle_gaps
from model.nlp.ipopt import quiet_stdout
from model.problem.ocp import LATERAL

if TYPE_CHECKING:
    from model.traffic.autopilot import Autopilot

PLAN_HORIZON = 8.0  # s: the QP's horizon
PLAN_SAMPLE = 0.25  # s between the occupancy's instants after the autopilot's checked ones
OCCUPANCY_HORIZON = 8.0  # s: the occupancy looks as far ahead as the QP (5 s, the autopilot's, measured worse)
QP_SAMPLE = 0.5  # s between the QP's instants after the first step
GRID = 0.5  # m between the truck's path lengths of the occupancy graph
BUFFER = 0.0  # m: the occupancy's distance threshold beyond the autopilot's
ALONG = math.radians(30.0)  # a vehicle heading within this of the truck's path drives along it
V_FLOOR = 0.5  # m/s: vmax is at least this (a plan ending at rest still reaches its end)
VMAX_TOL = 0.2  # m/s: the QP is solved again when vmax at its path lengths differs from the guess's by more
SLACK_WEIGHT = 1.0e3  # objective per metre of an occupancy or follower constraint's violation
SPEED_WEIGHT = 0.1  # per (m/s)^2 below vmax, per second
PROGRESS_WEIGHT = 10.0  # per metre travelled (linear: the latest braking wins, as the rules brake late)
ACCEL_WEIGHT = 0.5  # per (m/s^2)^2, per second
JERK_WEIGHT = 0.1  # per (m/s^3)^2, per second


@dataclass(frozen=True)
class Limits:
    """The longitudinal limits the QP keeps: acceleration (m/s^2), jerk (m/s^3, inf: none), lateral (m/s^2)."""

    a_min: float
    a_max: float
    j_min: float = -math.inf
    j_max: float = math.inf
    lateral: float = math.inf


@dataclass(frozen=True)
class Occupancy:
    """The s-t graph: which of the truck's path lengths ``arcs`` (S,) each vehicle occupies at each instant."""

    arcs: np.ndarray  # (S,) m, every GRID
    blocked: np.ndarray  # (n, T, S) booleans
    keys: tuple[str, ...]
    along: np.ndarray  # (n,) drives along the truck's path (a leader or a follower)
    speed: np.ndarray  # (n,) m/s now

    @property
    def any(self) -> np.ndarray:
        """(T, S): occupied by some vehicle."""
        return self.blocked.any(axis=0) if len(self.blocked) else np.zeros((0, len(self.arcs)), bool)


@dataclass
class SpeedProfile:
    """The QP's answer at its instants ``t``: path length ``s`` from now (m), speed ``v``, acceleration ``a``."""

    t: np.ndarray
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray
    success: bool
    violation: float  # m: the largest slack (0: every occupancy and follower constraint held)


def limits_of(pilot: Autopilot) -> Limits:
    """The scenario's longitudinal limits, or the rule-based driver's where it has none (``Limits``)."""
    ocp = pilot.scenario.ocp
    r = ocp.vehicle.roles
    top = max(pilot.top_speed, 1e-6)
    a_min, a_max = -pilot.rate_slope * top, pilot.rate_slope * top
    if r.acceleration is not None and r.acceleration in ocp.bounds:
        a_min, a_max = (float(b) for b in ocp.bounds[r.acceleration])
    j_min, j_max = -math.inf, math.inf
    if r.jerk is not None and r.jerk in ocp.bounds:
        j_min, j_max = (float(b) for b in ocp.bounds[r.jerk])
    lateral = ocp.bounds.get(LATERAL)
    lat = min(-lateral[0], lateral[1]) if lateral is not None else math.inf
    return Limits(a_min, a_max, j_min, j_max, lat)


def grid(step: float, samples: np.ndarray) -> np.ndarray:
    """The occupancy's instants: ``samples`` (the autopilot's checked instants) and every ``PLAN_SAMPLE`` s to
    ``OCCUPANCY_HORIZON``."""
    more = np.arange(PLAN_SAMPLE, OCCUPANCY_HORIZON + 1e-9, PLAN_SAMPLE)
    return np.unique(np.round(np.concatenate([samples, [step], more]), 9))


def qp_grid(step: float) -> np.ndarray:
    """The QP's instants: now, the step's end, then every ``QP_SAMPLE`` s to ``PLAN_HORIZON``."""
    more = np.arange(QP_SAMPLE, PLAN_HORIZON + 1e-9, QP_SAMPLE)
    return np.unique(np.round(np.concatenate([[0.0, step], more]), 9))


def coarse(fine: np.ndarray, k: np.ndarray, qp_tau: np.ndarray, side: str) -> np.ndarray:
    """The QP instants that carry the occupancy constraints of the ``fine`` instants ``k``, soundly for a path
    length that never decreases: a pass (s >= hi) at the QP instant at or before, a yield (s <= lo) at or after."""
    t = fine[k]
    if side == "pass":
        return np.searchsorted(qp_tau, t + 1e-9, side="right") - 1
    return np.minimum(np.searchsorted(qp_tau, t - 1e-9, side="left"), len(qp_tau) - 1)


@dataclass
class PathSpeed:
    """The plan's path by the reference point's path length: plan time, the plan's speed, vmax (arrays on ``arc``)."""

    arc: np.ndarray
    time: np.ndarray
    vmax: np.ndarray

    @property
    def length(self) -> float:
        """The path's length (m)."""
        return float(self.arc[-1])

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Plan times at path lengths ``s`` (clipped to the path)."""
        return np.interp(s, self.arc, self.time)

    def arc_at(self, plan_time: float) -> float:
        """The path length at plan time ``plan_time``."""
        return float(np.interp(plan_time, self.time, self.arc))

    def vmax_at(self, s: np.ndarray) -> np.ndarray:
        """vmax at path lengths ``s`` (beyond the end: the end's)."""
        return np.interp(s, self.arc, self.vmax)


def path_speed(pilot: Autopilot, limits: Limits, samples: int = 2001) -> PathSpeed:
    """The plan's path length, plan time and speed limit: min(plan's speed, speed bound, lateral limit), >= V_FLOOR."""
    ocp, plan = pilot.scenario.ocp, pilot.plan
    v = ocp.vehicle
    t = np.linspace(0.0, plan.duration, samples)
    st = plan.at(t)
    x, y = (st[n] for n in v.position)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    keep = np.concatenate([[True], np.diff(arc) > 1e-9])  # strictly increasing path length (a stand in the plan)
    arc, t = arc[keep], t[keep]
    st = {k: val[keep] for k, val in st.items()}
    vmax = np.abs(st[v.roles.speed])
    hi = ocp.bounds.get(v.roles.speed, (-math.inf, math.inf))[1]
    vmax = np.minimum(vmax, hi)
    if math.isfinite(limits.lateral) and len(arc) > 2:
        kappa = np.abs(np.gradient(np.unwrap(st[v.roles.heading]), arc))
        vmax = np.minimum(vmax, np.sqrt(limits.lateral / np.maximum(kappa, 1e-9)))
    return PathSpeed(arc, t, np.maximum(vmax, V_FLOOR))


def occupancy(pilot: Autopilot, path: PathSpeed, s0: float, tau: np.ndarray, theirs: np.ndarray,
              keys: list[str], speeds: list[float]) -> Occupancy:  # fmt: skip
    """The predicted vehicles' occupancy of the truck's path ahead of ``s0`` (module docstring, 1).

    Parameters
    ----------
    pilot : Autopilot
        The driver (its plan, bodies and safety distance).
    path : PathSpeed
        The plan's path by path length.
    s0 : float
        The truck's path length now (m).
    tau : numpy.ndarray
        The instants (T,) of the predictions.
    theirs : numpy.ndarray
        Predicted corners (n, T, 4, 2).
    keys, speeds : list
        Each vehicle's key and speed now.

    Returns
    -------
    Occupancy
        The s-t graph; the present (tau = 0) is never occupied (measured, not chosen).
    """
    reach = s0 + float(path.vmax.max()) * float(tau[-1]) + GRID
    arcs = np.arange(s0, min(reach, path.length) + GRID, GRID)
    n = len(theirs)
    if n == 0:
        return Occupancy(arcs, np.zeros((0, len(tau), len(arcs)), bool), (), np.zeros(0, bool), np.zeros(0))
    plan_times = path.time_at(arcs)
    st = pilot.plan.at(plan_times)
    mine = [body.corners(*pilot.body_poses[name](st)) for name, body in pilot.scenario.ocp.bodies.items()]
    limit = threshold(pilot, tau) + BUFFER  # (T,)
    blocked = _gaps(mine, theirs, limit) < limit[None, :, None]  # (n, T, S)
    blocked[:, 0] = False
    heading = np.unwrap(st[pilot.scenario.ocp.vehicle.roles.heading])
    along = np.zeros(n, bool)
    for i in range(n):
        t_k, s_k = np.nonzero(blocked[i])
        if len(t_k) == 0:
            continue
        box = theirs[i, t_k]  # (R, 4, 2)
        axis = box[:, 1:3, :].mean(axis=1) - box[:, [0, 3], :].mean(axis=1)
        cos = np.cos(np.arctan2(axis[:, 1], axis[:, 0]) - heading[s_k])
        along[i] = bool(np.median(cos) >= math.cos(ALONG))
    return Occupancy(arcs, blocked, tuple(keys), along, np.asarray(speeds, float))


def threshold(pilot: Autopilot, tau: np.ndarray) -> np.ndarray:
    """The autopilot's least distance at each instant: safety_distance + the prediction margin of that instant."""
    from model.traffic.autopilot import MARGIN_HORIZON, PREDICTION_MARGIN

    return pilot.scenario.traffic.safety_distance + PREDICTION_MARGIN * np.minimum(tau, MARGIN_HORIZON)


def _gaps(mine: list[np.ndarray], theirs: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """Least rectangle distance (n, T, S) of the truck's bodies at S path lengths to the predictions; pairs whose
    bounding circles are farther apart than ``limit`` (per instant) are not computed exactly (inf)."""
    n, T = theirs.shape[:2]
    S = len(mine[0])
    out = np.full((n, T, S), math.inf)
    c_them = theirs.mean(axis=2)  # (n, T, 2)
    r_them = np.linalg.norm(theirs - c_them[:, :, None, :], axis=-1).max(axis=-1)  # (n, T)
    for body in mine:
        c_me = body.mean(axis=1)  # (S, 2)
        r_me = np.linalg.norm(body - c_me[:, None, :], axis=-1).max(axis=-1)  # (S,)
        centre = np.linalg.norm(c_them[:, :, None, :] - c_me[None, None, :, :], axis=-1)  # (n, T, S)
        near = centre - r_them[:, :, None] - r_me[None, None, :] < limit[None, :, None]
        i, t, s = np.nonzero(near)
        if len(i):
            exact = rectangle_gaps(body[s], theirs[i, t])
            out[i, t, s] = np.minimum(out[i, t, s], exact)
    return out


def fastest(tau: np.ndarray, v0: float, a0: float, limits: Limits, path: PathSpeed, s0: float) -> np.ndarray:
    """Path lengths from now (m) of the fastest profile: the largest acceleration (jerk-limited) up to vmax."""
    s, v, a = 0.0, v0, a0
    out = [0.0]
    for h in np.diff(tau):
        cap = float(path.vmax_at(s0 + s))
        a_next = min(limits.a_max, a + limits.j_max * h) if math.isfinite(limits.j_max) else limits.a_max
        free = v + 0.5 * (a + a_next) * h
        v_next = min(max(free, 0.0), max(cap, v + limits.a_min * h))
        s += 0.5 * (v + v_next) * h
        v, a = v_next, a_next if v_next >= free - 1e-9 else 0.0  # at vmax: the acceleration gone
        out.append(s)
    return np.array(out)


def guide(graph: Occupancy, tau: np.ndarray, fast: np.ndarray, restart: np.ndarray, s0: float,
          line: float | None) -> np.ndarray:  # fmt: skip
    """The homotopy of the profile (module docstring, 2): path lengths (T,) from now, the fastest (``fast``) pulled
    back behind every occupied cell it would reach, all earlier instants with it (s never decreases), and the
    later ones from there at most ``restart`` (the fastest from rest, by time since) on. ``line``: the give-way
    line's path length while the truck is before it: a pull-back for a vehicle not driving along the path
    (circulating, crossing) that would leave the truck past the line leaves it at the line (it gives way there)."""
    occupied = graph.any
    g = fast.copy()
    if len(occupied) == 0:
        return g
    arcs = graph.arcs
    for _ in range(4 * len(tau)):  # each pass pulls back at least one instant, or stops
        k, cell = _first_occupied(occupied, arcs, s0 + g)
        if k is None:
            break
        b = cell
        while b > 0 and occupied[k, b - 1]:  # the bottom of the occupied run
            b -= 1
        back = arcs[b - 1] - s0 if b > 0 else 0.0
        crossing = graph.blocked[:, k, b:cell + 1].any(axis=1) & ~graph.along
        until = k
        if line is not None and crossing.any() and s0 + back > line:  # wait at the line while they are in the way
            back = max(line - s0, 0.0)
            later = graph.blocked[crossing][:, :, arcs >= line].any(axis=(0, 2))
            until = max(k, int(np.nonzero(later)[0].max()))
        if back >= g[k] - 1e-9:  # cannot pull back further (occupied at the truck itself): leave it to the check
            occupied = occupied.copy()
            occupied[k] = False
            continue
        g[: until + 1] = np.minimum(g[: until + 1], back)
        g[until + 1:] = np.minimum(g[until + 1:], back + np.interp(tau[until + 1:] - tau[until], tau, restart))
    return g


def _first_occupied(occupied: np.ndarray, arcs: np.ndarray, s: np.ndarray) -> tuple[int | None, int]:
    """The first instant whose path length ``s`` lies in an occupied cell (either grid point around it), and the
    cell; (None, 0) if none."""
    j = np.clip(np.searchsorted(arcs, s, side="right") - 1, 0, len(arcs) - 1)  # the grid point at or below
    up = np.minimum(j + 1, len(arcs) - 1)
    inside = s <= arcs[-1] + 1e-9
    rows = np.arange(len(s))
    hit = inside & (occupied[rows, j] | occupied[rows, up])
    if not hit.any():
        return None, 0
    k = int(np.argmax(hit))
    return k, int(j[k] if occupied[k, j[k]] else up[k])


def corridor(graph: Occupancy, g: np.ndarray, s0: float) -> tuple[np.ndarray, np.ndarray]:
    """Per instant, the free interval of path length (from now) around the guide ``g``: (lower, upper), -inf/inf
    where nothing occupies the path below/above it (or where ``g`` itself is occupied: no constraint)."""
    T = len(g)
    lower, upper = np.full(T, -np.inf), np.full(T, np.inf)
    occupied = graph.any
    if len(occupied) == 0:
        return lower, upper
    arcs = graph.arcs
    for k in range(1, T):
        s = s0 + g[k]
        j = int(np.clip(np.searchsorted(arcs, s, side="right") - 1, 0, len(arcs) - 1))
        if occupied[k, j] or s > arcs[-1]:
            below = np.nonzero(occupied[k, : j + 1])[0]
            if s > arcs[-1] and len(below):  # beyond the graph: only what lies below
                lower[k] = arcs[min(below[-1] + 1, len(arcs) - 1)] - s0
            continue
        below = np.nonzero(occupied[k, :j])[0]
        above = np.nonzero(occupied[k, j + 1:])[0]
        if len(below):
            lower[k] = arcs[below[-1] + 1] - s0
        if len(above):
            upper[k] = arcs[j + above[0]] - s0  # the last free grid point: j + 1 + above[0] - 1
    return lower, upper


def followers(graph: Occupancy, lower: np.ndarray, s0: float) -> list[tuple[int, np.ndarray]]:
    """The vehicles driving along the path behind the truck (their first occupied cell at or behind it) and the
    instants at which they occupy the cell just below the corridor's lower bound: (vehicle, instants)."""
    out = []
    arcs = graph.arcs
    for i in np.nonzero(graph.along)[0]:
        t_k, s_k = np.nonzero(graph.blocked[i])
        if len(t_k) == 0 or arcs[s_k[t_k == t_k.min()].min()] > s0 + GRID + 1e-9:
            continue
        ks = [k for k in np.unique(t_k) if np.isfinite(lower[k])
              and graph.blocked[i, k, max(int(round((lower[k] + s0 - arcs[0]) / GRID)) - 1, 0)]]  # fmt: skip
        if ks:
            out.append((int(i), np.array(ks)))
    return out


@dataclass
class SpeedPlanner:
    """The QP of the module docstring over the instants ``tau``, built once (casadi's qpOASES)."""

    tau: np.ndarray
    limits: Limits
    top: float = 8.0  # m/s: the top speed of the stop rows' linear bound (``solve``)
    solver: object = field(init=False, repr=False)
    n: int = field(init=False)
    previous: SpeedProfile | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        import casadi

        self.n = len(self.tau)
        self.stop_gain = self.top / (2.0 * -self.limits.a_min)
        self._layout()
        self._h_rows, self._h_cols = self._h_pattern()
        self._a_rows, self._a_cols = self._a_pattern()
        h_sp = self._matrix(self._h_rows, self._h_cols, np.ones(len(self._h_rows)), self.nx).sparsity()
        a_sp = self._matrix(self._a_rows, self._a_cols, np.ones(len(self._a_rows)), self.nrow).sparsity()
        opts = {"printLevel": "none", "error_on_fail": False, "hessian_type": "posdef"}
        with quiet_stdout():  # qpOASES prints its banner from C when made (and the first solve, to be sure)
            self.solver = casadi.conic("speed_qp", "qpoases", {"h": h_sp, "a": a_sp}, opts)
            n = self.n
            self.solve(0.0, 0.0, np.full(n, -np.inf), np.full(n, np.inf), np.full(n, -np.inf), np.zeros(n),
                       np.ones(n))  # fmt: skip

    def _layout(self) -> None:
        """Variable blocks: s, v, a (n each), lower slack e, upper slack f, follower slack g (n each)."""
        n = self.n
        self.S, self.V, self.A, self.E, self.F, self.G = (np.arange(n) + i * n for i in range(6))
        self.nx = 6 * n
        # rows: v dynamics (n-1), s dynamics (n-1), jerk (n-1), lower (n), upper (n), follower (n), vmax (n)
        m = n - 1
        self.R_V, self.R_S, self.R_J = np.arange(m), m + np.arange(m), 2 * m + np.arange(m)
        self.R_LO, self.R_HI, self.R_FO, self.R_VM, self.R_ST = (3 * m + i * n + np.arange(n) for i in range(5))
        self.nrow = 3 * m + 5 * n

    def _matrix(self, rows: list[int], cols: list[int], values, nrow: int):
        """A casadi matrix of the fixed pattern (rows, cols) with ``values`` (zeros kept as entries)."""
        import casadi

        return casadi.DM.triplet(rows, cols, casadi.DM(np.asarray(values, float)), nrow, self.nx)

    def _h_pattern(self) -> tuple[list[int], list[int]]:
        rows, cols = [], []
        for k in range(self.n):
            for i, j in ((self.V[k], self.V[k]), (self.A[k], self.A[k]), (self.E[k], self.E[k]),
                         (self.F[k], self.F[k]), (self.G[k], self.G[k])):  # fmt: skip
                rows.append(int(i))
                cols.append(int(j))
        for k in range(self.n - 1):  # the jerk term couples a_k and a_{k+1}
            rows += [int(self.A[k]), int(self.A[k + 1])]
            cols += [int(self.A[k + 1]), int(self.A[k])]
        return rows, cols

    def _a_pattern(self) -> tuple[list[int], list[int]]:
        self._a_entries = self._a_values(np.zeros(self.n))
        rows = [r for r, _, _ in self._a_entries]
        cols = [c for _, c, _ in self._a_entries]
        return rows, cols

    def _a_values(self, follow: np.ndarray) -> list[tuple[int, int, float]]:
        """The constraint matrix's entries (row, column, value); ``follow``: the follower rows' speed coefficient."""
        e, h = [], np.diff(self.tau)
        for k in range(self.n - 1):
            r = int(self.R_V[k])  # v_{k+1} - v_k - h/2 (a_k + a_{k+1}) = 0
            e += [(r, int(self.V[k + 1]), 1.0), (r, int(self.V[k]), -1.0),
                  (r, int(self.A[k]), -h[k] / 2), (r, int(self.A[k + 1]), -h[k] / 2)]  # fmt: skip
            r = int(self.R_S[k])  # s_{k+1} - s_k - h v_k - h^2/3 a_k - h^2/6 a_{k+1} = 0
            e += [(r, int(self.S[k + 1]), 1.0), (r, int(self.S[k]), -1.0), (r, int(self.V[k]), -h[k]),
                  (r, int(self.A[k]), -h[k] ** 2 / 3), (r, int(self.A[k + 1]), -h[k] ** 2 / 6)]  # fmt: skip
            r = int(self.R_J[k])  # a_{k+1} - a_k in [j_min h, j_max h]
            e += [(r, int(self.A[k + 1]), 1.0), (r, int(self.A[k]), -1.0)]
        for k in range(self.n):
            e += [(int(self.R_LO[k]), int(self.S[k]), 1.0), (int(self.R_LO[k]), int(self.E[k]), 1.0)]
            e += [(int(self.R_HI[k]), int(self.S[k]), 1.0), (int(self.R_HI[k]), int(self.F[k]), -1.0)]
            e += [(int(self.R_FO[k]), int(self.S[k]), 1.0), (int(self.R_FO[k]), int(self.V[k]), float(follow[k])),
                  (int(self.R_FO[k]), int(self.G[k]), 1.0)]  # fmt: skip
            e += [(int(self.R_VM[k]), int(self.V[k]), 1.0)]
            e += [(int(self.R_ST[k]), int(self.S[k]), 1.0), (int(self.R_ST[k]), int(self.V[k]), self.stop_gain),
                  (int(self.R_ST[k]), int(self.F[k]), -1.0)]  # fmt: skip
        return e

    def solve(self, v0: float, a0: float, lower: np.ndarray, upper: np.ndarray, follower: np.ndarray,
              follow: np.ndarray, vmax: np.ndarray, stop: np.ndarray | None = None) -> SpeedProfile:  # fmt: skip
        """One QP: from speed ``v0`` and acceleration ``a0``, path lengths from now within [``lower``, ``upper``]
        (m, -inf/inf: none), s + ``follow`` v >= ``follower`` (m, -inf: none), v <= ``vmax`` at the instants;
        ``stop``: s + ``stop_gain`` v <= stop (m, inf: none): the truck can still stop by there braking at
        its hardest (v^2 / (2 |a_min|) <= stop_gain v for v <= the top speed: a conservative linear row)."""
        h, lim = np.diff(self.tau), self.limits
        w = np.concatenate([[h[0] / 2], 0.5 * (h[:-1] + h[1:]), [h[-1] / 2]])  # the instants' time weights
        H = np.zeros(self.nx)
        H[self.V] = 2 * SPEED_WEIGHT * w
        H[self.A] = 2 * ACCEL_WEIGHT * w
        H[self.E] = H[self.F] = H[self.G] = 2.0
        jw = 2 * JERK_WEIGHT / h  # (a_{k+1} - a_k)^2 / h^2 * h
        H[self.A[:-1]] += jw
        H[self.A[1:]] += jw
        hv = [H[int(i)] if i == j else -jw[min(i, j) - int(self.A[0])]
              for i, j in zip(self._h_rows, self._h_cols, strict=True)]  # fmt: skip
        g = np.zeros(self.nx)
        g[self.V] = -2 * SPEED_WEIGHT * w * vmax - PROGRESS_WEIGHT * w
        g[self.E] = g[self.F] = g[self.G] = SLACK_WEIGHT
        a0 = min(max(a0, lim.a_min), lim.a_max)
        lbx, ubx = np.full(self.nx, -np.inf), np.full(self.nx, np.inf)
        lbx[self.V], lbx[self.A], ubx[self.A] = 0.0, lim.a_min, lim.a_max
        lbx[self.E] = lbx[self.F] = lbx[self.G] = 0.0
        lbx[self.S[0]] = ubx[self.S[0]] = 0.0
        lbx[self.V[0]] = ubx[self.V[0]] = max(v0, 0.0)
        lbx[self.A[0]] = ubx[self.A[0]] = a0
        lba, uba = np.full(self.nrow, -np.inf), np.full(self.nrow, np.inf)
        lba[self.R_V] = uba[self.R_V] = 0.0
        lba[self.R_S] = uba[self.R_S] = 0.0
        lba[self.R_J], uba[self.R_J] = lim.j_min * h, lim.j_max * h
        lba[self.R_LO], uba[self.R_HI], lba[self.R_FO] = lower, upper, follower
        uba[self.R_VM] = np.maximum(vmax, self._braking_envelope(v0, a0))
        if stop is not None:
            uba[self.R_ST] = stop
        av = [val for _, _, val in self._a_values(follow)]
        big = 1e9  # qpOASES: no infinite bounds
        sol = self.solver(h=self._matrix(self._h_rows, self._h_cols, hv, self.nx), g=g,
                          a=self._matrix(self._a_rows, self._a_cols, av, self.nrow),
                          lbx=np.clip(lbx, -big, big), ubx=np.clip(ubx, -big, big),
                          lba=np.clip(lba, -big, big), uba=np.clip(uba, -big, big))  # fmt: skip
        x = np.asarray(sol["x"]).ravel()  # names: casadi's solution key, not a vehicle state
        ok = bool(self.solver.stats().get("success", False))
        slack = float(max(x[self.E].max(), x[self.F].max(), x[self.G].max()))
        return SpeedProfile(self.tau.copy(), x[self.S], np.maximum(x[self.V], 0.0), x[self.A], ok, slack)

    def _braking_envelope(self, v0: float, a0: float) -> np.ndarray:
        """The least speed reachable at each instant braking as hard as the limits allow (vmax's floor)."""
        lim, v, a = self.limits, v0, a0
        out = [v0]
        for h in np.diff(self.tau):
            a_next = max(lim.a_min, a + lim.j_min * h) if math.isfinite(lim.j_min) else lim.a_min
            v = max(v + 0.5 * (a + a_next) * h, 0.0)
            a = a_next
            out.append(v + 1e-6)
        return np.array(out)


def plan_speed(planner: SpeedPlanner, pilot: Autopilot, path: PathSpeed, s0: float, v0: float, a0: float,
               graph: Occupancy, fine: np.ndarray) -> SpeedProfile:  # fmt: skip
    """The QP's profile from path length ``s0`` at speed ``v0`` through the s-t graph ``graph`` (module docstring).

    ``fine``: the graph's instants (``coarse`` maps its constraints onto the QP's). The give-way line is
    ``pilot.give_way`` (a plan time); the follower's braking ``FOLLOWER_DECEL``, the truck's own
    ``pilot.leader_decel``.
    """
    from model.traffic.autopilot import FOLLOWER_DECEL

    tau, n = planner.tau, planner.n
    line = path.arc_at(pilot.give_way)
    prev = planner.previous
    guess = s0 + v0 * tau
    v_ref = np.full(n, v0)
    if prev is not None:  # the last answer, one step on
        shifted = np.interp(tau + tau[1], prev.t, prev.s) - np.interp(tau[1], prev.t, prev.s)
        guess = s0 + np.where(tau + tau[1] <= prev.t[-1], shifted, shifted + prev.v[-1] * (tau + tau[1] - prev.t[-1]))
        v_ref = np.maximum(np.interp(tau + tau[1], prev.t, prev.v), 0.0)
    fast = fastest(fine, v0, a0, planner.limits, path, s0)
    restart = fastest(fine, 0.0, 0.0, planner.limits, path, s0)
    g = guide(graph, fine, fast, restart, s0, line if s0 < line - 1e-9 else None)
    low, up = corridor(graph, g, s0)
    lower, upper = np.full(n, -np.inf), np.full(n, np.inf)
    k = np.nonzero(np.isfinite(low))[0]
    np.maximum.at(lower, coarse(fine, k, tau, "pass"), low[k])
    k = np.nonzero(np.isfinite(up))[0]
    np.minimum.at(upper, coarse(fine, k, tau, "yield"), up[k])
    stop = np.full(n, np.inf)
    if np.isfinite(up[-1]) and fine[-1] < tau[-1] - 1e-9:  # the graph ends before the QP: it can still stop there
        stop[coarse(fine, np.array([len(fine) - 1]), tau, "yield")] = up[-1]
    follower, follow = np.full(n, -np.inf), v_ref / pilot.leader_decel
    for i, ks in followers(graph, low, s0):  # it can stop behind the truck braking at its decel
        q = coarse(fine, ks, tau, "pass")
        need = low[ks] + graph.speed[i] ** 2 / (2.0 * FOLLOWER_DECEL) + v_ref[q] ** 2 / (2.0 * pilot.leader_decel)
        np.maximum.at(follower, q, need)
    vmax = path.vmax_at(guess)
    best = planner.solve(v0, a0, lower, upper, follower, follow, vmax, stop)
    again = path.vmax_at(s0 + best.s)
    if np.max(np.abs(again - vmax)) > VMAX_TOL:  # vmax at the solution's path lengths, once
        best = planner.solve(v0, a0, lower, upper, follower, follow, again, stop)
    planner.previous = best
    return best


@dataclass
class QpDriver:
    """The ``qp`` speed planner of one autopilot: its path by path length, its QP, and its last answer."""

    pilot: Autopilot
    limits: Limits = field(init=False)
    path: PathSpeed = field(init=False, repr=False)
    planner: SpeedPlanner | None = field(init=False, default=None, repr=False)
    last: SpeedProfile | None = field(init=False, default=None, repr=False)

    def __post_init__(self) -> None:
        self.limits = limits_of(self.pilot)
        self.path = path_speed(self.pilot, self.limits)

    def profile(self, others: list, tau: np.ndarray, step: float,
                exiting: frozenset[str] = frozenset()) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """The QP's progress rates and plan times at the autopilot's instants ``tau`` (module docstring).

        Parameters
        ----------
        others : list of MovingVehicle
            The other vehicles now (as ``Autopilot.decide`` gets them).
        tau : numpy.ndarray
            The autopilot's checked instants (tau[1] is the step).
        step : float
            The step, s.
        exiting : frozenset of str
            The keys of the vehicles showing the exit side's signal.

        Returns
        -------
        tuple of numpy.ndarray
            The rates (plan seconds per second) and plan times at ``tau``.
        """
        pilot = self.pilot
        if self.planner is None or self.planner.tau[1] != tau[1]:
            self.planner = SpeedPlanner(qp_grid(step), self.limits, top=float(self.path.vmax.max()))
        fine = grid(step, tau)
        s0 = self.path.arc_at(pilot.s)
        here = float(pilot.plan.at(pilot.s)[pilot.scenario.ocp.vehicle.roles.speed][0])
        v0 = abs(pilot.rate * here)
        a0 = float(np.interp(step, self.last.t, self.last.a)) if self.last is not None else 0.0
        near = pilot.near(others, fine)
        theirs = pilot.predicted(near, fine, exiting)
        graph = occupancy(pilot, self.path, s0, fine, theirs, [o.key for o in near], [abs(o.speed) for o in near])
        self.last = best = plan_speed(self.planner, pilot, self.path, s0, v0, a0, graph, fine)
        s = np.interp(tau, best.t, best.s) + s0
        v = np.interp(tau, best.t, best.v)
        plan_times = self.path.time_at(s)
        pace = np.abs(np.interp(plan_times, pilot.plan.t, pilot.plan.columns[pilot.scenario.ocp.vehicle.roles.speed]))
        rates = v / np.maximum(pace, V_FLOOR)
        return rates, np.minimum(plan_times, pilot.plan.duration)


__all__ = [
    "ACCEL_WEIGHT", "ALONG", "BUFFER", "GRID", "JERK_WEIGHT", "OCCUPANCY_HORIZON", "PLAN_HORIZON", "PLAN_SAMPLE",
    "PROGRESS_WEIGHT", "QP_SAMPLE",
    "SLACK_WEIGHT", "SPEED_WEIGHT", "VMAX_TOL", "V_FLOOR",
    "Limits", "Occupancy", "PathSpeed", "QpDriver", "SpeedPlanner", "SpeedProfile", "fastest", "grid", "limits_of",
    "coarse", "corridor", "followers", "guide", "occupancy", "path_speed", "plan_speed", "qp_grid", "threshold",
]  # fmt: skip
