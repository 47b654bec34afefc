"""The ``autopilot`` driver: the truck's optimal plan, driven with a speed profile that gives way.

Strategy ("latest safe braking along the plan"): the plan is the scenario's own optimum (solved
once, before the truck appears, as ``roundabout solve`` solves it). The truck stays on the plan's
path and only its progress is chosen: the state at time t is the plan's at plan time s(t), with
ds/dt = r(t) in [0, 1]. For the kinematic models here f(x, r u) = r f(x, u), so the states are
exactly the plan's and the applied controls are the plan's scaled by r: the path, and so every
body's corridor clearance, is the validated plan's.

Each step (the speed profile is re-planned every step, from the new predictions) every other
vehicle is predicted as a ``MovingVehicle`` at constant speed and yaw rate from its current pose
(the yaw rate from its heading change over the last ``YAW_WINDOW`` seconds). A profile is *safe*
if at the instants 0, step, 0.25, 0.5, ..., ``HORIZON`` s every body of the truck (exact
rectangle at the plan time the profile reaches) keeps at least ``safety_distance`` from every
predicted rectangle: the gap acceptance compares the truck's own planned occupancy with the
predictions, no fixed critical gap or time margin. A prediction tau seconds ahead errs more the
larger tau is, so the instant tau > 0 needs ``safety_distance + PREDICTION_MARGIN * min(tau,
MARGIN_HORIZON)`` (the present, tau = 0, is measured, not chosen: it is not checked). The profiles,
fastest first:

- ``rate q`` for q in ``TARGETS`` (1, 0.875, ..., 0.125): r moves to q at ``RATE_SLOPE`` per second
  and stays there (r = 1 is the plan's own pace); before the give-way line a slower q only if it
  stays before the line over the horizon: the truck enters the ring at the plan's pace, never
  creeping in (a crawl would hold the ring past the horizon);
- ``approach`` (only before the give-way line, the plan time where the front bumper first comes
  within ``line_radius`` of the centre: ``LINE_SLACK`` before the end of SUMO's entry lane, where
  the junction begins, or ``Ro + GIVE_WAY_MARGIN`` without a network): r moves toward q (each q
  of the ladder in turn, after ``rate q``) for one step, then falls at
  ``RATE_SLOPE`` per second to a stop no later than the line, if that stop is still possible. The
  truck keeps its planned speed while it could still stop at the line safely, and slows only when
  the last such moment comes with no safe gap (it never slows for a conflict it can still wait out);
- ``stop at the line`` (r falls linearly to 0 exactly at the line), ``stand``.

The first safe profile (distance kept, SUMO's junction rule of ``junction_conflict`` kept when
the network's junctions are given, and no circulating follower made to brake harder than
``FOLLOWER_DECEL``, ``follower_braking``) is taken; if none is, the one with the largest least
predicted distance among the profiles keeping those rules, or among all if none keeps them.
A vehicle too far to come within ``safety_distance`` during the horizon, whatever it and the truck
do at their speeds, is not checked.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from model.analysis.bodies import rectangle_gaps
from model.problem.scenario import Scenario
from model.scene.moving import MovingVehicle
from model.scene.roundabout import lane_side
from model.traffic.network import ring_radius, truck_geometry
from model.traffic.speed_planner import QpDriver

HORIZON = 5.0  # s looked ahead
SAMPLE = 0.25  # s between the predicted instants (plus the first step's end)
RATE_SLOPE = 0.5  # 1/s: the largest change of the progress rate per second (up or down)
GIVE_WAY_MARGIN = 1.0  # m: without a network, the truck stops with its front bumper this far outside the outer curb
LINE_SLACK = 0.5  # m: with SUMO's network, the front bumper stops this far before the entry lane's end
TARGETS = (1.0, 0.875, 0.75, 0.625, 0.5, 0.375, 0.25, 0.125)
YAW_WINDOW = 0.5  # s: the others' yaw rate is their heading change over this long, divided by it
YIELD_DECEL = 4.5  # m/s^2: an entering vehicle that can stop at its line braking at most this hard yields
ENTERING_COS = math.cos(math.radians(30.0))  # heading within 30 degrees of the centre's direction: entering
SUMO_TAU = 1.0  # s: the headway of SUMO's car-following model (Krauss tau): its brake gap is v tau + v^2 / (2 b)
ENTRY_INSTANTS = 1  # the checked instants inside the entry junction for vehicles behind the truck in it
MAP_MARGIN = 1.0  # m: the ring's internal lane this much farther from the front than the exit's may still be chosen
TURNING_IN_COS = 0.5  # inside the exit's junction, a vehicle heading within 60 degrees of the centre still turns in
MARGIN_HORIZON = 1.0  # s: the margin grows with tau up to this far ahead, then stays (PREDICTION_MARGIN * 1 s)
PREDICTION_MARGIN = 0.2  # m/s: an instant tau ahead needs safety_distance + this * tau (the predictions' error grows)
FOLLOWER_DECEL = 4.0  # m/s^2: the hardest braking an entry may ask of a circulating follower (SUMO's car: 4.5)
FOLLOW_MIN_GAP = 2.5  # m: the follower's standstill gap behind the truck (SUMO's passenger minGap)
FOLLOW_HEADING = math.radians(30.0)  # a vehicle on the ring heading within this of the ring's tangent circulates
EXIT_SIGNAL_MIN = 8.0  # m: a car signalling its exit this near the merge point may mean the next exit: it follows
LEADER_DECEL = 4.0  # m/s^2: the truck's braking SUMO's follower assumes (SUMO's truck and trailer decel)
EMERGENCY_DECEL = 9.0  # m/s^2: the follower's hardest braking (SUMO's passenger emergencyDecel)
MAX_TURN = math.pi / 2.0  # rad: a constant-yaw-rate prediction turns at most this far, then goes straight
EXIT_LOOKAHEAD = 8.0  # m: a car turning out to an exit steers toward the exit lane's middle this far ahead
EXIT_MIN_RADIUS = 5.0  # m: the tightest turn of that predicted path
EXIT_TURN_ANGLE = math.radians(35.0)  # a car signalling its exit turns out this far before its leg's axis
COMMITTED_RATE_MIN = 0.5  # too near the line to stop by it at RATE_SLOPE, the truck may enter at down to this pace
RING_HEADING = math.radians(15.0)  # on the ring and heading within this of its tangent: predicted along the ring


@dataclass
class Plan:
    """A node trajectory (t, states, controls) to interpolate at plan time s."""

    t: np.ndarray
    columns: dict[str, np.ndarray]

    @property
    def duration(self) -> float:
        """The plan's final time Tf."""
        return float(self.t[-1])

    def at(self, s: np.ndarray | float) -> dict[str, np.ndarray]:
        """Every column linearly interpolated at plan times ``s``."""
        s = np.clip(np.atleast_1d(np.asarray(s, float)), 0.0, self.duration)
        return {k: np.interp(s, self.t, v) for k, v in self.columns.items()}


def plan_of(solution, vehicle) -> Plan:
    """The plan of a ``Solution``: its trajectory's t, states and controls."""
    frame = solution.trajectory
    names = [*vehicle.states, *vehicle.controls]
    return Plan(frame["t"].to_numpy(float), {n: frame[n].to_numpy(float) for n in names})


@dataclass
class Autopilot:
    """The driver's state: plan time ``s`` and progress rate ``rate``, and its timings."""

    scenario: Scenario
    plan: Plan
    front: float
    line_radius: float | None = None  # the give-way line's distance from the centre; None: Ro + GIVE_WAY_MARGIN
    junctions: tuple[np.ndarray, np.ndarray] | None = None  # SUMO's entry and exit junction outlines; None: no rule
    exit_lanes: tuple[np.ndarray, np.ndarray] | None = None  # the exit's internal lane and the ring's one beside it
    entry_rule: bool = False  # also the entry half of the junction rule (measured worse: off in `roundabout traffic`)
    s: float = 0.0
    rate: float = 1.0
    decision_seconds: list[float] = field(default_factory=list)
    decision_cpu_seconds: list[float] = field(default_factory=list)  # the same decisions in CPU seconds
    give_way: float = field(init=False)
    body_poses: dict = field(init=False, repr=False)
    reach: float = field(init=False)
    top_speed: float = field(init=False)
    windows: tuple[tuple[float, float], tuple[float, float]] | None = field(init=False, default=None)
    follow_rule: bool = True  # refuse an entry that makes a circulating follower brake above FOLLOWER_DECEL
    merge_point: tuple[float, float] | None = None  # where SUMO's entry lane joins the ring; None: on the entry's axis
    merge: np.ndarray = field(init=False, repr=False)  # the merge point used
    front_arc: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False)  # plan times, the front's path length
    front_speed: np.ndarray = field(init=False, repr=False)  # the front's speed along the plan at those plan times
    merge_arc: float = field(init=False)  # the front's path length where it passes nearest the merge point
    merge_time: float = field(init=False)  # the plan time there
    length: float = field(init=False)  # SUMO's length of the truck (the straight vehicle's overall length)
    leader_decel: float = LEADER_DECEL  # m/s^2: the truck's vType decel, which SUMO's follower assumes
    rate_slope: float = field(init=False)  # 1/s: the progress rate's largest change per second (``slope``)
    qp: QpDriver | None = field(init=False, default=None, repr=False)  # [traffic] speed_planner = "qp": the QP

    def __post_init__(self) -> None:
        self.give_way = self._give_way_time()
        if self.junctions is not None:
            self.windows = (self._inside_window(self.junctions[0]), self._mapped_window())
        # each body's pose as a numpy function of the states, made once (lambdify is slow; a decision is not)
        v = self.scenario.ocp.vehicle
        poses = v.body_poses()
        self.body_poses = {name: v.state_function(list(poses[name])) for name in self.scenario.ocp.bodies}
        self.reach, self.top_speed = self._reach()
        self.rate_slope = self.slope()
        self.length = truck_geometry(self.scenario)["length"]
        self._merge_geometry()
        if getattr(self.scenario.traffic, "speed_planner", "rules") == "qp":  # its profile is tried first
            self.qp = QpDriver(self)

    def _merge_geometry(self) -> None:
        """The merge point of the entry, the front's path length along the plan and at the merge point."""
        road = self.scenario.ocp.road
        ra, angle = road.roundabout, road.roundabout.legs[road.route.enter].angle
        self.merge = np.asarray(ra.center, float) + ring_radius(ra) * np.array([math.cos(angle), math.sin(angle)])
        if self.merge_point is not None:
            self.merge = np.asarray(self.merge_point, float)
        s = np.linspace(0.0, self.plan.duration, 2001)
        p = self._front(s)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        self.front_arc = (s, arc)
        self.front_speed = np.gradient(arc, s)  # the front bumper's speed along the plan (SUMO's speed of the truck)
        k = int(np.argmin(np.linalg.norm(p - self.merge, axis=1)))
        self.merge_arc, self.merge_time = float(arc[k]), float(s[k])

    def _reach(self) -> tuple[float, float]:
        """Farthest body corner from the reference point along the plan, and the plan's top speed (m, m/s)."""
        v = self.scenario.ocp.vehicle
        st = self.plan.at(np.linspace(0.0, self.plan.duration, 201))
        x, y = (st[n] for n in v.position)
        far = 0.0
        for name, body in self.scenario.ocp.bodies.items():
            c = body.corners(*self.body_poses[name](st))  # (n, 4, 2)
            far = max(far, float(np.hypot(c[..., 0] - x[:, None], c[..., 1] - y[:, None]).max()))
        return far, float(np.abs(st[v.roles.speed]).max())

    def slope(self) -> float:
        """``RATE_SLOPE``, or less with the scenario's acceleration bounds (``[vehicle.longitudinal]``): at the
        plan's top speed a change of the rate at this slope needs at most the smaller of the largest
        acceleration and braking, so that the truck can follow its reference under its limits."""
        ocp = self.scenario.ocp
        name = ocp.vehicle.roles.acceleration
        if name is None or name not in ocp.bounds or self.top_speed <= 0.0:
            return RATE_SLOPE
        lo, hi = ocp.bounds[name]
        return min(RATE_SLOPE, min(hi, -lo) / self.top_speed)

    def _give_way_time(self) -> float:
        """Plan time at which the front bumper first comes within ``line_radius`` (or Ro + GIVE_WAY_MARGIN)."""
        ra, v = self.scenario.ocp.road.roundabout, self.scenario.ocp.vehicle
        s = np.linspace(0.0, self.plan.duration, 2001)
        st = self.plan.at(s)
        px, py = v.position
        h = st[v.roles.heading]
        r = np.hypot(st[px] + self.front * np.cos(h) - ra.center[0], st[py] + self.front * np.sin(h) - ra.center[1])
        line = ra.outer_radius + GIVE_WAY_MARGIN if self.line_radius is None else self.line_radius
        inside = np.nonzero(r <= line)[0]
        return float(s[inside[0]]) if len(inside) else self.plan.duration

    def _front(self, s: np.ndarray) -> np.ndarray:
        """The front bumper's centre (len(s), 2) at plan times ``s``."""
        v = self.scenario.ocp.vehicle
        st = self.plan.at(s)
        h = st[v.roles.heading]
        x, y = (st[n] for n in v.position)
        return np.column_stack([x + self.front * np.cos(h), y + self.front * np.sin(h)])

    def _inside_window(self, outline: np.ndarray) -> tuple[float, float]:
        """First and last plan time with the front bumper inside ``outline``; (inf, inf) if never."""
        import shapely

        s = np.linspace(0.0, self.plan.duration, 2001)
        p = self._front(s)
        inside = np.nonzero(shapely.contains_xy(shapely.Polygon(outline), p[:, 0], p[:, 1]))[0]
        return (float(s[inside[0]]), float(s[inside[-1]])) if len(inside) else (math.inf, math.inf)

    def _mapped_window(self) -> tuple[float, float]:
        """Plan times, inside the exit junction, where SUMO may put the truck on the ring's lane, not its exit's.

        ``moveToXY(..., keepRoute=2)`` maps the front bumper onto the nearest lane: where the plan
        cuts the corner the ring's internal lane beside the exit's is about as near (within
        ``MAP_MARGIN``), and a car entering from the exit leg then sees a circulating truck.
        (inf, inf) without ``exit_lanes`` or if it never is.
        """
        import shapely

        if self.exit_lanes is None:
            return math.inf, math.inf
        s = np.linspace(0.0, self.plan.duration, 2001)
        p = self._front(s)
        points = shapely.points(p)
        mine, ring = (shapely.distance(shapely.LineString(lane), points) for lane in self.exit_lanes)
        inside = shapely.contains_xy(shapely.Polygon(self.junctions[1]), p[:, 0], p[:, 1])
        k = np.nonzero(inside & (ring <= mine + MAP_MARGIN))[0]
        return (float(s[k[0]]), float(s[k[-1]])) if len(k) else (math.inf, math.inf)

    def junction_conflict(self, tau: np.ndarray, s: np.ndarray, theirs: np.ndarray) -> bool:
        """Whether the profile reaching plan times ``s`` breaks SUMO's junction rule for a predicted vehicle.

        SUMO's vehicles brake for a vehicle on a foe or merging internal lane of the junction ahead
        (``traci.vehicle.getJunctionFoes``), and the truck, moved by ``moveToXY``, is on the junction's
        internal lanes while its front bumper is inside the junction outline. A vehicle that then
        cannot stop before the junction within its brake gap v ``SUMO_TAU`` + v^2 / (2 ``YIELD_DECEL``)
        brakes harder (up to SUMO's emergency 9 m/s^2). So: (entry) at the instant the truck's front
        enters the entry junction, no vehicle that is not itself entering may be approaching that
        junction within its brake gap; (exit) at every instant the front is inside the exit junction
        (where SUMO may map the truck onto the ring's internal lane that merges with the exit leg's
        entry), no entering vehicle may be within its brake gap of that junction or inside it still
        turning in.
        """
        if self.windows is None or len(theirs) == 0:
            return False
        import shapely

        (enter, e1), (x0, x1) = self.windows
        fronts = theirs[:, :, 1:3, :].mean(axis=2)  # (n, T, 2): the front corners' middle
        rears = theirs[:, :, [0, 3], :].mean(axis=2)
        axis = fronts - rears
        axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
        c = np.asarray(self.scenario.ocp.road.roundabout.center, float)
        radial = c - fronts
        radial /= np.maximum(np.linalg.norm(radial, axis=-1, keepdims=True), 1e-9)
        inward = (axis * radial).sum(axis=-1)  # (n, T): cosine between heading and the centre's direction
        speed = np.linalg.norm(np.gradient(fronts, tau, axis=1), axis=-1)
        arc = np.concatenate([np.zeros((len(theirs), 1)),
                              np.cumsum(np.linalg.norm(np.diff(fronts, axis=1), axis=-1), axis=1)], axis=1)  # fmt: skip
        gap = speed * SUMO_TAU + speed**2 / (2.0 * YIELD_DECEL)
        if self.entry_rule and s[0] < enter <= s[-1]:
            k = int(np.argmax(s >= enter))
            if self._approaching(self.junctions[0], fronts, arc, gap, k, inward[:, k] < ENTERING_COS).any():
                return True
        if self.entry_rule and s[-1] >= enter and s[0] <= e1:
            inside = shapely.contains_xy(shapely.Polygon(self.junctions[0]), fronts[..., 0], fronts[..., 1])
            mine = self._front(s) - c  # the truck's front from the centre, (T, 2)
            ra = self.scenario.ocp.road.roundabout
            turn = np.arctan2(-radial[..., 1], -radial[..., 0]) - np.arctan2(mine[:, 1], mine[:, 0])
            ahead = ra.circulation * np.arctan2(np.sin(turn), np.cos(turn)) > 0.0  # (n, T): further along the ring
            behind = inside & ~ahead & (inward > -TURNING_IN_COS) & (inward < ENTERING_COS)
            if behind[:, (s >= enter) & (s <= e1)][:, :ENTRY_INSTANTS].any():
                return True
        if s[0] <= x1 and s[-1] >= x0:
            entering = inward >= ENTERING_COS
            outline = shapely.Polygon(self.junctions[1])
            inside = shapely.contains_xy(outline, fronts[..., 0], fronts[..., 1])
            for k in np.nonzero((s >= x0) & (s <= x1))[0]:
                if (inside[:, k] & (inward[:, k] >= TURNING_IN_COS)).any():
                    return True
                if self._approaching(self.junctions[1], fronts, arc, gap, k, entering[:, k]).any():
                    return True
        return False

    @staticmethod
    def _approaching(outline: np.ndarray, fronts: np.ndarray, arc: np.ndarray, gap: np.ndarray, k: int,
                     which: np.ndarray) -> np.ndarray:  # fmt: skip
        """Per vehicle: among ``which``, outside ``outline`` at instant ``k`` and reaching it within its brake gap."""
        import shapely

        inside = shapely.contains_xy(shapely.Polygon(outline), fronts[..., 0], fronts[..., 1])  # (n, T)
        later = inside[:, k:]
        hits = later.any(axis=1)
        first = k + np.argmax(later, axis=1)
        dist = arc[np.arange(len(arc)), first] - arc[:, k]
        return which & ~inside[:, k] & hits & (dist < gap[:, k])

    def follower_braking(self, tau: np.ndarray, rates: np.ndarray, s: np.ndarray, theirs: np.ndarray,
                         exiting: np.ndarray | None = None) -> float:  # fmt: skip
        """The hardest braking (m/s^2) an entry along this profile asks of a circulating follower; 0 if none.

        Only until the truck's front reaches the merge point (``merge_time``: standing or slowing
        just past the line still makes a follower brake) and for a profile that crosses the
        give-way line. A follower is a
        predicted vehicle circulating on the ring: its front between the inner and the outer curb,
        heading within ``FOLLOW_HEADING`` of the ring's tangent in the circulation direction (a
        vehicle turning out to an exit deviates more and is no follower), and not showing the exit
        side's turn signal (``decide(..., exiting=...)``: SUMO's car signals about 50 degrees before
        its exit's junction; ``exiting``) unless it is within ``EXIT_SIGNAL_MIN`` of the merge point
        (there it may signal for the exit after the entry). It is taken to follow the
        ring to the merge point (``merge_point``, the end of SUMO's internal lane from the entry
        into the ring; without it the ring lane's centre on the entry leg's axis): its distance to it
        is the arc of the ring lane's centre line (radius ``ring_radius``) from its front's angle to
        the merge point's, in the circulation direction (the ring's geometry, not its predicted path:
        a constant yaw rate from the last ``YAW_WINDOW`` misleads where SUMO's ring lane bends at a
        junction). From the instant the truck's front crosses the line, SUMO's follower treats the
        truck as its leader (if the truck's front is the nearer to the merge point): gap = (the
        follower's distance to the merge point) - (the front's path length to it) - the truck's
        length - ``FOLLOW_MIN_GAP``. The follower, at its speed now, is driven by SUMO's safe follow
        speed (``_safe_stop_speed`` of the gap plus the truck's braking distance v_l^2 / (2
        ``LEADER_DECEL``); headway ``SUMO_TAU``, braking ``YIELD_DECEL``; v_l the speed of the truck's
        front bumper, SUMO's speed of the moved truck), never faster
        than now and braking at most ``EMERGENCY_DECEL``, at every ``step`` of the horizon; its
        largest deceleration is returned.

        Parameters
        ----------
        tau : numpy.ndarray
            The checked instants (``instants``); tau[1] is the step.
        rates, s : numpy.ndarray
            The profile's progress rates and plan times at ``tau``.
        theirs : numpy.ndarray
            The predicted corners (n, len(tau), 4, 2).
        exiting : numpy.ndarray, optional
            (n,) booleans: the vehicle shows the exit side's turn signal.

        Returns
        -------
        float
            The largest deceleration of the simulated followers, m/s^2.
        """
        if not self.follow_rule or self.s >= self.merge_time or s[-1] <= self.give_way or len(theirs) == 0:
            return 0.0
        step = float(tau[1])
        ahead = self._ring_to_merge(theirs, step, exiting)
        if not ahead:
            return 0.0
        grid = np.arange(0.0, tau[-1] + 1e-9, step)
        s_t = np.interp(grid, tau, s)
        v_l = np.interp(s_t, self.front_arc[0], self.front_speed) * np.interp(grid, tau, rates)  # the front's
        to_merge = self.merge_arc - np.interp(s_t, *self.front_arc)  # the front's path length to the merge point
        inside = s_t > self.give_way
        return max(_krauss_follower(d, v, to_merge, v_l, inside, self.length, step, self.leader_decel)
                   for d, v in ahead)  # fmt: skip

    def _ring_to_merge(self, theirs: np.ndarray, step: float,
                       exiting: np.ndarray | None = None) -> list[tuple[float, float]]:  # fmt: skip
        """The circulating vehicles' (distance along the ring to the merge point, speed now), m and m/s."""
        ra = self.scenario.ocp.road.roundabout
        c = np.asarray(ra.center, float)
        front = theirs[:, 0, 1:3, :].mean(axis=1)  # (n, 2): now
        axis = front - theirs[:, 0, [0, 3], :].mean(axis=1)
        axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
        rel = front - c
        r = np.linalg.norm(rel, axis=-1)
        angle = np.arctan2(rel[:, 1], rel[:, 0])
        tangent = angle + ra.circulation * math.pi / 2.0
        along = axis[:, 0] * np.cos(tangent) + axis[:, 1] * np.sin(tangent)
        ring = (r >= ra.inner_radius) & (r <= ra.outer_radius) & (along >= math.cos(FOLLOW_HEADING))
        m = self.merge - c
        turn = np.mod(ra.circulation * (math.atan2(m[1], m[0]) - angle), 2.0 * math.pi)
        distance = ring_radius(ra) * turn
        if exiting is not None:
            ring &= ~(np.asarray(exiting, bool) & (distance > EXIT_SIGNAL_MIN))  # signalling an exit before the merge
        speed = np.linalg.norm(theirs[:, 1, 1:3, :].mean(axis=1) - front, axis=-1) / step
        return [(float(distance[k]), float(speed[k])) for k in np.nonzero(ring)[0]]

    def instants(self, step: float) -> np.ndarray:
        """The checked instants: now, the end of the step, then every ``SAMPLE`` up to ``HORIZON``."""
        return np.unique(np.concatenate([[0.0, step], np.arange(SAMPLE, HORIZON + 1e-9, SAMPLE)]))

    def profiles(self, tau: np.ndarray) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
        """The candidate (name, rates, plan times) at ``tau``, fastest first (made as they are asked for)."""
        step = tau[1]
        # committed: too near the line to stop by it braking at the rate slope; it may then enter a little slower
        committed = self.s < self.give_way and self.s + self.rate**2 / (2.0 * self.rate_slope) > self.give_way
        for target in TARGETS:
            r = np.clip(target, self.rate - self.rate_slope * tau, self.rate + self.rate_slope * tau)
            s = self.s + _integral(r, tau)
            enters = target == 1.0 or (committed and target >= COMMITTED_RATE_MIN)  # else only the plan's pace
            if enters or s[-1] <= self.give_way or self.s >= self.give_way:
                yield f"rate {target:g}", r, s
            if self.s < self.give_way:
                approach = self.approach(tau, step, target)
                if approach is not None:
                    yield "approach", *approach
        if self.s < self.give_way:
            gap = self.give_way - self.s  # plan seconds to the line
            stop_time = 2.0 * gap / max(self.rate, 1e-9)
            r = np.clip(self.rate * (1.0 - tau / stop_time), 0.0, None) if self.rate > 0 else np.zeros_like(tau)
            yield "stop at the line", r, np.minimum(self.s + _integral(r, tau), self.give_way)
        yield "stand", np.zeros_like(tau), np.full_like(tau, self.s)

    def approach(self, tau: np.ndarray, step: float, target: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Toward ``target`` for one step, then braking at ``rate_slope`` to a stop by the line; None if too late."""
        first = float(np.clip(target, self.rate - self.rate_slope * step, self.rate + self.rate_slope * step))
        s1 = self.s + 0.5 * (self.rate + first) * step
        if s1 + first**2 / (2.0 * self.rate_slope) > self.give_way:
            return None
        r = np.where(tau <= step, self.rate + (first - self.rate) * tau / step,
                     np.clip(first - self.rate_slope * (tau - step), 0.0, None))  # fmt: skip
        # exact plan times of the piecewise-linear rate (a trapezoid on the grid would miss the kink at the stop)
        after = np.clip(tau - step, 0.0, first / self.rate_slope)
        s = np.where(tau <= step, self.s + self.rate * tau + 0.5 * (first - self.rate) * tau**2 / step,
                     s1 + first * after - 0.5 * self.rate_slope * after**2)  # fmt: skip
        return r, np.minimum(s, self.give_way)

    def decide(self, others: list[MovingVehicle], step: float,
               exiting: frozenset[str] = frozenset()) -> tuple[str, float]:  # fmt: skip
        """Choose the profile for the next step; advance s and rate; return (name, least predicted distance).

        ``exiting``: the keys of the vehicles showing the exit side's turn signal (no followers, see
        ``follower_braking``).
        """
        t0, c0 = time.perf_counter(), time.process_time()
        tau = self.instants(step)
        near = self._near(others, tau)
        theirs = self._predict(near, tau, exiting)
        signalling = np.array([o.key in exiting for o in near], bool)
        safety, braking, keeps = self.scenario.traffic.safety_distance, {}, {}

        def brakes(i: int, rates: np.ndarray, s: np.ndarray) -> float:  # each profile's follower braking once
            if i not in braking:
                braking[i] = self.follower_braking(tau, rates, s, theirs, signalling)
            return braking[i]

        def rules(i: int, rates: np.ndarray, s: np.ndarray) -> bool:  # the junction rule, no follower braked hard
            if i not in keeps:
                keeps[i] = not self.junction_conflict(tau, s, theirs) and brakes(i, rates, s) <= FOLLOWER_DECEL
            return keeps[i]

        best, tried, candidates, planned = None, [], self.profiles(tau), None
        if self.qp is not None:  # the QP's profile first, under the same checks; the rules' if it fails them
            planned = self.qp.profile(others, tau, step, exiting)
            candidates = itertools.chain([("qp", *planned)], candidates)
        for i, (name, rates, s) in enumerate(candidates):
            gaps = self.clearances(s, theirs)
            net = self.net_gap(tau, s, gaps)
            if net >= safety and rules(i, rates, s):
                best, best_gap = (name, rates), float(gaps.min())
                break
            tried.append((net, name, rates, s, float(gaps.min()), i))
        if best is None:  # none safe: the largest least distance among those keeping the rules
            kept = [t for t in tried if rules(t[5], t[2], t[3])]
            # none keeps them (a follower appeared after the line): the distance-safe one braking it least
            sure = [t for t in tried if t[0] >= safety]
            if kept or not sure:
                _, name, rates, _, best_gap, _ = max(kept or tried, key=lambda t: t[0])
            else:
                _, name, rates, _, best_gap, _ = min(sure, key=lambda t: brakes(t[5], t[2], t[3]))
            best = (name, rates)
        name, rates = best
        new_rate = float(np.interp(step, tau, rates))
        advance = 0.5 * (self.rate + new_rate) * step
        if name == "qp":  # the QP's own plan time at the step's end
            advance = max(float(planned[1][1]) - self.s, 0.0)
        if name in ("approach", "stop at the line", "stand") and self.s < self.give_way:
            advance = min(advance, self.give_way - self.s)  # never past the line when it chose to stop there
        self.s = min(self.s + advance, self.plan.duration)
        self.rate = new_rate
        self.decision_seconds.append(time.perf_counter() - t0)
        self.decision_cpu_seconds.append(time.process_time() - c0)
        return name, best_gap

    def net_gap(self, tau: np.ndarray, s: np.ndarray, gaps: np.ndarray) -> float:
        """The least distance less the prediction margin over the instants after now, until the truck arrives.

        Not the present (measured, not chosen), nor the instants after the one at which the profile
        reaches the plan's end: the run ends there (the truck arrives and leaves SUMO); parked at
        its goal pose in the prediction it would be hit by the car following it out of the exit
        (traced: truck straight 450 seed 1, a 'stand' in the exit at 8 m/s for that; 1.1 s of delay).
        """
        live = np.concatenate([[False], s[:-1] < self.plan.duration - 1e-9])  # not now, nor after arriving
        if not live.any():
            return math.inf
        return float(np.min(gaps[live] - PREDICTION_MARGIN * np.minimum(tau[live], MARGIN_HORIZON)))

    def expect(self, other: MovingVehicle, tau: np.ndarray, exiting: bool = False) -> MovingVehicle:
        """``other`` as the roundabout's rule expects it: an entering vehicle that can still stop yields.

        A vehicle circulating on the ring (``circulates``) and not showing the exit side's turn
        signal (``exiting``) follows the ring: ``along_ring``.

        A vehicle outside the outer curb whose heading points within 30 degrees of the centre is
        entering; if braking at constant deceleration to stop with its front at the curb needs at
        most ``YIELD_DECEL`` it is predicted to do that (it gives way to the truck on the ring, as
        the network's ``<roundabout>`` makes it); otherwise (too close, too fast: committed) and
        for every other vehicle, constant speed and yaw rate.
        """
        if other.start is None:
            return other
        if self.circulates(other):
            return self.to_exit(other, tau, signalled=True) if exiting else self.along_ring(other, tau)
        ra = self.scenario.ocp.road.roundabout
        x, y, h = other.start
        half, v = other.length / 2, other.speed
        fx, fy = x + half * math.cos(h) - ra.center[0], y + half * math.sin(h) - ra.center[1]
        d = math.hypot(fx, fy) - ra.outer_radius
        radial = fx * math.cos(h) + fy * math.sin(h)  # > 0: heading away from the centre
        if d > 0 and radial >= ENTERING_COS * math.hypot(fx, fy):
            return self.along_leg(other)
        if d <= 0 and radial >= math.sin(RING_HEADING) * math.hypot(fx, fy):  # on the ring, turning out
            return self.to_exit(other, tau)
        entering = d > 0 and -radial >= ENTERING_COS * math.hypot(fx, fy)
        if entering and v > 0 and v * v > 2.0 * YIELD_DECEL * d:
            return self.into_ring(other, tau)
        if not entering or v <= 0:
            return _turn_capped(other, tau)
        a = v * v / (2.0 * d)
        t = np.minimum(tau, v / a)
        run = v * t - 0.5 * a * t * t
        samples = tuple((float(ti), x + r * math.cos(h), y + r * math.sin(h), h)
                        for ti, r in zip(tau, run, strict=True))  # fmt: skip
        return MovingVehicle(other.length, other.width, trajectory=samples, key=other.key)

    def into_ring(self, other: MovingVehicle, tau: np.ndarray) -> MovingVehicle:
        """An entering car too close or too fast to yield: straight on at its speed to the ring lane's middle
        (radius ``ring_radius``), then round the ring (turned about the centre, heading the tangent).

        Straight on at constant speed it crossed the whole ring (traced: truck straight 700 seed 1, a car
        9 m before the curb at 9.4 m/s predicted 0.99 m from the truck 4.5 s ahead on the far side of the
        ring; the truck stopped at its line for it).
        """
        ra = self.scenario.ocp.road.roundabout
        c = np.asarray(ra.center, float)
        x, y, h = other.start
        v, radius = other.speed, ring_radius(ra)
        p, u = np.array([x, y]) - c, np.array([math.cos(h), math.sin(h)])
        b, q = float(p @ u), float(p @ p) - radius * radius
        if b * b < q:  # its line misses the ring lane's middle: straight on
            return _turn_capped(other, tau)
        t_in = max((-b - math.sqrt(b * b - q)) / v, 0.0)
        straight = np.minimum(tau, t_in)
        px, py = x + v * straight * u[0], y + v * straight * u[1]
        w = ra.circulation * v * (tau - straight) / radius  # the turn about the centre after reaching the lane
        entry = p + v * t_in * u  # where it reaches the lane's middle, from the centre
        a0 = math.atan2(float(entry[1]), float(entry[0]))
        angle = a0 + w
        on = tau > t_in
        px = np.where(on, c[0] + radius * np.cos(angle), px)
        py = np.where(on, c[1] + radius * np.sin(angle), py)
        heading = np.where(on, angle + ra.circulation * math.pi / 2.0, h)
        samples = tuple(
            (float(t), float(a), float(e), float(g)) for t, a, e, g in zip(tau, px, py, heading, strict=True)
        )
        return MovingVehicle(other.length, other.width, trajectory=samples, key=other.key)

    def along_leg(self, other: MovingVehicle) -> MovingVehicle:
        """A vehicle leaving the ring (outside the outer curb, heading within 30 degrees of away from the centre):
        straight on at its speed along the axis of the leg it is on (the nearest by angle).

        Its yaw rate while it straightens out of the exit's curve would turn it in a circle back onto
        the road (traced: semitrailer straight 200 seed 3, a car leaving by the truck's exit at -1.0
        rad/s predicted across the truck's path 5 s ahead; the truck stopped for it).
        """
        ra = self.scenario.ocp.road.roundabout
        x, y, h = other.start
        angle = math.atan2(y - ra.center[1], x - ra.center[0])
        leg = min(ra.legs, key=lambda g: abs(math.remainder(g.angle - angle, 2.0 * math.pi)))
        heading = h + math.remainder(leg.angle - h, 2.0 * math.pi)  # the leg's direction, nearest its heading now
        return MovingVehicle(other.length, other.width, start=(x, y, heading), speed=other.speed, key=other.key)

    def to_exit(self, other: MovingVehicle, tau: np.ndarray, signalled: bool = False) -> MovingVehicle:
        """A car turning out of the ring to an exit lane, at its speed.

        Without ``signalled``: a car on the ring heading outward of the tangent by more than
        ``RING_HEADING`` turns out to the nearest leg's exit lane, steered (pure pursuit, no tighter than
        ``EXIT_MIN_RADIUS``) toward the lane's middle ``EXIT_LOOKAHEAD`` ahead of it. Its yaw rate measured
        over ``YAW_WINDOW`` at the start of the turn is small and sent it straight on over the entry lane
        beside the exit (traced: truck right 700 seed 1, a car leaving by the truck's own leg at -0.12
        rad/s predicted across the standing truck; the truck stood for it). ``signalled``: a car
        circulating and showing the exit side's signal (SUMO's, about 50 degrees before its exit) goes
        round the ring to the next leg ahead and turns out the same way from ``EXIT_TURN_ANGLE`` before
        that leg's axis.
        """
        ra = self.scenario.ocp.road.roundabout
        c = np.asarray(ra.center, float)
        x, y, h = other.start
        angle = math.atan2(y - c[1], x - c[0])
        ahead = [float(np.mod(ra.circulation * (g.angle - angle), 2.0 * math.pi)) for g in ra.legs]
        near = [abs(math.remainder(g.angle - angle, 2.0 * math.pi)) for g in ra.legs]
        k = int(np.argmin(ahead if signalled else near))
        leg, around = ra.legs[k], ahead[k] - EXIT_TURN_ANGLE if signalled else 0.0
        across = lane_side(ra, "exit") * leg.lane_width / 2.0
        v, dt = other.speed, 0.05
        fine = np.arange(0.0, float(tau[-1]) + dt / 2, dt)
        poses = np.empty((len(fine), 3))
        radius = max(math.hypot(x - c[0], y - c[1]), 1e-9)
        for i in range(len(fine)):
            poses[i] = x, y, h
            if around > 0.0:  # still going round the ring: turned about the centre
                w = min(v * dt / radius, around)
                around -= w
                w *= ra.circulation
                dx, dy = x - c[0], y - c[1]
                x, y, h = c[0] + math.cos(w) * dx - math.sin(w) * dy, c[1] + math.sin(w) * dx + math.cos(w) * dy, h + w
                continue
            target = c + (float(np.dot((x, y) - c, leg.axis)) + EXIT_LOOKAHEAD) * leg.axis + across * leg.normal
            alpha = math.remainder(math.atan2(target[1] - y, target[0] - x) - h, 2.0 * math.pi)
            curvature = min(max(2.0 * math.sin(alpha) / EXIT_LOOKAHEAD, -1.0 / EXIT_MIN_RADIUS), 1.0 / EXIT_MIN_RADIUS)
            x, y, h = x + v * dt * math.cos(h), y + v * dt * math.sin(h), h + v * dt * curvature
        samples = tuple((float(t), *(float(np.interp(t, fine, poses[:, j])) for j in range(3))) for t in tau)
        return MovingVehicle(other.length, other.width, trajectory=samples, key=other.key)

    def circulates(self, other: MovingVehicle) -> bool:
        """Whether ``other`` drives on the ring: its centre between the curbs, heading within ``RING_HEADING`` of the
        ring's tangent in the circulation direction."""
        ra = self.scenario.ocp.road.roundabout
        x, y, h = other.start
        rx, ry = x - ra.center[0], y - ra.center[1]
        if not ra.inner_radius <= math.hypot(rx, ry) <= ra.outer_radius:
            return False
        tangent = math.atan2(ry, rx) + ra.circulation * math.pi / 2.0
        return abs(math.remainder(h - tangent, 2.0 * math.pi)) <= RING_HEADING

    def along_ring(self, other: MovingVehicle, tau: np.ndarray) -> MovingVehicle:
        """``other`` turned about the ring's centre at its speed, at its radius now (its pose to the ring kept).

        SUMO's ring lane is an arc (5 degree chords and internal lanes at the junctions): a yaw rate
        measured over ``YAW_WINDOW`` there can be near zero, and a constant-yaw-rate prediction then
        drives a circulating car straight out of the ring across the entry (traced: truck right 200
        seed 0, a car at 7.1 m/s with 0.04 rad/s predicted over the truck's give-way line).
        """
        ra = self.scenario.ocp.road.roundabout
        x, y, h = other.start
        cx, cy = ra.center
        radius = max(math.hypot(x - cx, y - cy), 1e-9)
        turn = ra.circulation * other.speed / radius * np.asarray(tau, float)
        c, s = np.cos(turn), np.sin(turn)
        px, py = cx + c * (x - cx) - s * (y - cy), cy + s * (x - cx) + c * (y - cy)
        samples = tuple((float(t), float(a), float(b), float(h + w))
                        for t, a, b, w in zip(tau, px, py, turn, strict=True))  # fmt: skip
        return MovingVehicle(other.length, other.width, trajectory=samples, key=other.key)

    def predicted(self, others: list[MovingVehicle], tau: np.ndarray,
                  exiting: frozenset[str] = frozenset()) -> np.ndarray:  # fmt: skip
        """The predicted corners (n, len(tau), 4, 2) of the vehicles that can come near within the horizon.

        A vehicle is left out when its distance now (between bounding circles of the truck's reach
        and of its rectangle) exceeds what both can close in ``tau[-1]`` seconds plus the safety distance.
        The others are predicted as ``expect`` says (``exiting``: the keys showing the exit side's signal).
        """
        return self._predict(self._near(others, tau), tau, exiting)

    def near(self, others: list[MovingVehicle], tau: np.ndarray) -> list[MovingVehicle]:
        """The vehicles that can come near within the horizon ``tau[-1]`` (``predicted``)."""
        return self._near(others, tau)

    def _near(self, others: list[MovingVehicle], tau: np.ndarray) -> list[MovingVehicle]:
        """The vehicles that can come near within the horizon (``predicted``)."""
        if not others:
            return []
        here = self.plan.at(self.s)
        v = self.scenario.ocp.vehicle
        x, y = (float(here[n][0]) for n in v.position)
        reach = self.reach + self.top_speed * tau[-1] + self.scenario.traffic.safety_distance
        now = [_position_speed(o) for o in others]
        return [o for o, (ox, oy, speed) in zip(others, now, strict=True)
                if math.hypot(ox - x, oy - y) <= reach + speed * tau[-1]
                + 0.5 * math.hypot(o.length, o.width)]  # fmt: skip

    def _predict(self, near: list[MovingVehicle], tau: np.ndarray,
                 exiting: frozenset[str] = frozenset()) -> np.ndarray:  # fmt: skip
        """The predicted corners (n, len(tau), 4, 2) of ``near`` (``expect``)."""
        if not near:
            return np.empty((0, len(tau), 4, 2))
        return np.stack([self.expect(o, tau, o.key in exiting).corners(tau) for o in near])

    def least_distance(self, s: np.ndarray, theirs: np.ndarray) -> float:
        """Least distance between the truck's bodies at plan times ``s`` and the predicted corners ``theirs``."""
        return float(self.clearances(s, theirs).min())

    def clearances(self, s: np.ndarray, theirs: np.ndarray) -> np.ndarray:
        """Per instant, the least distance (m) between the truck's bodies at plan times ``s`` and ``theirs``.

        Parameters
        ----------
        s : numpy.ndarray
            The plan times (T,) the profile reaches at the checked instants.
        theirs : numpy.ndarray
            The predicted corners (n, T, 4, 2) of the other vehicles (``predicted``).

        Returns
        -------
        numpy.ndarray
            (T,) exact rectangle distances, the least over bodies and vehicles; inf without vehicles.
        """
        if len(theirs) == 0:
            return np.full(len(s), math.inf)
        ocp = self.scenario.ocp
        states = self.plan.at(s)
        flat = theirs.reshape(-1, 4, 2)  # vehicle-major: (n * len(s), 4, 2)
        least = np.full(len(s), math.inf)
        for name, body in ocp.bodies.items():
            mine = np.tile(body.corners(*self.body_poses[name](states)), (len(theirs), 1, 1))
            least = np.minimum(least, rectangle_gaps(mine, flat).reshape(len(theirs), len(s)).min(axis=0))
        return least

    def state(self) -> dict[str, float]:
        """The truck's states at the current plan time, and the plan's controls scaled by the rate."""
        v = self.scenario.ocp.vehicle
        row = {k: float(val[0]) for k, val in self.plan.at(self.s).items()}
        for c in v.controls:
            row[c] *= self.rate
        return row


def _krauss_follower(distance: float, speed: float, to_merge: np.ndarray, v_l: np.ndarray, inside: np.ndarray,
                     length: float, step: float, leader_decel: float = LEADER_DECEL) -> float:  # fmt: skip
    """The largest deceleration of a Krauss follower ``distance`` before the merge point behind the truck.

    At each step where the truck is ``inside`` (its front past the give-way line) and its front is
    nearer to the merge point than the follower's (else the follower is ahead), the follower's gap
    is its distance to the merge point minus the truck front's (``to_merge``) minus ``length`` and
    ``FOLLOW_MIN_GAP``; it slows to SUMO's safe follow speed for the truck's speed ``v_l`` and its SUMO
    deceleration ``leader_decel`` (never below
    ``speed`` - ``EMERGENCY_DECEL`` step per step, never faster than ``speed``).
    """
    x, v, worst = 0.0, speed, 0.0
    b, tau = YIELD_DECEL, SUMO_TAU
    for k in range(len(to_merge)):
        if inside[k] and to_merge[k] <= distance - x:  # the truck's front is the nearer to the merge point
            g = distance - x - to_merge[k] - length - FOLLOW_MIN_GAP
            safe = _safe_stop_speed(max(g, 0.0) + v_l[k] ** 2 / (2.0 * leader_decel), b, tau, step)
            new = min(v, max(safe, v - EMERGENCY_DECEL * step, 0.0))
            worst = max(worst, (v - new) / step)
            v = new
        x += v * step
    return worst


def _safe_stop_speed(gap: float, decel: float, headway: float, step: float) -> float:
    """SUMO's ``MSCFModel::maximumSafeStopSpeedEuler``: the speed that stops within ``gap`` (m).

    Braking at ``decel`` every step after a reaction of ``headway`` (SUMO 1.28, Euler update). With
    the leader's braking distance v_l^2 / (2 b_l) added to the gap it is SUMO's
    ``maximumSafeFollowSpeed``, the Krauss model's follow speed.
    """
    g, b = gap - 1e-6, decel * step
    if g <= 0.0:
        return 0.0
    n = math.floor(0.5 - (headway - 0.5 * math.sqrt(step * step + 4.0 * (step * (2.0 * g / b - headway)
                                                                         + headway * headway))) / step)  # fmt: skip
    h = 0.5 * n * (n - 1) * b * step + n * b * headway
    return n * b + (g - h) / (n * step + headway)


def _position_speed(other: MovingVehicle) -> tuple[float, float, float]:
    """Where ``other`` is now and its speed (m/s): its start and speed, or its path's first sample and fastest leg."""
    if other.start is not None:
        return other.start[0], other.start[1], abs(other.speed)
    p = np.asarray(other.trajectory, float)
    legs = np.hypot(np.diff(p[:, 1]), np.diff(p[:, 2])) / np.maximum(np.diff(p[:, 0]), 1e-9)
    return float(p[0, 1]), float(p[0, 2]), float(legs.max(initial=0.0))


def _turn_capped(other: MovingVehicle, tau: np.ndarray) -> MovingVehicle:
    """``other`` at constant speed and yaw rate until it has turned ``MAX_TURN``, then straight on (no circles)."""
    if other.start is None or abs(other.yaw_rate) * float(tau[-1]) <= MAX_TURN:
        return other
    x, y, h = other.start
    v, w = other.speed, other.yaw_rate
    t_turn = MAX_TURN / abs(w)
    a = np.minimum(tau, t_turn)
    heading = h + w * a
    px = x + v / w * (np.sin(heading) - math.sin(h)) + v * np.cos(heading) * (tau - a)
    py = y - v / w * (np.cos(heading) - math.cos(h)) + v * np.sin(heading) * (tau - a)
    samples = tuple((float(t), float(p), float(q), float(g)) for t, p, q, g in zip(tau, px, py, heading, strict=True))
    return MovingVehicle(other.length, other.width, trajectory=samples, key=other.key)


def _integral(r: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of ``r`` over ``tau`` from 0."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(tau))])


def predict(row: tuple, previous_heading: float | None, step: float) -> MovingVehicle:
    """Another vehicle (its traffic.csv row) predicted at constant speed and yaw rate from now.

    The yaw rate is the heading change since ``previous_heading``, its heading ``step`` seconds
    earlier (the driver passes the one ``YAW_WINDOW`` back, or the oldest it saw), over ``step``;
    0 without one.
    """
    _, vid, _, x, y, heading, speed, length, width = row
    yaw = 0.0 if previous_heading is None else math.remainder(heading - previous_heading, 2 * math.pi) / step
    return MovingVehicle(length, width, start=(x, y, heading), speed=speed, yaw_rate=yaw, key=f"traffic {vid}")


__all__ = [
    "COMMITTED_RATE_MIN", "EMERGENCY_DECEL", "EXIT_LOOKAHEAD", "EXIT_MIN_RADIUS", "EXIT_SIGNAL_MIN",
    "EXIT_TURN_ANGLE", "FOLLOWER_DECEL", "FOLLOW_HEADING",
    "FOLLOW_MIN_GAP", "GIVE_WAY_MARGIN", "HORIZON", "LEADER_DECEL", "LINE_SLACK", "MAP_MARGIN", "MARGIN_HORIZON",
    "MAX_TURN", "PREDICTION_MARGIN", "RATE_SLOPE", "RING_HEADING", "SAMPLE", "SUMO_TAU", "TARGETS", "TURNING_IN_COS",
    "YAW_WINDOW",
    "Autopilot", "Plan", "plan_of", "predict",
]  # fmt: skip
