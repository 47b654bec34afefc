"""Bodies on a road: the "corners" formulation against the default disc cover (docs/bodies-formulation.md)."""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

import model.direct.bodies as bodies
from model.analysis.bodies import clearances
from model.direct.bodies import disc_count
from model.problem.scenario import parse_scenario
from tests.conftest import ROOT

EXAMPLE = ROOT / "examples" / "roundabout-truck.toml"
N = 40
TOL = 1e-6  # relative: the corners formulation's objective may exceed the discs' by this much at most


def energy_doc(lane_width: float | None = None) -> dict:
    """The truck straight on at a fixed Tf = 20 s, energy objective, N = 40; optionally narrower lanes."""
    doc = tomllib.loads(EXAMPLE.read_text())
    doc["problem"] = {"objective": "energy", "final_time": 20.0, "intervals": N}
    if lane_width is not None:
        for leg in doc["roundabout"]["legs"]:
            leg["lane_width"] = lane_width
    return doc


def solve(doc: dict, formulation: str):
    """The default solve at N without the goal-accuracy refinement (it would solve again on 2N: not tested here)."""
    return parse_scenario(copy.deepcopy(doc)).ocp.solve(intervals=N, accuracy=None, formulation=formulation)


@pytest.fixture(scope="module")
def corners():
    return solve(energy_doc(), "corners")


def test_the_default_is_the_disc_cover_and_the_model_records_the_one_passed():
    """No module setting: build_model builds the formulation it is given, and refuses an unknown one."""
    from model.direct.transcription import build_model

    ocp = parse_scenario(energy_doc()).ocp
    assert bodies.DEFAULT_FORMULATION == "discs"
    discs = build_model(ocp, 4)
    assert discs.body_formulation == "discs" and discs.find_component("body_vehicle_0_island") is not None
    corners = build_model(ocp, 4, formulation="corners")
    assert corners.body_formulation == "corners" and corners.find_component("body_vehicle_0_island") is None
    assert build_model(ocp, 4).body_formulation == "discs"  # nothing carried over from the call before
    with pytest.raises(ValueError, match="formulation"):
        build_model(ocp, 4, formulation="squares")
    with pytest.raises(ValueError, match="formulation"):
        ocp.solve(intervals=4, formulation="squares")


def test_corners_solve_and_the_exact_rectangles_validate(corners):
    assert corners.ok, (corners.status, corners.validation["checks"])
    exact = clearances(corners.ocp, corners.columns)["vehicle"]
    assert exact.min() >= 0.0
    # the keep-out rows give away log(4) / k, the corner rows log(5) / k: nothing more is kept free
    assert exact.min() < 1.5 * math.log(5) / bodies.CORNER_SHARPNESS


def test_corners_are_not_worse_than_the_discs(corners):
    discs = solve(energy_doc(), "discs")
    assert discs.ok
    assert corners.objective <= discs.objective * (1 + TOL)
    assert (
        clearances(discs.ocp, discs.columns)["vehicle"].min()
        > clearances(corners.ocp, corners.columns)["vehicle"].min()
    )


def test_a_lane_the_rectangle_fits_but_its_cover_discs_do_not():
    """2.7 m lanes, a 2.5 m wide body: the discs (2.75 m across) cannot even stand at the start; corners converge
    with every node's rectangle in the corridor. Between the nodes of N = 40, though, the controls integrated
    from each node take the body up to 0.68 m out of the lane (issue 22, item 4): the validation fails the
    answer on ``dense_clearance`` alone, with the numbers (its 2N re-solve ends infeasible)."""
    doc = energy_doc(lane_width=2.7)
    body = parse_scenario(copy.deepcopy(doc)).ocp.bodies["vehicle"]
    radius = body.cover(disc_count(body.length, body.width)).radius
    assert 2 * radius > 2.7 > body.width  # the start lies in the middle of the lane, fixed
    sol = solve(doc, "corners")
    assert sol.status == "validation_failed"  # Ipopt converged; the validation refused
    failed = [k for k, c in sol.validation["checks"].items() if not c["passed"]]
    assert failed == ["dense_clearance"], sol.validation["checks"]
    assert sol.validation["measures"]["min_clearance_integrated"] < -0.1
    exact = clearances(sol.ocp, sol.columns)["vehicle"]
    assert 0.0 <= exact.min() < 0.1  # 0.1 m each side at the start


# --------------------------------------------------------------------------- the exact conditions, on random poses


def _perimeter(ref, u, v, length: float, width: float, step: float = 0.01) -> np.ndarray:
    """Points every ``step`` along the sides of a rectangle centred at ``ref`` with axes u, v."""
    k, m = int(np.ceil(length / step)), int(np.ceil(width / step))
    s = np.concatenate([np.linspace(-1, 1, k + 1), np.ones(m + 1), np.linspace(1, -1, k + 1), -np.ones(m + 1)])
    t = np.concatenate([-np.ones(k + 1), np.linspace(-1, 1, m + 1), np.ones(k + 1), np.linspace(1, -1, m + 1)])
    return ref + (s * length / 2)[:, None] * u + (t * width / 2)[:, None] * v


def _conditions(ocp, apron: bool, ref, u, v, corners, length: float, width: float) -> np.ndarray:
    """The "corners" formulation's conditions without smoothing, per pose: what a feasible NLP point satisfies."""
    region = ocp.road.corridor("trailer" if apron else "vehicle")
    ok = region.contains(corners.reshape(-1, 2)).reshape(-1, 4).all(axis=1)

    def frame(q):
        d = np.asarray(q, float) - ref
        return (d * u).sum(axis=1), (d * v).sum(axis=1)

    for _, centre, radius in bodies._keep_out_discs(ocp, apron):
        x, y = frame(centre)
        ok &= np.hypot(np.maximum(np.abs(x) - length / 2, 0), np.maximum(np.abs(y) - width / 2, 0)) >= radius
    for _, (vertex, end), normal in bodies._keep_out_lines(ocp):
        (xv, yv), (xe, ye) = frame(vertex), frame(end)
        across = (corners - np.asarray(vertex)) @ np.asarray(normal)
        ok &= ((np.minimum(xv, xe) >= length / 2) | (np.maximum(xv, xe) <= -length / 2)
               | (np.minimum(yv, ye) >= width / 2) | (np.maximum(yv, ye) <= -width / 2)
               | (across.min(axis=1) >= 0) | (across.max(axis=1) <= 0))  # fmt: skip
    return ok


@pytest.mark.parametrize(("traffic", "exit_", "apron"), [("right", 1, False), ("right", 3, True), ("left", 2, False)])
def test_the_corner_conditions_hold_exactly_when_the_rectangle_is_in_the_corridor(traffic, exit_, apron):
    """Random rectangles (13.6 m x 2.5 m) centred in the corridor: conditions <=> perimeter sampled every 1 cm inside.

    Both ways: the formulation is conservative (no pose meets the conditions and leaves the corridor)
    and, up to its smoothing, exact (no pose inside the corridor fails them). Some poses have all four
    corners inside and a side outside: the keep-outs are needed.
    """
    doc = energy_doc()
    doc["roundabout"]["traffic"] = traffic
    doc["route"]["exit"] = exit_
    ocp = parse_scenario(doc).ocp
    region = ocp.road.corridor("trailer" if apron else "vehicle")
    rng = np.random.default_rng(exit_)
    ref = rng.uniform(-45.0, 45.0, (20000, 2))
    ref = ref[region.contains(ref)]
    heading = rng.uniform(-np.pi, np.pi, len(ref))
    u = np.column_stack([np.cos(heading), np.sin(heading)])
    v = np.column_stack([-u[:, 1], u[:, 0]])
    length, width = 13.6, 2.5
    local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * [length / 2, width / 2]
    corners = ref[:, None] + local[:, :1] * u[:, None] + local[:, 1:] * v[:, None]
    ok = _conditions(ocp, apron, ref, u, v, corners, length, width)
    corners_in = region.contains(corners.reshape(-1, 2)).reshape(-1, 4).all(axis=1)
    inside = corners_in.copy()
    for i in np.flatnonzero(corners_in):
        inside[i] = region.contains(_perimeter(ref[i], u[i], v[i], length, width)).all()
    assert np.array_equal(ok, inside)
    assert (corners_in & ~inside).sum() > 20 and inside.sum() > 50
