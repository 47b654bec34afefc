"""Continuation in the geometry and the three-point start for tight road problems (issue 22, item 2)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from model.problem.scenario import load_scenario
from model.search import geometry_continuation as gc
from model.search.context import Search
from model.search.starts import THREE_POINT, start_values
from tests.conftest import ROOT

TIGHT = ROOT / "benchmarks" / "limits" / "eu-annulus-uturn.toml"


@pytest.fixture(scope="module")
def ocp():
    return load_scenario(TIGHT).ocp


def test_scale_zero_is_the_scenario_and_scale_one_is_roomier(ocp):
    assert gc.relaxed_ocp(ocp, 0.0) is ocp
    rb, big = ocp.road.roundabout, gc.relaxed_ocp(ocp, 1.0).road.roundabout
    assert big.outer_radius == pytest.approx(rb.outer_radius + gc.RELAX_OUTER)
    assert big.inner_radius < rb.inner_radius and big.island_radius >= gc.MIN_ISLAND
    assert big.apron_use == "all"
    assert all(b.lane_width > a.lane_width for a, b in zip(rb.legs, big.legs, strict=True))


def test_relaxed_roads_keep_the_scenarios_poses_along_the_legs(ocp):
    """The start and goal distances move with the outer curb: the poses stay on the same leg points."""
    for scale in (1.0, 0.5, 0.25):
        road = gc.relaxed_ocp(ocp, scale).road
        for mine, theirs in ((road.start(), ocp.road.start()), (road.goal(), ocp.road.goal())):
            assert mine[2] == pytest.approx(theirs[2])
            # along the leg axis the same point; across, the middle of a wider lane
            assert math.hypot(mine[0] - theirs[0], mine[1] - theirs[1]) <= gc.RELAX_LANE * scale / 2 + 1e-9


def test_each_relaxed_corridor_contains_the_scenarios(ocp):
    import shapely

    from model.scene.roundabout import corridor_shape

    own = corridor_shape(ocp.road.roundabout, ocp.road.route, apron=False).polygon()
    for scale in (1.0, 0.25):
        road = gc.relaxed_ocp(ocp, scale).road
        big = corridor_shape(road.roundabout, road.route, apron=True).polygon()
        assert shapely.difference(own, big).area < 1e-6 * own.area


def _fake(ok_from: float):
    """A stand-in step: validates on roads relaxed by at least ``ok_from``; records the scales asked."""
    asked = []

    def step(problem, last):
        scale = float(problem.name.rsplit("x", 1)[1].rstrip(")")) if "relaxed" in problem.name else 0.0
        asked.append((scale, last is not None))
        ok = scale >= ok_from
        return SimpleNamespace(ok=ok, status="optimal" if ok else "infeasible", objective=10.0 + scale)

    return step, asked


def test_the_walk_reaches_the_scenario_warm_from_each_step(ocp):
    step, asked = _fake(0.0)
    found, record = gc.shrink_road(ocp, step, lambda line: None, lambda: False)
    assert found is not None and found.ok and found.objective == 10.0
    assert [s for s, _ in asked] == list(gc.SCALES)
    assert [warm for _, warm in asked] == [False] + [True] * (len(gc.SCALES) - 1)
    assert record["least_validated_scale"] == 0.0


def test_a_failed_step_is_halved_and_an_unreachable_road_is_not_validated(ocp):
    step, asked = _fake(0.3)  # 1 and 0.5 pass, 0 fails: 0.25 fails, then 0.375 ...
    found, record = gc.shrink_road(ocp, step, lambda line: None, lambda: False)
    scales = [s for s, _ in asked]
    assert scales[:5] == [1.0, 0.5, 0.0, 0.25, 0.375]
    assert found is not None and not found.ok  # the scenario's road answered once, not validated
    assert 0.3 <= record["least_validated_scale"] < 0.375


def test_the_walk_stops_when_the_budget_is_spent(ocp):
    step, asked = _fake(0.0)
    calls = iter([False, True])
    found, _ = gc.shrink_road(ocp, step, lambda line: None, lambda: next(calls))
    assert found is None and len(asked) == 1


def test_the_three_point_start_reverses_in_the_ring_and_keeps_its_ends(ocp):
    values = start_values(ocp, 60, "none", None, 1.0, THREE_POINT)
    r = ocp.vehicle.roles
    u = values.values[r.speed]
    assert (u < 0).any() and (u > 0).any()  # forward, reverse, forward
    signs = np.sign(u[np.abs(u) > 1e-9])
    assert np.count_nonzero(np.diff(signs)) == 2  # two cusps
    x0, y0, _ = ocp.road.start()
    assert values.values[r.x][0] == pytest.approx(x0) and values.values[r.y][0] == pytest.approx(y0)
    gx, gy, _ = ocp.road.goal()
    assert values.values[r.x][-1] == pytest.approx(gx) and values.values[r.y][-1] == pytest.approx(gy)
    assert values.final_time > 0


def test_a_run_cap_is_no_stop_of_the_search(ocp):
    """A run ended by run_cap with time left leaves the search running (the time limit did not pass)."""
    search = Search(ocp, 10, time_limit=1000.0, run_cap=1.0)
    assert not search.expired() and search.remaining() > 900


def test_the_reserve_ends_the_search_early_but_the_limit_is_reported(ocp):
    search = Search(ocp, 10, time_limit=100.0, reserve=20.0)
    assert search.deadline == pytest.approx(search.started + 80.0)
    assert search.record_of_search("default")["time_limit"] == 100.0
