"""The second opinion on road answers that reverse (model.search.road_polish)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

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


def test_failed_road_tries_the_corners_before_the_minimal_violation_solve(monkeypatch):
    """Every discs start failed: the corners formulation is tried on the same start, and its answer is kept."""
    import model.search.diagnosis as diagnosis
    from model.direct import bodies

    calls = []

    def fake_solve_starts(ocp, intervals, passing, starts, options=None, relax=False):
        calls.append((bodies.FORMULATION, relax))
        return [_Solved(bodies.FORMULATION == "corners" and not relax, bodies.FORMULATION)]

    monkeypatch.setattr(diagnosis, "solve_starts", fake_solve_starts)
    ocp = parse_scenario(U_TURN).ocp
    got = diagnosis.failed_road(ocp, 20, _Solved(False, "discs"), start=object())
    assert got.ok and got.formulation == "corners" and calls == [("corners", False)]
    assert got.diagnosis["via"] == "corners formulation"
    assert bodies.FORMULATION == "discs"  # the setting is restored
