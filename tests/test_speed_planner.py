"""The ``qp`` speed planner (model/traffic/speed_planner.py): the key, the QP, the s-t graph, the autopilot's guard."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_traffic import ring_car, straight_pilot

from model.errors import InputError
from model.problem.scenario import parse_scenario
from model.traffic.autopilot import Autopilot
from model.traffic.speed_planner import (
    Limits,
    Occupancy,
    SpeedPlanner,
    coarse,
    corridor,
    guide,
    qp_grid,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "traffic-roundabout.toml"
STEP = 0.1


def document() -> dict:
    return tomllib.loads(EXAMPLE.read_text())


def test_the_speed_planner_key_defaults_to_the_rules_and_takes_qp():
    assert parse_scenario(document()).traffic.speed_planner == "rules"
    doc = document()
    doc["traffic"]["speed_planner"] = "qp"
    assert parse_scenario(doc).traffic.speed_planner == "qp"


@pytest.mark.parametrize("value", ["mpc", 1, ""])
def test_an_unknown_speed_planner_names_the_key(value):
    doc = document()
    doc["traffic"]["speed_planner"] = value
    with pytest.raises(InputError, match=r"traffic\.speed_planner"):
        parse_scenario(doc)


def free(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """No occupancy: lower, upper, follower bounds and the follower rows' speed coefficient."""
    return np.full(n, -np.inf), np.full(n, np.inf), np.full(n, -np.inf), np.zeros(n)


def within_limits(p, lim: Limits, tol: float = 1e-6) -> None:
    h = np.diff(p.t)
    assert p.success
    assert np.all(p.a >= lim.a_min - tol) and np.all(p.a <= lim.a_max + tol)
    jerk = np.diff(p.a) / h
    assert np.all(jerk >= lim.j_min - tol) and np.all(jerk <= lim.j_max + tol)
    assert np.all(p.v >= -tol)
    # s and v integrate the piecewise-linear acceleration exactly
    assert np.allclose(np.diff(p.v), 0.5 * h * (p.a[:-1] + p.a[1:]), atol=1e-6)
    assert np.allclose(np.diff(p.s), h * p.v[:-1] + h**2 * (p.a[:-1] / 3 + p.a[1:] / 6), atol=1e-6)


def test_on_a_free_road_the_qp_speeds_up_to_vmax_within_its_acceleration_and_jerk_bounds():
    lim = Limits(-2.0, 1.0, -1.0, 1.0)
    planner = SpeedPlanner(qp_grid(STEP), lim)
    n = planner.n
    p = planner.solve(3.0, 0.0, *free(n), np.full(n, 8.0))
    within_limits(p, lim)
    assert p.v.max() <= 8.0 + 1e-6
    assert p.v[-1] > 7.5  # 8 s: 1 s of jerk, 3 s at 1 m/s^2 reach 7 m/s and more
    assert p.violation < 1e-6


def test_a_yield_keeps_the_truck_behind_the_occupied_interval_and_a_pass_ahead_of_it():
    lim = Limits(-4.0, 4.0)
    planner = SpeedPlanner(qp_grid(STEP), lim)
    n, tau = planner.n, planner.tau
    lower, upper, follower, follow = free(n)
    upper = np.where((tau >= 3.0) & (tau <= 6.0), 20.0, np.inf)  # occupied from 20 m on, 3 s to 6 s
    p = planner.solve(8.0, 0.0, lower, upper, follower, follow, np.full(n, 8.0))
    within_limits(p, lim)
    assert np.all(p.s[(tau >= 3.0) & (tau <= 6.0)] <= 20.0 + 1e-6) and p.violation < 1e-6
    assert p.s[-1] > p.s[tau == 6.0][0]  # it goes on after the window
    lower = np.where((tau >= 2.0) & (tau <= 4.0), 14.0, -np.inf)  # ahead of a vehicle occupying up to 14 m
    p = planner.solve(8.0, 0.0, lower, free(n)[1], follower, follow, np.full(n, 8.0))
    assert np.all(p.s[(tau >= 2.0) & (tau <= 4.0)] >= 14.0 - 1e-6) and p.violation < 1e-6


def test_an_impossible_constraint_is_violated_softly_and_reported():
    lim = Limits(-2.0, 1.0)
    planner = SpeedPlanner(qp_grid(STEP), lim)
    n, tau = planner.n, planner.tau
    lower, upper, follower, follow = free(n)
    upper = np.where(tau >= 1.0, 2.0, np.inf)  # stop within 2 m from 8 m/s at 2 m/s^2: impossible
    p = planner.solve(8.0, 0.0, lower, upper, follower, follow, np.full(n, 8.0))
    within_limits(p, lim)
    assert p.violation > 1.0


def test_the_follower_row_keeps_the_gap_a_braking_follower_needs():
    """s + c v >= need (the linearised follower constraint) at 3 s, with s(3) <= 15 m (a yield): held by
    arriving there fast enough, where the profile without it is slower there."""
    lim = Limits(-4.0, 4.0)
    planner = SpeedPlanner(qp_grid(STEP), lim)
    n, tau = planner.n, planner.tau
    lower, upper, follower, follow = free(n)
    upper = np.where(tau == 3.0, 15.0, np.inf)
    follow = np.full(n, 2.0)
    follower = np.where(tau == 3.0, 30.0, -np.inf)
    at = tau == 3.0
    loose = planner.solve(4.0, 0.0, lower, upper, free(n)[2], free(n)[3], np.full(n, 8.0))
    assert loose.s[at][0] + 2.0 * loose.v[at][0] < 30.0 - 1e-3
    p = planner.solve(4.0, 0.0, lower, upper, follower, follow, np.full(n, 8.0))
    within_limits(p, lim)
    assert p.s[at][0] <= 15.0 + 1e-6 and p.s[at][0] + 2.0 * p.v[at][0] >= 30.0 - 1e-6 and p.violation < 1e-6


def test_the_stop_row_leaves_room_to_stop_braking_at_the_hardest():
    """s + top / (2 |a_min|) v <= stop at the row given: from there braking at a_min stops by ``stop``."""
    lim = Limits(-2.0, 1.0)
    planner = SpeedPlanner(qp_grid(STEP), lim, top=8.0)
    n, tau = planner.n, planner.tau
    stop = np.where(tau == 5.0, 40.0, np.inf)
    loose = planner.solve(8.0, 0.0, *free(n), np.full(n, 8.0))
    at = tau == 5.0
    assert loose.s[at][0] + loose.v[at][0] ** 2 / 4.0 > 40.0  # without it the truck could not stop by 40 m
    p = planner.solve(8.0, 0.0, *free(n), np.full(n, 8.0), stop)
    within_limits(p, lim)
    assert p.s[at][0] + p.v[at][0] ** 2 / 4.0 <= 40.0 + 1e-6 and p.violation < 1e-6


def test_vmax_below_the_speed_now_brakes_as_hard_as_the_limits_allow_not_harder():
    lim = Limits(-2.0, 1.0, -1.0, 1.0)
    planner = SpeedPlanner(qp_grid(STEP), lim)
    n = planner.n
    p = planner.solve(8.0, 0.0, *free(n), np.full(n, 4.0))
    within_limits(p, lim)
    assert p.v[-1] <= 4.0 + 1e-3


def test_coarse_puts_a_pass_at_or_before_and_a_yield_at_or_after_each_fine_instant():
    qp = qp_grid(STEP)
    fine = np.array([0.0, 0.1, 0.25, 0.5, 0.75, 1.0])
    k = np.arange(len(fine))
    assert np.all(qp[coarse(fine, k, qp, "pass")] <= fine + 1e-12)
    assert np.all(qp[coarse(fine, k, qp, "yield")] >= fine - 1e-12)
    assert qp[coarse(fine, k, qp, "pass")][4] == 0.5 and qp[coarse(fine, k, qp, "yield")][4] == 1.0


def graph(blocks: list[tuple[float, float, float, float]], along: list[bool], tau: np.ndarray) -> Occupancy:
    """An s-t graph on arcs 0..80 m with one vehicle per block (t0, t1, s0, s1)."""
    arcs = np.arange(0.0, 80.0 + 1e-9, 0.5)
    blocked = np.zeros((len(blocks), len(tau), len(arcs)), bool)
    for i, (t0, t1, a, b) in enumerate(blocks):
        blocked[i] = ((tau >= t0) & (tau <= t1))[:, None] & ((arcs >= a) & (arcs <= b))[None, :]
    keys = tuple(f"v{i}" for i in range(len(blocks)))
    return Occupancy(arcs, blocked, keys, np.array(along, bool), np.full(len(blocks), 7.0))


@pytest.mark.parametrize("speed,passes", [(13.5, True), (8.0, False)])
def test_the_guide_passes_a_vehicle_it_clears_and_yields_to_one_it_cannot(speed, passes):
    """A vehicle occupying 20-26 m from 2 s to 3 s: the fastest profile at 13.5 m/s is past it at 2 s (pass:
    the corridor's lower bound above 26 m); at 8 m/s it would be inside it at 3 s (yield: the upper bound
    at 20 m)."""
    tau = np.round(np.arange(0.0, 8.0 + 1e-9, 0.25), 9)
    g = graph([(2.0, 3.0, 20.0, 26.0)], [False], tau)
    fast = 13.5 * tau if passes else speed * tau
    restart = 2.0 * tau**2
    path = guide(g, tau, fast, restart, 0.0, None)
    lower, upper = corridor(g, path, 0.0)
    window = (tau >= 2.0) & (tau <= 3.0)
    if passes:
        assert np.all(path[window] > 26.0) and np.all(lower[window] > 26.0) and np.all(np.isinf(upper[window]))
    else:
        assert np.all(path[window] < 20.0) and np.all(upper[window] <= 20.0) and np.all(np.isinf(lower[window]))


def test_before_the_line_the_truck_waits_at_the_line_for_a_crossing_vehicle_but_follows_a_leader():
    tau = np.round(np.arange(0.0, 8.0 + 1e-9, 0.25), 9)
    fast, restart = 8.0 * tau, 2.0 * tau**2
    line = 10.0
    crossing = graph([(3.0, 4.0, 20.0, 26.0)], [False], tau)  # met 10 m past the line, at 3-4 s
    path = guide(crossing, tau, fast, restart, 0.0, line)
    window = (tau >= 3.0) & (tau <= 4.0)
    assert path[window].max() <= line + 1e-9
    leader = graph([(3.0, 4.0, 20.0, 26.0)], [True], tau)
    path = guide(leader, tau, fast, restart, 0.0, line)
    assert path[window].max() > line + 5.0 and np.all(path[window] < 20.0)  # followed into the ring, behind it


# the autopilot with the qp planner: the example's scenario, a straight plan along the entry lane into the ring


def qp_pilot():
    """``straight_pilot`` of test_traffic.py with the qp planner."""
    pilot = straight_pilot()
    scenario = dataclasses.replace(pilot.scenario, traffic=dataclasses.replace(pilot.scenario.traffic,
                                                                               speed_planner="qp"))
    return Autopilot(scenario, pilot.plan, front=6.5)


def test_with_no_traffic_the_qp_drives_the_plans_pace():
    pilot = qp_pilot()
    assert pilot.qp is not None
    for _ in range(5):
        name, _ = pilot.decide([], STEP)
        assert name == "qp"
    assert pilot.rate == pytest.approx(1.0, abs=1e-3)
    assert pilot.s == pytest.approx(5 * STEP, abs=1e-3)


@pytest.mark.parametrize("degrees,enters", [(140.0, False), (60.0, True)])
def test_at_the_line_the_qp_waits_for_a_car_in_its_window_and_enters_a_big_gap(degrees, enters):
    """As the rule-based driver (tests/test_traffic.py): a car 40 degrees upstream, wait; 120 degrees, enter."""
    pilot = qp_pilot()
    pilot.s, pilot.rate = pilot.give_way - 0.01, 0.0
    for _ in range(10):
        name, gap = pilot.decide([ring_car(degrees)], STEP)
    if enters:
        assert pilot.s > pilot.give_way and gap >= 1.0
    else:
        assert pilot.s <= pilot.give_way + 1e-9


def test_a_qp_profile_that_fails_the_autopilots_check_is_overridden(monkeypatch):
    """The guard: a QP answer that drives into a circulating car is not taken; the rules' profile is."""
    from model.traffic.speed_planner import QpDriver

    pilot = qp_pilot()
    pilot.s, pilot.rate = pilot.give_way - 0.01, 1.0

    def reckless(self, others, tau, step, exiting=frozenset()):
        return np.ones_like(tau), np.minimum(self.pilot.s + tau, self.pilot.plan.duration)

    monkeypatch.setattr(QpDriver, "profile", reckless)
    name, _ = pilot.decide([ring_car(150.0)], STEP)
    assert name != "qp"
