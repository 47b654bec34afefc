"""Smooth routes (model.search.curves) and the search that screens them."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from model.problem.scenario import parse_scenario
from model.search.curves import curve_guess, curve_routes, hermite

# rob-s0-124 of benchmarks/bench_robustness.py (seed 0): a goal behind a sharp turn; the default
# starts end at 1.8208 s, reversing into the goal takes 1.5713 s (the plain-Opti peer's optimum)
SHARP_TURN = {
    "name": "sharp-turn",
    "vehicle": {"model": "truck", "wheelbase": 0.1949},
    "bounds": {"u1": [-1.0643, 1.0643], "u2": [-0.3927, 0.3927], "phi": [-0.6742, 0.6742]},
    "initial": {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0},
    "final": {"x": 0.8289, "y": -0.1005, "theta": -0.9073},
    "problem": {"objective": "time", "intervals": 77},
}


def test_hermite_ends_and_tangents():
    a, b = (0.0, 0.0, 0.0), (1.0, 1.0, math.pi / 2)
    p = hermite(a, b, 1, 1.0, m=2001)
    assert np.allclose(p[0], a[:2]) and np.allclose(p[-1], b[:2])
    start_dir, end_dir = p[1] - p[0], p[-1] - p[-2]
    assert math.atan2(start_dir[1], start_dir[0]) == pytest.approx(0.0, abs=1e-3)
    assert math.atan2(end_dir[1], end_dir[0]) == pytest.approx(math.pi / 2, abs=1e-3)


def test_reverse_into_goal_guess_reverses_at_the_end():
    ocp = parse_scenario(SHARP_TURN).ocp
    routes = curve_routes(ocp)
    assert {"hermite-x1", "reverse-into-goal", "all-reverse", "reverse-first-left"} <= set(routes)
    values, tf = curve_guess(ocp, routes["reverse-into-goal"], 60, 1.0)
    assert values["x"][0] == pytest.approx(0.0) and values["x"][-1] == pytest.approx(0.8289)
    assert values["theta"][-1] == pytest.approx(-0.9073 + 2 * math.pi * round(0.9073 / (2 * math.pi)), abs=0.05)
    assert values["u1"][0] > 0 > values["u1"][-1]
    assert tf > 0 and np.all(np.abs(values["phi"]) <= 0.6742)


def test_no_routes_without_a_goal_position():
    doc = {**SHARP_TURN, "final": {"theta": 0.0}}
    assert curve_routes(parse_scenario(doc).ocp) == {}


def test_search_finds_the_reversing_optimum():
    sol = parse_scenario(SHARP_TURN).ocp.solve(intervals=77)
    assert sol.ok
    assert sol.objective < 1.5713 * 1.001  # the default starts alone stop at 1.8208
    assert any(a["route"].startswith("screening") for a in sol.attempts)


def test_a_given_first_guess_of_tf_makes_one_start_per_route_and_none_is_lost():
    from model.search.curves import TF_SCALES, tf_scales

    free = parse_scenario(SHARP_TURN).ocp
    guessed = parse_scenario({**SHARP_TURN, "problem": {**SHARP_TURN["problem"], "final_time": 1.5}}).ocp
    assert tf_scales(free) == TF_SCALES and tf_scales(guessed) == (1.0,)
    for name, legs in curve_routes(guessed).items():  # the scales it drops would be the same start
        (a, ta), (b, tb) = (curve_guess(guessed, legs, 40, k) for k in TF_SCALES)
        assert ta == tb and all(np.array_equal(a[s], b[s]) for s in a), name
    legs = next(iter(curve_routes(free).values()))
    assert curve_guess(free, legs, 40, 1.0)[1] != curve_guess(free, legs, 40, 2.0)[1]


def test_equal_starts_are_solved_once_and_each_gets_the_answer(monkeypatch):
    from model.direct.solve import Start
    from model.search import context
    from model.search.starts import distinct_starts, start_values

    ocp = parse_scenario(SHARP_TURN).ocp
    a, b = (start_values(ocp, 40, "none", None, 1.0, r) for r in ("arc", "reeds-shepp"))
    assert not np.array_equal(a.values["x"], b.values["x"])
    same_as_a = Start({k: v.copy() for k, v in a.values.items()}, a.final_time)
    kept, index = distinct_starts([a, b, same_as_a])
    assert kept == [a, b] and index == [0, 1, 0]
    moved = Start({**a.values, "x": a.values["x"] + 1e-12}, a.final_time)
    assert distinct_starts([a, moved])[1] == [0, 1]
    solved, answers = [], [SimpleNamespace(status="optimal"), SimpleNamespace(status="infeasible")]
    monkeypatch.setattr(context, "solve_starts", lambda ocp, n, p, starts, *rest, **_: solved.append(starts) or
                        answers[: len(starts)])  # fmt: skip
    search = context.Search(ocp, 40)
    got = search.solve(40, "none", [a, b, same_as_a])
    assert solved == [[a, b]] and [id(s) for s in got] == [id(answers[0]), id(answers[1]), id(answers[0])]
    assert search.solutions == answers  # each run counted once (the phase timings)
