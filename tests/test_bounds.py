"""Bounds before search (issue 22, item 1): the steady swept annulus, the ring, the lanes, proofs, the time."""

from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest

from benchmarks.bench_road_suite import road_document, routes
from model.analysis.bounds import steady_radii, wound_length
from model.problem.scenario import parse_scenario
from model.search.bounds import refusal_from_bounds, road_bounds
from model.studies.roads import EU_INNER, EU_OUTER, eu_steering, preset_vehicle, steady_turn
from model.vehicles import PRESETS
from tests.conftest import ROOT


def road(preset="SU-30", legs=4, exit_=2, icd=30.0, ring=6.0, apron=0.0, lane=4.0, apron_use="none",
         traffic="right", intervals=40):  # fmt: skip
    """A road-suite document on another roundabout (fillets 8 / 10 m so that small rings have room)."""
    doc = road_document(preset, legs, traffic, exit_, intervals)
    doc["roundabout"].update(inscribed_diameter=icd, circulatory_width=ring, apron_width=apron, apron_use=apron_use)
    for leg in doc["roundabout"]["legs"]:
        leg.update(lane_width=lane, entry_radius=8.0, exit_radius=10.0)
    return doc


def ocp_of(doc):
    return parse_scenario(doc).ocp


@pytest.mark.parametrize("name", PRESETS)
def test_the_closed_form_steady_turn_is_the_turning_circle_study(name):
    """Each body's outer and inner swept radius in closed form equals the study's placed rectangles'."""
    vehicle, bodies, limit = preset_vehicle(name)
    p = vehicle.parameters()
    phi = limit if limit is not None else eu_steering(vehicle, bodies)
    if "L" in p:  # short of the least steady radius (no steady trailer beyond it), by 0.5 m
        phi = min(phi, math.atan(p["d"] / (math.sqrt(max(p["L"] ** 2 - p["h"] ** 2, 0.0)) + 0.5)))
    study = steady_turn(vehicle, bodies, phi)
    mine = steady_radii(vehicle, bodies, vehicle.parameters()["d"] / math.tan(phi))
    for body, radii in study["bodies"].items():
        assert mine[body]["outer"] == pytest.approx(radii["outer"], abs=1e-9)
        assert mine[body]["inner"] == pytest.approx(radii["inner"], abs=1e-9)


def test_the_eu_semitrailer_fits_the_directive_annulus_as_a_tight_steady_turn():
    """The EU annulus (12.5 / 5.3 m) as a 25 m roundabout with a 7.2 m ring: fits, by the preset's 5 cm."""
    bounds = road_bounds(ocp_of(road("EU-semitrailer", exit_=4, icd=2 * EU_OUTER, ring=EU_OUTER - EU_INNER,
                                     apron_use="trailer")))  # fmt: skip
    fit = bounds["ring_fit"]
    assert fit["fits"] and 0.0 < fit["margin"] < 0.1 and fit["inner_body"] == "trailer"
    assert bounds["verdict"] == "tight" and not bounds["proofs"]
    assert "steady circulating turn leaves" in bounds["tight"][0]


def test_a_large_ring_is_free_and_its_time_bound_is_below_the_road_suite_answers():
    """Every route of the road suite: verdict free, and the time bound at most the answer in road-suite.md."""
    table = (ROOT / "benchmarks" / "road-suite.md").read_text()
    for preset, legs, traffic, exit_ in routes():
        doc = road_document(preset, legs, traffic, exit_, 60)
        answer = float(re.search(rf"\| {doc['name']} \|[^\n]*?\| discs \|(?:[^|]*\|){{3}} ([0-9.]+) \|", table)[1])
        bounds = road_bounds(ocp_of(doc))
        assert bounds["verdict"] == "free", (doc["name"], bounds["tight"])
        assert 0.5 * answer < bounds["time_lower_bound_s"] <= answer, doc["name"]


def test_the_wound_path_is_the_tangent_arc_tangent_or_the_chord():
    a, b = np.array([10.0, 0.0]), np.array([-10.0, 0.0])
    tangent = math.sqrt(100.0 - 25.0)
    assert wound_length(a, b, 5.0, math.pi) == pytest.approx(2 * tangent + 5.0 * (math.pi - 2 * math.acos(0.5)))
    assert wound_length(a, np.array([0.0, 10.0]), 1.0, math.pi / 2) == pytest.approx(math.sqrt(200.0))  # chord
    assert wound_length(a, a, 5.0, 2 * math.pi) > 2 * math.pi * 5.0  # a full loop round the disc


@pytest.mark.parametrize(
    ("doc", "bound", "words"),
    [
        (road(exit_=4, ring=2.0), "ring passage", "cannot cross the ray"),  # a U-turn: the leg connects
        (road(exit_=4, ring=2.0, traffic="left"), "ring passage", "cannot cross the ray"),
        (road(exit_=2, ring=2.0), "corridor passage", "cannot pass from the start to the goal"),
        (road(exit_=1, ring=2.0), "corridor passage", "cannot pass from the start to the goal"),
    ],
)
def test_a_ring_narrower_than_the_truck_is_refused_in_seconds_with_the_bound(doc, bound, words):
    t0 = time.perf_counter()
    refusal = refusal_from_bounds(ocp_of(doc))
    assert time.perf_counter() - t0 < 5.0
    assert refusal["kind"] == "proven bound" and refusal["bound"] == bound
    assert words in refusal["message"] and "2.44 m" in refusal["message"] and "\n" not in refusal["message"]


def test_the_apron_or_a_wider_ring_lifts_the_proof():
    """The same 2 m ring with the apron allowed, or a 3 m ring: no proof (a U-turn needs no steady turn)."""
    assert refusal_from_bounds(ocp_of(road(exit_=4, ring=2.0, apron=2.0, apron_use="all"))) is None
    bounds = road_bounds(ocp_of(road(exit_=4, ring=3.0)))
    assert not bounds["ring_fit"]["fits"] and bounds["verdict"] == "tight" and not bounds["proofs"]


def test_a_start_beyond_the_leg_is_proven_infeasible():
    doc = road()
    doc["route"]["start_distance"] = 60.0  # the leg's length: the body's rear overhang sticks out of its end
    refusal = refusal_from_bounds(ocp_of(doc))
    assert refusal["bound"] == "start pose" and refusal["proofs"][0]["clearance_m"] < -1.0
    assert refusal_from_bounds(ocp_of(road())) is None


def test_a_fixed_final_time_below_the_wound_path_is_proven_infeasible():
    """A U-turn must go round the island: 2 pi R at the top speed, far more than the straight line."""
    doc = road(exit_=4)
    doc["problem"] = {"objective": "energy", "final_time": 9.0, "intervals": 40}
    refusal = refusal_from_bounds(ocp_of(doc))
    assert refusal["bound"] == "time" and refusal["bounds"]["path_length"]["straight_m"] < 10.0
    assert refusal["proofs"][0]["time_lower_bound_s"] > 9.0


def test_the_lane_margin_and_the_check_command_print_the_bounds(tmp_path, capsys):
    from model.cli import main

    bounds = road_bounds(ocp_of(road("EU-semitrailer", exit_=4, icd=24.0, lane=2.8, apron_use="trailer")))
    assert bounds["lane"]["margin"] == pytest.approx(0.25) and any("2.8 m" in r for r in bounds["tight"])
    assert main(["check", str(ROOT / "examples" / "roundabout-truck.toml")]) == 0
    out = capsys.readouterr().out
    assert "bounds: free" in out and "time >=" in out


def test_a_tight_ring_is_solved_and_the_coarse_grid_re_solved_for_its_integration_error():
    """SU-30 straight on through a 4.6 m ring: the steady turn leaves 0.26 m (tight). On N = 40 the controls,
    integrated from node 28, end 0.066 m from node 29 where the clearance is 0.047 m: the search solves again
    on 2N, and the answer's bodies end each interval within their clearances."""
    ocp = ocp_of(road(ring=4.6))
    bounds = road_bounds(ocp)
    assert bounds["verdict"] == "tight" and 0.0 < bounds["ring_fit"]["margin"] < 0.5
    sol = ocp.solve(intervals=40)
    assert sol.ok and sol.intervals == 80 and sol.accuracy["grid_failures"] == []
    assert sol.objective >= bounds["time_lower_bound_s"]
    assert any(a.get("route") == "N=80 for accuracy" for a in sol.attempts)
    error = sol.validation["measures"]["integration_error"]
    assert error["within_clearance"] and error["body_error"] <= error["tolerance"]
    assert sol.validation["measures"]["min_clearance_integrated"] >= -0.02


def test_solve_ocp_refuses_a_proven_infeasible_road_with_the_bound_in_seconds():
    """The search's first step: a proof ends it, one cut-short start beside it, the proof as the diagnosis."""
    from model.search.multistart import solve_ocp

    t0 = time.perf_counter()
    sol = solve_ocp(ocp_of(road(exit_=2, ring=2.0, intervals=30)), 30)
    assert time.perf_counter() - t0 < 60.0  # a 3 s start beside the proof, not a search
    assert not sol.ok and sol.diagnosis["kind"] == "proven bound" and sol.diagnosis["bound"] == "corridor passage"
    assert len(sol.attempts) == 1
