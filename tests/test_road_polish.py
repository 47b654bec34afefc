"""The second opinion on road answers that reverse (model.search.road_polish)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from model.problem.scenario import parse_scenario
from model.search.road_polish import reverses
from model.vehicles import Truck

# the SU-30's U-turn on a three-leg roundabout (benchmarks/bench_road_suite.py): the discs' cold
# starts reverse away from the roundabout and back (49-54 s on N = 60); a forward U-turn takes 15.8 s
U_TURN = {
    "name": "su30-u-turn",
    "vehicle": {"preset": "SU-30"},
    "bounds": {"u1": [-10.0, 10.0], "u2": [-0.5, 0.5]},
    "roundabout": {
        "center": [0.0, 0.0], "inscribed_diameter": 44.0, "circulatory_width": 6.0, "apron_width": 2.0,
        "apron_use": "all", "traffic": "right",
        "legs": [{"angle": a, "lane_width": 4.0, "entry_radius": 15.0, "exit_radius": 20.0} for a in (180, 270, 0)],
    },
    "route": {"enter": 0, "exit": 3, "start_distance": 30.0, "goal_distance": 30.0},
    "problem": {"objective": "time", "intervals": 60},
}  # fmt: skip


class _Answer:
    def __init__(self, u1):
        self.ocp = SimpleNamespace(vehicle=Truck())  # reverses() reads the vehicle's speed control (roles.speed)
        self.columns = {"u1": np.asarray(u1, dtype=float)}


def test_reverses_needs_a_real_sign_change():
    assert reverses(_Answer([1.0, 5.0, -1.0, 2.0]))
    assert not reverses(_Answer([1.0, 5.0, -0.01, 2.0]))  # noise around a stop
    assert not reverses(_Answer([0.0, 3.0, 9.0]))


def test_u_turn_is_driven_forwards():
    sol = parse_scenario(U_TURN).ocp.solve(intervals=60)
    assert sol.ok
    assert sol.objective < 17.0  # the discs' cold starts alone: 26.27 s after the 2N re-solve
    assert any(a["route"].startswith("second opinion") for a in sol.attempts)


class _Solved:
    """A stand-in answer: ``ok`` as given, the formulation it was built with."""

    def __init__(self, ok: bool, formulation: str):
        self.ok, self.formulation, self.diagnosis = ok, formulation, None


def _failing_search(formulation: str, calls: list):
    """A search of the U-turn whose every solve fails except with the corners (records formulation, relax)."""
    from model.search.context import Search

    search = Search(parse_scenario(U_TURN).ocp, 20, formulation=formulation)

    def fake_solve(intervals, passing, starts, extra=None, relax=False, analyse=True, formulation=None):
        kind = formulation or search.formulation
        calls.append((kind, relax))
        if relax:
            raise RuntimeError("stop: the minimal-violation solve was reached")
        return [_Solved(kind == "corners", kind)]

    search.solve = fake_solve
    return search


def test_failed_road_tries_the_corners_before_the_minimal_violation_solve():
    """Every discs start failed: the corners formulation is tried on the same start, and its answer is kept."""
    from model.search.road import failed_road

    calls = []
    search = _failing_search("discs", calls)
    got = failed_road(search, _Solved(False, "discs"), start=object())
    assert got.ok and got.formulation == "corners" and calls == [("corners", False)]
    assert got.diagnosis["via"] == "corners formulation"
    assert search.formulation == "discs"  # the search's own formulation is untouched


def test_a_corners_search_goes_straight_to_the_minimal_violation_solve():
    """The search's formulation is already "corners": no second try with it, the relaxed solve is next."""
    from model.search.road import failed_road

    calls = []
    with pytest.raises(RuntimeError, match="minimal-violation"):
        failed_road(_failing_search("corners", calls), _Solved(False, "corners"), start=object())
    assert calls == [("corners", True)]
