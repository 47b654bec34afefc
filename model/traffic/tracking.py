"""What the autopilot commands is what the truck does: held controls per step, the vehicle's own dynamics integrated.

The autopilot (``model.traffic.autopilot``) chooses, each step, how far along its plan the truck
should be at the step's end (plan time ``s``). ``Tracker`` turns that into the controls held over
the step and integrates the vehicle's dynamics (``vehicle.rhs_function()``, scipy's DOP853) under
them: the integrated state is where the truck is (SUMO's ``moveToXY``) and the next row of
``trajectory.csv``; each row holds the states at t and the controls that act until the next row.

The controls (each clipped to the scenario's bounds):

- progress: with the speed as a control, the mean speed that covers the reference point's path
  length from where the truck is (its projection on the plan's path) to where the plan is at
  the step's end. With the speed as a state (``[vehicle.longitudinal]``) the truck cannot jump to
  the pace asked for, so its progress is where it is (the autopilot re-anchors its plan time at the
  truck's projection each step, ``locate``) and what is tracked is the speed asked for, the plan's
  speed there times the progress rate: the acceleration that reaches it by the step's end (within
  the acceleration bounds and the speed's); with a jerk limit, the jerk that drives the speed and
  acceleration errors down with both poles at -1 / ``SPEED_TIME`` from the acceleration that speed
  needs, the acceleration kept where the jerk bound can still stop it before the speed leaves its
  bounds. A jerk-limited truck follows a plan that is itself at its jerk bound only approximately
  (the speed lags where the plan switches its jerk), so with a lateral acceleration bound the speed
  asked for is also at most the one that keeps ``CORNER_SHARE`` of it along the path
  ``CORNER_LOOKAHEAD`` plan seconds ahead (the speed planner of issue 45 is to give profiles the
  truck can follow);
- steering: the plan's steering angle at the step's end, corrected for the reference point's
  lateral and heading error from the plan's path (a critically damped decay over the path length
  ``TRACK_LENGTH``, the curvature change turned into a steering change by the model's own
  d(curvature)/d(steering) at the current state), reached over the step by the steering rate; a
  model without a steering angle turns at the plan's heading change plus that correction.

The plan's path is its nodes integrated each interval from its node under the plan's controls
(``model.analysis.validation.one_step_columns``, ``REFERENCE_STEPS`` samples per interval): the
straight chords between the nodes are not a path the truck can drive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model.analysis.validation import one_step_columns
from model.problem.ocp import LATERAL, OCP

TRACK_LENGTH = 6.0  # m: the lateral error's critically damped decay length along the path
SPEED_TIME = 1.0  # s: with a jerk limit, the speed error's time constant
CORNER_LOOKAHEAD = 3.0  # plan s: the speed asked for keeps the lateral acceleration bound this far along the path
CORNER_SHARE = 0.9  # of the lateral bound the speed asked for may use (the rest: the steering's corrections)
REFERENCE_STEPS = 20  # samples of the plan's integrated path per interval
PROJECT_WINDOW = 2.0  # s of plan time either side of the last projection searched for the nearest point
RTOL, ATOL = 1e-10, 1e-12  # the step's integration tolerances (DOP853)


@dataclass
class Reference:
    """The plan's integrated motion: dense plan times, states, controls, and the reference point's path length."""

    t: np.ndarray
    columns: dict[str, np.ndarray]
    position: tuple[str, str]  # the vehicle's position states (``roles.position``)
    arc: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        x, y = (self.columns[n] for n in self.position)
        self.arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])

    def at(self, s: float) -> dict[str, float]:
        """Every column linearly interpolated at plan time ``s`` (clipped to the plan)."""
        s = min(max(float(s), 0.0), float(self.t[-1]))
        return {k: float(np.interp(s, self.t, v)) for k, v in self.columns.items()}

    def arc_at(self, s: float) -> float:
        """The reference point's path length (m) at plan time ``s``."""
        return float(np.interp(min(max(float(s), 0.0), float(self.t[-1])), self.t, self.arc))

    def time_at(self, arc: float) -> float:
        """The first plan time at which the reference point's path length reaches ``arc`` (clipped to the plan)."""
        k = int(np.searchsorted(self.arc, arc, side="left"))
        if k <= 0:
            return float(self.t[0])
        if k >= len(self.t):
            return float(self.t[-1])
        a0, a1 = self.arc[k - 1], self.arc[k]
        w = (arc - a0) / (a1 - a0) if a1 > a0 else 1.0
        return float(self.t[k - 1] + w * (self.t[k] - self.t[k - 1]))

    def project(self, x: float, y: float, near: float) -> float:
        """The plan time of the point of the path nearest (x, y), searched within ``PROJECT_WINDOW`` of ``near``."""
        k0, k1 = np.searchsorted(self.t, [near - PROJECT_WINDOW, near + PROJECT_WINDOW])
        k0, k1 = max(int(k0) - 1, 0), min(int(k1) + 1, len(self.t))
        px, py = (self.columns[n][k0:k1] for n in self.position)
        if k1 - k0 < 2:
            return float(self.t[k0])
        ax, ay, dx, dy = px[:-1], py[:-1], np.diff(px), np.diff(py)
        seg = np.maximum(dx * dx + dy * dy, 1e-18)
        w = np.clip(((x - ax) * dx + (y - ay) * dy) / seg, 0.0, 1.0)
        d = np.hypot(ax + w * dx - x, ay + w * dy - y)
        k = int(np.argmin(d))
        return float(self.t[k0 + k] + w[k] * (self.t[k0 + k + 1] - self.t[k0 + k]))


def reference_of(ocp: OCP, t: np.ndarray, columns: dict[str, np.ndarray]) -> Reference:
    """The plan (node times ``t``, its state and control ``columns``) integrated between its nodes."""
    v = ocp.vehicle
    paths = one_step_columns(ocp, {"t": t, **columns}, REFERENCE_STEPS)
    t = np.asarray(t, float)
    if paths is None:  # the integration failed: the nodes themselves
        return Reference(t, {n: np.asarray(columns[n], float) for n in [*v.states, *v.controls]}, v.position)
    fraction = np.linspace(0.0, 1.0, REFERENCE_STEPS + 1)[:-1]
    dense_t = np.concatenate([(t[:-1, None] + np.diff(t)[:, None] * fraction).ravel(), t[-1:]])
    cols = {n: np.concatenate([paths[i, :, :-1].ravel(), [columns[n][-1]]]) for i, n in enumerate(v.states)}
    for c in v.controls:
        cols[c] = np.interp(dense_t, t, np.asarray(columns[c], float))
    return Reference(dense_t, cols, v.position)


@dataclass
class Tracker:
    """The truck's true state, moved one step at a time under held controls (``controls``, ``advance``)."""

    ocp: OCP
    reference: Reference
    x: np.ndarray = field(init=False)
    where: float = 0.0  # the plan time of the truck's projection on the path
    aim: float = 0.0  # the plan time asked for at the end of the last step: the reference now
    rate: float = 1.0  # the progress rate asked for then
    direction: float = 1.0  # 1 forward along the plan, -1 backward
    f: object = field(init=False, repr=False)
    lateral: np.ndarray | None = field(init=False, repr=False)  # |lateral acceleration| per (m/s)^2 along the path
    lateral_bound: float = field(init=False)  # m/s^2: the smaller magnitude of [bounds] lateral_acceleration

    def __post_init__(self) -> None:
        self.f = self.ocp.vehicle.rhs_function()
        self.lateral, self.lateral_bound = None, math.inf
        v = self.ocp.vehicle
        bound = self.ocp.bounds.get(LATERAL)
        if bound is not None and v.roles.speed in v.states and v.lateral_acceleration is not None:
            unit = dict(self.reference.columns) | {v.roles.speed: np.ones_like(self.reference.t)}
            self.lateral = np.abs(v.state_function([v.lateral_acceleration])(unit)[0])
            self.lateral_bound = min(-bound[0], bound[1])
        self.appear()

    def appear(self) -> None:
        """The truck at the plan's start."""
        start = self.reference.at(0.0)
        self.x = np.array([start[n] for n in self.ocp.vehicle.states])
        self.where = self.aim = 0.0

    def locate(self) -> float:
        """The plan time of the point of the plan's path nearest the truck's reference point now."""
        r = self.ocp.vehicle.roles
        state = self.state()
        return self.reference.project(state[r.x], state[r.y], self.where)

    def state(self) -> dict[str, float]:
        """The truck's states by name."""
        return dict(zip(self.ocp.vehicle.states, self.x.tolist(), strict=True))

    def speed(self, u: np.ndarray) -> float:
        """The speed (the speed role's value: a state or a held control), m/s."""
        v = self.ocp.vehicle
        name = v.roles.speed
        return float(self.x[v.states.index(name)] if name in v.states else u[v.controls.index(name)])

    def _bound(self, name: str, value: float) -> float:
        lo, hi = self.ocp.bounds.get(name, (-math.inf, math.inf))
        return float(min(max(value, lo), hi))

    def controls(self, target: float, rate: float, step: float) -> np.ndarray:
        """The controls to hold over the next ``step`` seconds so that the truck reaches plan time ``target``.

        Parameters
        ----------
        target : float
            The plan time the autopilot wants the truck at by the step's end.
        rate : float
            The progress rate (plan seconds per second) it wants there.
        step : float
            The step, s.

        Returns
        -------
        numpy.ndarray
            The controls in the model's order, within their bounds.
        """
        v, ref = self.ocp.vehicle, self.reference
        r, names = v.roles, v.states
        state = self.state()
        self.where = ref.project(state[r.x], state[r.y], self.where)
        here, there = ref.at(self.where), ref.at(target)
        self.direction = direction = 1.0 if there[r.speed] >= 0.0 else -1.0
        u = np.array([there[c] for c in v.controls], float)  # the plan's controls: the default of any other control
        self._progress(u, state, target, rate, step)
        self.aim, self.rate = target, rate
        if r.speed in names:  # steer for where the truck gets to under these controls, not where it was asked to
            there = ref.at(ref.time_at(ref.arc_at(self.where) + direction * self._travel(u, state, step)))
        h = state[r.heading]
        ex, ey = state[r.x] - here[r.x], state[r.y] - here[r.y]
        lateral = -math.sin(here[r.heading]) * ex + math.cos(here[r.heading]) * ey  # left of the path: > 0
        heading = math.remainder(h - here[r.heading], 2.0 * math.pi)
        bend = -(lateral / TRACK_LENGTH**2 + 2.0 * direction * math.sin(heading) / TRACK_LENGTH)  # 1/m
        if r.steering is not None and r.steering_rate is not None:
            phi = state[r.steering]
            goal = self._bound(r.steering, there[r.steering] + bend / self._curvature_slope(names.index(r.steering)))
            u[v.controls.index(r.steering_rate)] = self._bound(r.steering_rate, (goal - phi) / step)
        elif r.turn_rate is not None:
            turn = math.remainder(there[r.heading] - h, 2.0 * math.pi) / step + self.speed(u) * bend
            u[v.controls.index(r.turn_rate)] = self._bound(r.turn_rate, turn)
        return u

    def _progress(self, u: np.ndarray, state: dict[str, float], target: float, rate: float, step: float) -> None:
        """The longitudinal control in ``u``: the speed, or the acceleration, or the jerk (module docstring)."""
        v, ref = self.ocp.vehicle, self.reference
        r = v.roles
        if r.speed in v.controls:  # the speed control: the mean speed that reaches the plan time asked for
            distance = ref.arc_at(target) - ref.arc_at(self.where)
            u[v.controls.index(r.speed)] = self._bound(r.speed, self.direction * distance / step)
            return
        # with the speed a state the truck's progress is where it is (``locate``: the autopilot re-anchors its
        # plan time there each step), and what is tracked is the speed the autopilot asks for along the plan
        then = ref.at(target)
        speed, accel = state[r.speed], state.get(r.acceleration, 0.0)
        wanted = min(rate * then[r.speed], self._corner_speed(target))
        if r.acceleration in v.controls:  # the speed asked for at the step's end, reached over the step
            lo, hi = self._speed_window(speed, step)
            u[v.controls.index(r.acceleration)] = self._bound(r.acceleration, min(max((wanted - speed) / step, lo), hi))
            return
        if r.jerk is None or r.jerk not in v.controls:
            return
        # the acceleration the speed asked for along the path needs at the truck's speed (d(wanted)/dt = rate
        # a_plan v / v_plan), and the speed and acceleration errors decaying with both poles at -1 / SPEED_TIME
        slope = (rate - self.rate) / step
        pace = speed / then[r.speed] if abs(then[r.speed]) > 0.5 else rate
        feed = rate * pace * then[r.acceleration] + slope * then[r.speed]
        lam = 1.0 / SPEED_TIME
        jerk = 2.0 * lam * (feed - accel) + lam * lam * (wanted - speed)
        next_a = self._bound(r.acceleration, self._within_speed(accel + jerk * step, speed, accel, step))
        u[v.controls.index(r.jerk)] = self._bound(r.jerk, (next_a - accel) / step)

    def _corner_speed(self, target: float) -> float:
        """The highest speed (m/s) whose lateral acceleration stays within its bound along the plan's path from
        ``target`` to ``CORNER_LOOKAHEAD`` plan seconds ahead (the path's own steering angles); inf without one."""
        if self.lateral is None:
            return math.inf
        ref = self.reference
        ahead = (ref.t >= target) & (ref.t <= target + CORNER_LOOKAHEAD)
        per_speed = float(self.lateral[ahead].max(initial=0.0))  # |a_lat| at unit speed
        return math.sqrt(CORNER_SHARE * self.lateral_bound / per_speed) if per_speed > 1e-9 else math.inf

    def _travel(self, u: np.ndarray, state: dict[str, float], step: float) -> float:
        """The path length the speed state covers over the step under ``u`` (constant acceleration or jerk)."""
        v = self.ocp.vehicle
        r = v.roles
        speed = state[r.speed]
        if r.acceleration in v.controls:
            return speed * step + 0.5 * u[v.controls.index(r.acceleration)] * step**2
        jerk = u[v.controls.index(r.jerk)] if r.jerk in v.controls else 0.0
        return speed * step + 0.5 * state.get(r.acceleration, 0.0) * step**2 + jerk * step**3 / 6.0

    def _within_speed(self, goal: float, speed: float, accel: float, step: float) -> float:
        """``goal`` (the acceleration at the step's end) limited so that the jerk bound can still bring the
        acceleration to 0 before the speed leaves its bounds (from the speed at the step's end)."""
        r = self.ocp.vehicle.roles
        j_lo, j_hi = self.ocp.bounds.get(r.jerk, (-math.inf, math.inf))
        v_lo, v_hi = self.ocp.bounds.get(r.speed, (-math.inf, math.inf))
        a = goal
        for _ in range(3):  # a fixed point: the limit depends on the speed at the step's end, which depends on a
            ahead = speed + 0.5 * (accel + a) * step
            if math.isfinite(v_lo) and j_hi > 0:
                a = max(a, -math.sqrt(2.0 * j_hi * max(ahead - v_lo, 0.0)))
            if math.isfinite(v_hi) and j_lo < 0:
                a = min(a, math.sqrt(2.0 * -j_lo * max(v_hi - ahead, 0.0)))
        return a

    def _speed_window(self, speed: float, step: float) -> tuple[float, float]:
        """The accelerations that keep the speed within its bounds over the step."""
        lo, hi = self.ocp.bounds.get(self.ocp.vehicle.roles.speed, (-math.inf, math.inf))
        return (lo - speed) / step, (hi - speed) / step

    def _curvature_slope(self, i_steer: int) -> float:
        """d(curvature)/d(steering) of the heading at the current state (the model's own), at least 1e-3 1/m/rad."""
        v = self.ocp.vehicle
        r = v.roles
        u = np.zeros(len(v.controls))
        x = self.x.copy()
        if r.speed in v.controls:
            u[v.controls.index(r.speed)] = 1.0
        else:
            x[v.states.index(r.speed)] = 1.0
            if r.acceleration in v.states:
                x[v.states.index(r.acceleration)] = 0.0
        i_h, eps = v.states.index(r.heading), 1e-5
        hi, lo = x.copy(), x.copy()
        hi[i_steer] += eps
        lo[i_steer] -= eps
        slope = (self.f(hi, u)[i_h] - self.f(lo, u)[i_h]) / (2.0 * eps)
        return float(slope) if abs(slope) > 1e-3 else math.copysign(1e-3, slope if slope else 1.0)

    def advance(self, u: np.ndarray, step: float) -> np.ndarray:
        """Integrate the vehicle's dynamics over ``step`` under the held ``u`` from the current state; the new state."""
        from scipy.integrate import solve_ivp  # here, not at import: see model/nlp/imports.py

        sol = solve_ivp(lambda _, y: self.f(y, u), (0.0, step), self.x, method="DOP853", rtol=RTOL, atol=ATOL)
        self.x = sol.y[:, -1].copy()
        return self.x


__all__ = ["CORNER_LOOKAHEAD", "CORNER_SHARE", "REFERENCE_STEPS", "SPEED_TIME", "TRACK_LENGTH", "Reference", "Tracker",
           "reference_of"]
