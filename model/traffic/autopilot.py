"""The ``autopilot`` driver: the truck's optimal plan, driven with a speed scaling that gives way.

Strategy ("yield-and-follow by time scaling"): the plan is the scenario's own optimum (solved once,
before the truck appears, as ``roundabout solve`` solves it). The truck stays on the plan's path
and only its progress is chosen: the state at time t is the plan's at plan time s(t), with
ds/dt = r(t) in [0, 1]. For the kinematic models here f(x, r u) = r f(x, u), so the states are
exactly the plan's and the applied controls are the plan's scaled by r: the path, and so every
body's corridor clearance, is the validated plan's.

Each step the autopilot predicts every other vehicle as a ``MovingVehicle`` at constant speed and
yaw rate from its current pose (the yaw rate from its last two headings), and tries the progress
profiles below, from the fastest: keep going at the plan's pace (r -> 1), slow to r = 0.5 and to
r = 0.25, stop before the give-way line (the plan time where the front bumper first comes within
``Ro + GIVE_WAY_MARGIN`` of the centre, only while the truck has not passed it), stand still. A
profile is safe if over the next ``HORIZON`` seconds every body of the truck keeps at least
``safety_distance`` from every predicted rectangle (exact rectangles, shapely); r changes at most
by ``RATE_SLOPE`` per second. The first safe profile is taken; if none is, the one with the
largest least predicted distance. No re-planning: a blocked plan waits (documented as not built).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from model.analysis.bodies import rectangle_gaps
from model.problem.scenario import Scenario
from model.scene.moving import MovingVehicle

HORIZON = 4.0  # s looked ahead
SAMPLE = 0.25  # s between the predicted instants
RATE_SLOPE = 0.5  # 1/s: the largest change of the progress rate per second
GIVE_WAY_MARGIN = 1.0  # m: the truck stops with its front bumper this far outside the outer curb
TARGETS = (1.0, 0.5, 0.25)


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
    s: float = 0.0
    rate: float = 1.0
    decision_seconds: list[float] = field(default_factory=list)
    give_way: float = field(init=False)
    body_poses: dict = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.give_way = self._give_way_time()
        # each body's pose as a numpy function of the states, made once (lambdify is slow; a decision is not)
        v = self.scenario.ocp.vehicle
        poses = v.body_poses()
        self.body_poses = {name: v.state_function(list(poses[name])) for name in self.scenario.ocp.bodies}

    def _give_way_time(self) -> float:
        """Plan time at which the front bumper first comes within Ro + GIVE_WAY_MARGIN of the centre."""
        ra, v = self.scenario.ocp.road.roundabout, self.scenario.ocp.vehicle
        s = np.linspace(0.0, self.plan.duration, 2001)
        st = self.plan.at(s)
        px, py = v.position
        h = st[v.roles.heading]
        r = np.hypot(st[px] + self.front * np.cos(h) - ra.center[0], st[py] + self.front * np.sin(h) - ra.center[1])
        inside = np.nonzero(r <= ra.outer_radius + GIVE_WAY_MARGIN)[0]
        return float(s[inside[0]]) if len(inside) else self.plan.duration

    def profiles(self, step: float) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """The candidate (name, rates, plan times) over the horizon's instants, fastest first."""
        tau = np.arange(0.0, HORIZON + 1e-9, SAMPLE)
        out = []
        for target in TARGETS:
            r = np.clip(target, self.rate - RATE_SLOPE * tau, self.rate + RATE_SLOPE * tau)
            out.append((f"rate {target:g}", r, self.s + _integral(r, tau)))
        if self.s < self.give_way:
            gap = self.give_way - self.s  # plan seconds to the line
            stop_time = 2.0 * gap / max(self.rate, 1e-9)
            r = np.clip(self.rate * (1.0 - tau / stop_time), 0.0, None) if self.rate > 0 else np.zeros_like(tau)
            out.append(("stop at the line", r, np.minimum(self.s + _integral(r, tau), self.give_way)))
        out.append(("stand", np.zeros_like(tau), np.full_like(tau, self.s)))
        return out

    def decide(self, others: list[MovingVehicle], step: float) -> tuple[str, float]:
        """Choose the profile for the next step; advance s and rate; return (name, least predicted distance)."""
        t0 = time.perf_counter()
        best, best_gap = None, -math.inf
        tau = np.arange(0.0, HORIZON + 1e-9, SAMPLE)
        for name, rates, s in self.profiles(step):
            gap = self.least_distance(s, tau, others)
            if gap >= self.scenario.traffic.safety_distance:
                best, best_gap = (name, rates), gap
                break
            if gap > best_gap:
                best, best_gap = (name, rates), gap
        name, rates = best
        new_rate = float(np.interp(step, tau, rates))
        advance = 0.5 * (self.rate + new_rate) * step
        if name in ("stop at the line", "stand") and self.s < self.give_way:
            advance = min(advance, self.give_way - self.s)  # never past the line when it chose to stop
        self.s = min(self.s + advance, self.plan.duration)
        self.rate = new_rate
        self.decision_seconds.append(time.perf_counter() - t0)
        return name, best_gap

    def least_distance(self, s: np.ndarray, tau: np.ndarray, others: list[MovingVehicle]) -> float:
        """Least distance between the truck's bodies at plan times ``s`` and the predictions at ``tau``."""
        if not others:
            return math.inf
        ocp = self.scenario.ocp
        states = self.plan.at(s)
        bodies = {name: body.corners(*self.body_poses[name](states)) for name, body in ocp.bodies.items()}
        theirs = np.concatenate([o.corners(tau) for o in others])  # (len(others) * len(tau), 4, 2)
        least = math.inf
        for corners in bodies.values():
            mine = np.tile(corners, (len(others), 1, 1))
            least = min(least, float(rectangle_gaps(mine, theirs).min()))
        return least

    def state(self) -> dict[str, float]:
        """The truck's states at the current plan time, and the plan's controls scaled by the rate."""
        v = self.scenario.ocp.vehicle
        row = {k: float(val[0]) for k, val in self.plan.at(self.s).items()}
        for c in v.controls:
            row[c] *= self.rate
        return row


def _integral(r: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of ``r`` over ``tau`` from 0."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(tau))])


def predict(row: tuple, previous_heading: float | None, step: float) -> MovingVehicle:
    """Another vehicle (its traffic.csv row) predicted at constant speed and yaw rate from now."""
    _, vid, _, x, y, heading, speed, length, width = row
    yaw = 0.0 if previous_heading is None else math.remainder(heading - previous_heading, 2 * math.pi) / step
    return MovingVehicle(length, width, start=(x, y, heading), speed=speed, yaw_rate=yaw, key=f"traffic {vid}")


__all__ = ["GIVE_WAY_MARGIN", "HORIZON", "Autopilot", "Plan", "RATE_SLOPE", "plan_of", "predict"]
