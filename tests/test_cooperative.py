"""The cooperative driver's management (issue 45, point 5): windows at the truck's actual progress, and a
priority request only when the truck waits, from vehicles that can be held, once waiting costs more than asking."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from model.traffic.cooperative import Cooperator, PriorityRequest
from model.traffic.windows import Window, clock_windows, progress_time


def test_progress_time_ramps_the_rate_up_at_its_slope_to_the_plans_pace():
    assert progress_time(3.0, rate=1.0, slope=0.5) == pytest.approx(3.0)  # at the plan's pace
    assert progress_time(3.0, rate=0.0, slope=math.inf) == pytest.approx(3.0)  # the old announcement
    # from standing at 0.5 /s: 2 s to reach the pace, covering 1 plan second, then 1 more second per plan second
    assert progress_time(3.0, rate=0.0, slope=0.5) == pytest.approx(4.0)
    assert progress_time(0.25, rate=0.0, slope=0.5) == pytest.approx(1.0)  # 0.25 = 0.5 * 0.5 * t^2 at t = 1 s
    assert progress_time(-1.0, rate=0.0, slope=0.5) == 0.0


def test_clock_windows_of_a_standing_truck_open_later_than_at_the_plans_pace():
    windows = [Window(0, 2.0, 5.0), Window(1, 4.0, 7.0), Window(2, 0.0, 1.0)]
    paced = clock_windows(windows, now=10.0, s=1.0)
    standing = clock_windows(windows, now=10.0, s=1.0, rate=0.0, slope=0.5)
    assert [w.leg for w in paced] == [0, 1]  # the window behind plan time 1 s is gone
    assert paced[0] == Window(0, 11.0, 14.0)
    assert standing[0] == Window(0, 12.0, 15.0)  # 1 plan second takes 2 s from standing, then the pace
    assert all(a.start < b.start and a.end < b.end for a, b in zip(paced, standing, strict=True))


@dataclass
class StubCooperator(Cooperator):
    """A ``Cooperator`` without SUMO: fixed asks and hold cost; the commands it would send are kept."""

    fixed: dict[str, float] = field(default_factory=dict)
    cost: float = 0.0

    def __post_init__(self) -> None:
        self.windows = [Window(0, 1.0, 4.0), Window(1, 3.0, 6.0)]
        self.areas = {}

    def asks(self, traci, now, windows, truck="truck", holds=None):
        return dict(self.fixed) if any(w.leg == 0 for w in windows) else {}

    def hold_cost(self, traci, now, speeds, windows):
        return self.cost

    def command(self, traci, speeds):
        sent = speeds | {vid: -1.0 for vid in sorted(set(self.commanded) - set(speeds))}
        self.commanded = dict(speeds)
        return sent


@dataclass
class StubPilot:
    """The autopilot's progress; no vehicle predicted near (``blockers`` finds none, ``clears`` passes)."""

    s: float
    rate: float
    rate_slope: float = 0.5
    give_way: float = 2.0

    def instants(self, step):
        return np.array([0.0, step, 0.5])

    def near(self, others, tau):
        return []

    def predicted(self, others, tau):
        return np.empty((0, len(tau), 4, 2))

    def clearances(self, s, theirs):
        return np.full(len(s), math.inf)

    def net_gap(self, tau, s, gaps):
        return math.inf

    def follower_braking(self, tau, rates, s, theirs):
        return 0.0

    def junction_conflict(self, tau, s, theirs):
        return False

    @property
    def scenario(self):
        return SimpleNamespace(traffic=SimpleNamespace(safety_distance=1.0))


def request(fixed: dict[str, float], cost: float) -> PriorityRequest:
    coop = StubCooperator(ocp=None, plan_at=None, duration=8.0, step=0.1, fixed=fixed, cost=cost)
    return PriorityRequest(coop, enter=0, appeared=0.0)


def test_a_truck_at_its_plans_pace_holds_no_one():
    manager = request({"car": 3.0}, cost=0.0)
    assert manager.step(None, now=1.0, pilot=StubPilot(s=1.1, rate=1.0)) == {}
    assert not manager.granted


def test_a_waiting_truck_asks_only_once_it_has_lost_what_the_hold_costs():
    manager = request({"car": 3.0}, cost=1.5)
    assert manager.step(None, now=1.0, pilot=StubPilot(s=0.6, rate=0.4)) == {}  # lost 0.5 s < 1.5 s
    assert manager.step(None, now=2.0, pilot=StubPilot(s=0.6, rate=0.0)) == {"car": 3.0}  # lost 1.5 s
    assert manager.granted
    assert manager.reasons == {"the hold costs more than the time lost": 1, "asked": 1}


def test_a_granted_request_stays_past_the_line_and_releases_when_the_entry_area_is_passed():
    manager = request({"car": 3.0}, cost=0.0)
    assert manager.step(None, now=1.0, pilot=StubPilot(s=1.0, rate=0.5)) == {"car": 3.0}
    assert manager.step(None, now=2.0, pilot=StubPilot(s=3.0, rate=1.0)) == {"car": 3.0}  # past the line at pace
    assert manager.step(None, now=3.0, pilot=StubPilot(s=4.5, rate=1.0)) == {"car": -1.0}  # entry area passed
    assert manager.step(None, now=3.1, pilot=StubPilot(s=4.6, rate=1.0)) == {}


def test_a_request_that_would_hold_no_one_is_not_made():
    manager = request({}, cost=0.0)
    assert manager.step(None, now=5.0, pilot=StubPilot(s=0.5, rate=0.0)) == {}
    assert not manager.granted
    assert manager.reasons == {"no vehicle to hold": 1}


def test_swept_areas_are_the_part_of_each_legs_area_the_truck_covers():
    """Straight in along leg 0 and parked in the ring: leg 0's swept area holds the truck's path across the curb,
    not the ring upstream of its entry (where a circulating car can still be held), and is inside leg 0's area."""
    import shapely

    from model.problem.scenario import load_scenario

    ocp = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "traffic-roundabout.toml").ocp

    def straight(s):  # from x = -40 m at 5 m/s, stopping with the rear axle at x = -22 m (front in the ring)
        s = np.minimum(np.atleast_1d(np.asarray(s, float)), 3.6)
        return {"x": -40.0 + 5.0 * s, "y": 0 * s, "theta": 0 * s, "phi": 0 * s}

    whole = Cooperator(ocp, straight, duration=4.0, step=0.1)
    swept = Cooperator(ocp, straight, duration=4.0, step=0.1, swept=True)
    ra = ocp.road.roundabout
    mid = (ra.inner_radius + ra.outer_radius) / 2
    upstream = shapely.Point(mid * math.cos(math.radians(140.0)), mid * math.sin(math.radians(140.0)))
    assert whole.areas[0].contains(upstream) and not swept.areas[0].contains(upstream)
    assert swept.areas[0].contains(shapely.Point(-ra.outer_radius + 0.5, 0.0))  # the truck's front in the ring
    assert swept.areas[0].difference(whole.areas[0]).area < 1e-9
    assert swept.areas[2].is_empty  # never near the far leg


def test_a_hold_that_does_not_get_the_truck_going_never_costs_more_than_the_truck_has_lost():
    """Two cars held for a truck that stays standing: the vehicle-seconds held grow twice as fast as its lost time,
    so the hold is refused whenever they have caught up (rent or buy: holding never outspends waiting)."""
    manager = request({"a": 0.0, "b": 0.0}, cost=0.0)
    granted = []
    for k in range(30):
        now = 1.0 + 0.1 * k
        manager.step(None, now=now, pilot=StubPilot(s=1.0, rate=0.0))
        granted.append(manager.granted)
        assert manager.spent <= manager.lost(now, StubPilot(s=1.0, rate=0.0)) + 0.2 + 1e-9  # one step's hold
    assert granted[0] and not all(granted)
    assert manager.reasons["the hold costs more than the time lost"] == granted.count(False)


def test_a_blocker_is_asked_to_stand_where_it_is_and_named_by_its_sumo_id():
    from model.scene.moving import MovingVehicle
    from model.traffic.cooperative import standing, sumo_id

    car = MovingVehicle(4.5, 1.8, start=(1.0, 2.0, 0.5), speed=8.0, yaw_rate=0.1, key="traffic f1_3.1")
    still = standing(car)
    assert sumo_id(still) == "f1_3.1" and still.start == car.start
    tau = np.array([0.0, 1.0, 5.0])
    assert np.allclose(still.pose(tau)[0], 1.0) and np.allclose(still.pose(tau)[1], 2.0)


def test_no_request_when_the_held_vehicles_standing_would_still_not_let_the_truck_go():
    """A follower the truck's entry would make brake hard even with the held vehicles standing: waiting is kept."""

    @dataclass
    class Followed(StubPilot):
        def follower_braking(self, tau, rates, s, theirs):
            return 9.0

    manager = request({"car": 0.0}, cost=0.0)
    assert manager.step(None, now=5.0, pilot=Followed(s=0.5, rate=0.0)) == {}
    assert manager.reasons == {"holding would not clear the way": 1}
