"""Road studies (issue 11, item 8): turning-circle physics, the cell scenarios, the table scripts on one small cell."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from model.problem.scenario import parse_scenario
from model.studies.roads import (
    EU_INNER,
    EU_OUTER,
    cell_document,
    cell_name,
    eu_steering,
    eu_turning_circle,
    integrate,
    limits_note,
    operational_text,
    parse_cell,
    preset_vehicle,
    rectangle_distance,
    steady_poses,
    steady_turn,
    trailer_radius,
)
from model.vehicles import Body, TractorTrailer, Truck, operational_limits

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "workflows" / "scripts"
TEMPLATE = ROOT / "workflows" / "scenarios" / "roads" / "left-turn.toml"


def trailer_axle(vehicle, run):
    p = vehicle.parameters()
    ax = run["x"] + p["h"] * np.cos(run["theta"]) - p["L"] * np.cos(run["theta1"])
    ay = run["y"] + p["h"] * np.sin(run["theta"]) - p["L"] * np.sin(run["theta1"])
    return np.hypot(ax, ay)


@pytest.mark.parametrize("h", [0.6, 0.0, -0.8])  # fifth wheel ahead, on the axle, tow ball behind
def test_off_tracking_closed_form_matches_an_integrated_steady_circle(h):
    """R_t^2 = R^2 + h^2 - L^2: the trailer axle of the integrated model settles on it to 1e-3 m."""
    v = TractorTrailer(wheelbase=3.7, hitch_offset=h, trailer_wheelbase=7.7)
    phi = 0.35
    R = 3.7 / math.tan(phi)
    start = {"x": R, "y": 0.0, "theta": math.pi / 2, "phi": phi, "theta1": math.pi / 2}  # trailer straight
    run = integrate(v, start, 1.0, 0.0, 6 * 2 * math.pi * R, samples=601)
    radius = trailer_axle(v, run)
    assert abs(radius[-1] - trailer_radius(R, h, 7.7)) < 1e-3
    assert abs(radius[0] - trailer_radius(R, h, 7.7)) > 0.01  # it started elsewhere
    # the steady pose is a fixed point: integrated from it, the trailer axle stays on R_t
    run = integrate(v, steady_poses(v, phi), 1.0, 0.0, 2 * math.pi * R, samples=201)
    assert np.max(np.abs(trailer_axle(v, run) - trailer_radius(R, h, 7.7))) < 1e-6


def test_turning_circle_of_a_rigid_truck_in_closed_form():
    """A rectangle on a rear axle: the front outer corner on 12.50 m fixes R, the inner side is R - w/2."""
    v, body = Truck(wheelbase=5.0), Body(length=8.0, width=2.5, rear_overhang=1.5)
    phi = eu_steering(v, {"vehicle": body})
    R = math.sqrt(EU_OUTER**2 - 6.5**2) - 1.25
    assert math.isclose(5.0 / math.tan(phi), R, abs_tol=1e-9)
    s = steady_turn(v, {"vehicle": body}, phi)
    assert math.isclose(s["outer"], EU_OUTER, abs_tol=1e-9)
    assert math.isclose(s["inner"], R - 1.25, abs_tol=1e-9)
    r = eu_turning_circle(v, {"vehicle": body}, phi_limit=0.6)
    assert r["passes"] and math.isclose(r["inner_margin"], R - 1.25 - EU_INNER, abs_tol=1e-9)
    # the integrated turns of a rigid truck are its steady circle from the first instant
    for turn in r["transient"]["turns"]:
        assert math.isclose(turn["inner"], R - 1.25, abs_tol=1e-6)
        assert turn["outside_annulus_m2"] < 1e-6
    assert not eu_turning_circle(v, {"vehicle": body}, phi_limit=phi - 0.01, transient=False)["passes"]


def test_eu_semitrailer_turning_circle_steady_and_integrated_agree():
    v, bodies, limit = preset_vehicle("EU-semitrailer")
    r = eu_turning_circle(v, bodies, limit)
    assert r["passes"] and limit is None
    assert 0.0 < r["inner_margin"] < 0.1  # the preset's docstring: inner side at 5.35 m
    assert r["steady"]["inner_body"] == "trailer"
    last = r["transient"]["turns"][-1]
    assert abs(last["inner"] - r["steady"]["inner"]) < 1e-3  # converged to the steady state
    assert r["transient"]["turns"][0]["inner"] >= r["steady"]["inner"] - 1e-9  # approached from outside
    assert abs(last["outer"] - EU_OUTER) < 1e-6 and last["outside_annulus_m2"] < 1e-6


def test_rectangle_distance_sides_and_corners():
    square = np.array([[[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]]])
    assert rectangle_distance(square)[0] == pytest.approx(1.0)  # a side, not a corner
    assert rectangle_distance(square + np.array([0.0, 2.0]))[0] == pytest.approx(math.sqrt(2.0))  # corner (1, 1)
    assert rectangle_distance(square, (2.0, 0.0))[0] == 0.0  # inside


def test_cell_documents():
    template = tomllib.loads(TEMPLATE.read_text())
    assert parse_cell(cell_name("WB-62", 45, 2)) == ("WB-62", 45.0, 2.0)
    su = cell_document(template, "SU-30", 30, 2, 20)
    ocp = parse_scenario(su).ocp
    assert ocp.road.roundabout.apron_use == "all" and ocp.road.roundabout.inscribed_diameter == 30
    assert ocp.road.roundabout.legs[0].entry_radius == pytest.approx(template["roundabout"]["legs"][0]["entry_radius"]
                                                                     * 30 / 40)  # fmt: skip
    assert ocp.bounds["phi"][1] < 0.6  # the preset's limit, not the template's
    eu = parse_scenario(cell_document(template, "EU-semitrailer", 55, 0, 20)).ocp
    assert eu.road.roundabout.apron_use == "trailer" and eu.bounds["phi"] == (-0.6, 0.6)
    assert parse_scenario(cell_document(template, "P", 25, 2, 20)).ocp.road.roundabout.apron_use == "none"


@pytest.mark.parametrize("name", ["SU-30", "EU-semitrailer"])
def test_an_operational_cell_takes_the_presets_limits_and_the_templates_speed_bound(name):
    template = tomllib.loads(TEMPLATE.read_text())
    plain = parse_scenario(cell_document(template, name, 45, 2, 20)).ocp
    doc = cell_document(template, name, 45, 2, 20, operational=True)
    ocp, lim = parse_scenario(doc).ocp, operational_limits(name)
    assert "v" in ocp.vehicle.states and "v" not in plain.vehicle.states  # the speed a state, not a control
    assert ocp.bounds["v"] == tuple(template["bounds"]["u1"])  # forward only, the template's cap (below 50 km/h)
    assert ocp.bounds["a"] == lim.acceleration and ocp.bounds["j"] == lim.jerk
    assert ocp.bounds["u2"] == (-lim.steering_rate, lim.steering_rate) != tuple(template["bounds"]["u2"])
    assert ocp.bounds["lateral_acceleration"] == (-lim.lateral_acceleration, lim.lateral_acceleration)
    assert ocp.initial["v"] == lim.crawl_speed and "v" not in ocp.final  # enters at a crawl, leaves at any speed
    assert ocp.bounds["phi"] == plain.bounds["phi"]  # the steering limit as without the limits
    assert "operational" not in template.get("vehicle", {}) and "u1" in template["bounds"]  # the template untouched


def test_a_limits_note_says_above_or_within_with_the_presets_numbers():
    lim = operational_limits("SU-30")
    over = limits_note("SU-30", False, 3.0 * lim.lateral_acceleration)
    assert over.startswith("kinematic model without operational limits")
    assert f"above the SU-30's allowed {lim.lateral_acceleration:g} m/s^2" in over
    assert "within" in limits_note("SU-30", False, 0.5 * lim.lateral_acceleration)
    held = limits_note("SU-30", True, lim.lateral_acceleration, lim.acceleration)
    assert held.startswith(f"operational limits of the SU-30: a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}]")
    assert f"lateral acceleration at most {lim.lateral_acceleration:g} m/s^2" in held
    assert "reached: max lateral acceleration" in held and "|" not in held + over  # Markdown tables take them
    assert f"entering at {lim.crawl_speed:.2f} m/s" in operational_text("SU-30")


def run(script: str, *args) -> None:
    subprocess.run([sys.executable, str(SCRIPTS / script), *map(str, args)], check=True, cwd=ROOT,
                   capture_output=True, text=True)  # fmt: skip


def test_table_scripts_on_one_small_cell(tmp_path):
    cell, larger = tmp_path / "cells" / "P_icd40_apron0.json", tmp_path / "cells" / "P_icd50_apron0.json"
    # a row as the pipeline runs it: two cells in one process, each written to its own file
    run("studies_roads_cell.py", "--template", TEMPLATE, "--cell", "P_icd40_apron0", "P_icd50_apron0", "--intervals",
        20, "--time-limit", 60, "--clock", "cpu", "--energy-time-limit", 60, "--no-operational", "--out", cell,
        larger)  # fmt: skip
    data, other = json.loads(cell.read_text()), json.loads(larger.read_text())
    assert not data["operational"] and data["limits"] is None and "v" not in data["trajectory"]
    assert (data["cell"], data["icd"], other["cell"], other["icd"]) == ("P_icd40_apron0", 40, "P_icd50_apron0", 50)
    assert other["time"]["valid"] and other["time"]["final_time"] > data["time"]["final_time"]  # the larger ring
    assert 0.0 < other["cpu_seconds"] < 60.0  # its own clock, not the process's
    assert data["energy_time_limit"] == 60.0
    assert data["time"]["valid"] and data["energy"]["valid"]
    assert data["time_limit_clock"] == "cpu" and 0.0 < data["cpu_seconds"] < 60.0
    assert data["energy"]["intervals_asked"] == data["time"]["intervals"]  # the energy solve on the answer's grid
    assert data["energy"]["final_time"] == pytest.approx(1.2 * data["time"]["final_time"])
    assert data["energy"]["energy"] < data["time"]["energy"]
    assert data["measures"]["apron_used_m"] == 0.0 and 2.0 < data["measures"]["swept_width_m"] < 4.5
    # by default at the preset's operational limits, held at the nodes and said so in the record (N = 20 is too
    # coarse for them: between the nodes the body cuts the island's edge by 0.2 m; the small grid runs N = 60)
    limited = tmp_path / "cells" / "SU-30_icd45_apron0.json"
    run("studies_roads_cell.py", "--template", TEMPLATE, "--cell", "SU-30_icd45_apron0", "--intervals", 40,
        "--time-limit", 120, "--clock", "cpu", "--energy-time-limit", 60, "--out", limited)  # fmt: skip
    op, lim = json.loads(limited.read_text()), operational_limits("SU-30")
    assert op["operational"] and op["limits"]["acceleration"] == list(lim.acceleration) and op["time"]["valid"]
    assert op["initial_speed"] == pytest.approx(lim.crawl_speed)
    assert op["trajectory"]["v"][0] == pytest.approx(lim.crawl_speed, abs=1e-6)
    assert op["time"]["max_abs_lateral_acceleration"] <= lim.lateral_acceleration + 1e-6
    assert lim.acceleration[0] - 1e-6 <= op["time"]["min_acceleration"] <= op["time"]["max_acceleration"] <= (
        lim.acceleration[1] + 1e-6)
    # a failed cell (made by hand) is reported with its diagnosis, never as a solution
    failed = {**data, "cell": "WB-67_icd40_apron0", "preset": "WB-67", "energy": None, "measures": None}
    failed["time"] = {**data["time"], "valid": False, "status": "infeasible",
                      "diagnosis": {"message": "the trailer crosses the apron by 1.30 m", "body": "trailer",
                                    "edge": "apron", "encroachment_m": 1.3}}  # fmt: skip
    (tmp_path / "cells" / "WB-67_icd40_apron0.json").write_text(json.dumps(failed))
    # a cell at a smaller ICD that took three times the CPU, refused at its time limit: the section says why
    slow = {**failed, "cell": "P_icd35_apron0", "preset": "P", "icd": 35.0, "time_limit": 60.0,
            "cpu_seconds": 3 * data["cpu_seconds"]}  # fmt: skip
    slow["time"] = {**failed["time"], "diagnosis": {"kind": "time limit", "time_limit_s": 60.0, "clock": "cpu"}}
    (tmp_path / "cells" / "P_icd35_apron0.json").write_text(json.dumps(slow))
    section = tmp_path / "74.md"
    run("studies_roads_table.py", "--cells", cell, tmp_path / "cells" / "WB-67_icd40_apron0.json",
        tmp_path / "cells" / "P_icd35_apron0.json", limited, "--template",
        TEMPLATE, "--mode", "small", "--vehicles", "P", "WB-67", "SU-30", "--icd", 40, "--apron", 0, "--intervals", 20,
        "--out", tmp_path / "table", "--section", section, "--formats", "png")  # fmt: skip
    text = section.read_text()
    assert "`road_studies: small` run" in text
    assert f"{data['time']['final_time']:.4g}" in text
    assert "FAILED" in text and "the trailer crosses the apron by 1.30 m" in text
    assert "minimum time is above twice the same vehicle's at the next larger ICD (with the same apron): none" in text
    assert "P ICD 35 m apron 0 m:" in text and "(refused at its time limit of 60 s" in text
    assert "1 of the 4 cells run" in text and "at **its preset's operational limits**" in text
    assert operational_text("SU-30") in text and operational_text("P") not in text
    assert f"operational limits of the SU-30: a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}]" in text
    allowed = operational_limits("P").lateral_acceleration
    reached = data["time"]["max_abs_lateral_acceleration"]
    over = "above" if reached > allowed else "within"
    assert (f"kinematic model without operational limits: max lateral acceleration {reached:.2f}"
            f" m/s^2 ({over} the P's allowed {allowed:g} m/s^2)") in text
    assert (tmp_path / "table" / "table.png").exists()


@pytest.mark.parametrize("flag", ["--time-limit", "--energy-time-limit"])
def test_a_cell_with_a_bad_time_limit_is_refused_in_one_line(tmp_path, flag):
    """``--time-limit`` and ``--energy-time-limit`` (the full grid's per-cell budgets) must be positive: one line
    naming the flag, exit 2, nothing written."""
    cell = tmp_path / "cell.json"
    done = subprocess.run([sys.executable, str(SCRIPTS / "studies_roads_cell.py"), "--template", str(TEMPLATE),
                           "--cell", "P_icd40_apron0", "--intervals", "20", flag, "0", "--out", str(cell)],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith(f"{flag}:")
    assert not cell.exists()


@pytest.mark.parametrize(
    ("cells", "outs", "flag"),
    [(["P_icd40_apron0"], ["a.json", "b.json"], "--out"), (["P_icd40_apron0", "P-40"], ["a.json", "b.json"], "--cell")],
)
def test_a_row_with_bad_cells_or_files_is_refused_in_one_line(tmp_path, cells, outs, flag):
    """A row's ``--out`` needs one file per ``--cell``, each cell a VEHICLE_icdD_apronA name: one line naming the
    flag, exit 2, no file written (not even the good cells')."""
    done = subprocess.run([sys.executable, str(SCRIPTS / "studies_roads_cell.py"), "--template", str(TEMPLATE),
                           "--cell", *cells, "--intervals", "20", "--out", *[str(tmp_path / o) for o in outs]],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith(f"{flag}:")
    assert not list(tmp_path.iterdir())


def test_the_energy_time_section_labels_its_rows_and_sets_the_operational_time_beside_them():
    """The trade-off's rows (the kinematic model) each say their lateral acceleration against the preset's allowed
    one; the minimum time at the preset's limits stands beside them, its numbers read from its record."""
    from model.problem.scenario import load_scenario

    sys.path.insert(0, str(SCRIPTS))
    try:
        import studies_roads_tradeoff as tradeoff
    finally:
        sys.path.remove(str(SCRIPTS))
    scenario = ROOT / "workflows" / "scenarios" / "roads" / "su30-left-turn.toml"
    lim = operational_limits("SU-30")
    row = {"objective": "time", "ratio": None, "final_time": 12.5, "status": "optimal", "valid": True,
           "energy": 625.0, "iterations": 40, "solve_seconds": 1.0, "max_speed": 10.0, "mean_speed": 10.0,
           "max_steering_rate": 0.5, "path_length": 125.0, "speed_share": 0.99, "min_clearance": 0.1,
           "min_clearance_dense": 0.1, "max_abs_lateral_acceleration": 8.25, "apron_used_m": 1.9,
           "swept_width_m": 4.2, "diagnosis": None}  # fmt: skip
    slow = {**row, "objective": "energy", "ratio": 2.0, "final_time": 25.0, "energy": 312.5,
            "max_abs_lateral_acceleration": 0.5 * lim.lateral_acceleration}  # fmt: skip
    ref = {"preset": "SU-30", "valid": True, "status": "optimal", "final_time": 17.5, "intervals": 120,
           "max_abs_lateral_acceleration": 2.0, "acceleration": [-2.25, 1.3], "speed_bound": [0.0, 10.0]}  # fmt: skip
    text = tradeoff.section(load_scenario(scenario).ocp, [row, slow], Path("f.png"), 60, 0.01, "SU-30", ref)
    assert (f"max lateral acceleration 8.25 m/s^2 (above the SU-30's allowed {lim.lateral_acceleration:g} m/s^2)"
            in text) and "(within the SU-30's allowed" in text  # fmt: skip
    assert "the same turn's minimum time is 17.5 s (N = 120; reached: max lateral acceleration 2.00 m/s², a in " \
           "[-2.25, 1.30] m/s²), against T_min = 12.5 s without them" in text
    assert tradeoff.operational_text("SU-30") in text
    failed = tradeoff.reference_lines({**ref, "valid": False, "diagnosis": "the body crosses the island"}, row)
    assert failed[0].endswith("FAILED: the body crosses the island.")
    assert tradeoff.reference_lines(None, row) == []
