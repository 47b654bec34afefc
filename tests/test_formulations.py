"""Bodies on a road: the "corners" formulation against the default disc cover (docs/bodies-formulation.md)."""

from __future__ import annotations

import copy
import math
import tomllib

import pytest

import model.direct.bodies as bodies
from model.analysis.bodies import clearances
from model.direct.bodies import disc_count, use_formulation
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
    with use_formulation(formulation):
        return parse_scenario(copy.deepcopy(doc)).ocp.solve(intervals=N)


@pytest.fixture(scope="module")
def corners():
    return solve(energy_doc(), "corners")


def test_the_default_is_the_disc_cover_and_a_block_restores_it():
    assert bodies.FORMULATION == "discs"
    with use_formulation("corners"):
        assert bodies.FORMULATION == "corners"
    assert bodies.FORMULATION == "discs"
    with pytest.raises(ValueError, match="formulation"), use_formulation("squares"):
        pass


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
    """2.7 m lanes, a 2.5 m wide body: the discs (2.75 m across) cannot even stand at the start; corners solve."""
    doc = energy_doc(lane_width=2.7)
    body = parse_scenario(copy.deepcopy(doc)).ocp.bodies["vehicle"]
    radius = body.cover(disc_count(body.length, body.width)).radius
    assert 2 * radius > 2.7 > body.width  # the start lies in the middle of the lane, fixed
    sol = solve(doc, "corners")
    assert sol.ok, (sol.status, sol.validation["checks"])
    exact = clearances(sol.ocp, sol.columns)["vehicle"]
    assert 0.0 <= exact.min() < 0.1  # 0.1 m each side at the start
