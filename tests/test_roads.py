"""Road scenarios: the [roundabout] and [route] tables, a solve that keeps exact rectangles in the corridor."""

from __future__ import annotations

import copy
import json
import math
import tomllib

import numpy as np
import pytest

from model import InputError
from model.analysis.bodies import clearances
from model.problem.scenario import load_scenario, parse_scenario
from tests.conftest import ROOT

EXAMPLE = ROOT / "examples" / "roundabout-truck.toml"


@pytest.fixture
def doc():
    return tomllib.loads(EXAMPLE.read_text())


def energy(doc, final_time=20.0, intervals=60):
    out = copy.deepcopy(doc)
    out["problem"] = {"objective": "energy", "final_time": final_time, "intervals": intervals}
    return out


def test_the_route_sets_start_and_goal(doc):
    ocp = parse_scenario(doc).ocp
    assert (ocp.initial["x"], ocp.initial["y"], ocp.initial["theta"]) == pytest.approx((-50.0, -2.0, 0.0))
    assert (ocp.final["x"], ocp.final["y"], ocp.final["theta"]) == pytest.approx((50.0, -2.0, 0.0))
    assert ocp.road.exit_leg == 2


def mutate(doc, path, value):
    out = copy.deepcopy(doc)
    target = out
    for key in path[:-1]:
        target = target[key]
    if value is None:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return out


@pytest.mark.parametrize(
    ("path", "value", "key"),
    [
        (("roundabout", "legs", 1, "lane_width"), 2.4, "roundabout.legs[1].lane_width"),
        (("route", "exit"), 5, "route.exit"),
        (("roundabout", "legs", 0, "lane_widht"), 4.0, "roundabout.legs[0].lane_widht"),
        (("obstacles",), [{"center": [0.0, 0.0], "radius": 1.0}], "obstacles"),
        (("initial",), {"x": 1.0}, "initial.x"),
        (("roundabout", "traffic"), "middle", "roundabout.traffic"),
        (("vehicle", "body", "width"), 4.5, "roundabout.legs[0].lane_width"),
    ],
)
def test_bad_road_files_name_the_key(doc, path, value, key):
    with pytest.raises(InputError) as err:
        parse_scenario(mutate(doc, path, value))
    assert err.value.key == key
    assert "\n" not in str(err.value)


def test_a_misspelled_leg_key_gets_a_suggestion(doc):
    with pytest.raises(InputError, match="did you mean 'lane_width'"):
        parse_scenario(mutate(doc, ("roundabout", "legs", 0, "lane_widht"), 4.0))


def test_a_truck_goes_straight_on_with_its_rectangle_inside_the_corridor(doc):
    sol = parse_scenario(energy(doc)).ocp.solve(intervals=60)
    assert sol.ok, (sol.status, sol.validation["checks"])
    measures = sol.validation["measures"]
    assert measures["exit_taken"] == 2
    exact = clearances(sol.ocp, sol.columns)["vehicle"]
    assert exact.min() >= -1e-6 and measures["min_clearance"] == pytest.approx(exact.min())
    # the discs reach 10 % of the half-width beyond the body: the exact clearance is about that, not much more
    assert exact.min() < 0.3


def test_the_validation_rejects_a_body_over_the_island(doc):
    """Not vacuous: the same trajectory with a body twice as wide fails the exact-rectangle check."""
    from model.analysis.validation import validate
    from model.vehicles import Body

    sol = parse_scenario(energy(doc)).ocp.solve(intervals=60)
    wide = copy.copy(sol.ocp)
    wide.bodies = {"vehicle": Body(8.0, 5.0, 1.5)}
    base = {k: sol.columns[k] for k in ("t", *sol.ocp.vehicle.states, *sol.ocp.vehicle.controls)}
    result = validate(wide, base, sol.final_time)
    assert not result["checks"]["body_clearance"]["passed"]
    assert result["measures"]["min_clearance"] < -0.5


def test_solve_writes_the_swept_path(tmp_path, doc):
    from model.cli import main

    path = tmp_path / "r.toml"
    text = EXAMPLE.read_text().replace('objective = "time"', 'objective = "energy"\nfinal_time = 20.0')
    path.write_text(text.replace("intervals = 100", "intervals = 60"))
    assert main(["solve", str(path), "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["exit_taken"] == 2 and summary["min_clearance"] >= 0
    swept = json.loads((tmp_path / "out" / "swept_path.geojson").read_text())
    (feature,) = swept["features"]
    assert feature["properties"]["body"] == "vehicle" and feature["geometry"]["type"] in ("Polygon", "MultiPolygon")
    ring = np.array(feature["geometry"]["coordinates"][0] if feature["geometry"]["type"] == "Polygon"
                    else feature["geometry"]["coordinates"][0][0])  # fmt: skip
    assert math.isclose(ring[:, 0].min(), -50.0 - 1.5, abs_tol=0.2)  # the rear bumper at the start


def test_load_example():
    assert load_scenario(EXAMPLE).ocp.road is not None


def test_the_road_figure_draws_the_roundabout_and_the_bodies(tmp_path, doc):
    import matplotlib

    matplotlib.use("Agg")
    from PIL import Image

    from model.plotting.roads import road_figure

    sol = parse_scenario(energy(doc)).ocp.solve(intervals=60)
    fig = road_figure(sol.ocp, sol.columns)
    fig.savefig(tmp_path / "road.png", dpi=60)
    pixels = np.asarray(Image.open(tmp_path / "road.png").convert("L"), float)
    assert pixels.std() > 10  # not blank
    assert len(fig.axes) == 5  # the plan and u1, u2, phi, the lateral acceleration


def test_a_ring_too_narrow_for_the_truck_fails_with_a_diagnosis(tmp_path, doc):
    """3.2 m of ring for a 2.5 m wide, 8 m long truck (no apron for it): exit 1 and which edge gives way."""

    narrow = energy(mutate(doc, ("roundabout", "circulatory_width"), 3.2), intervals=40)
    sol = parse_scenario(narrow).ocp.solve(intervals=40)
    assert not sol.ok
    diagnosis = sol.diagnosis
    assert diagnosis["kind"] == "minimal violation" and diagnosis["body"] == "vehicle"
    assert diagnosis["edge"] in ("outer curb", "apron") and diagnosis["encroachment_m"] > 0.05
    assert "\n" not in diagnosis["message"] and f"{diagnosis['encroachment_m']:.2f} m" in diagnosis["message"]
    assert sol.attempts[-1]["route"] == "minimal violation"


def test_the_lane_strip_ends_at_the_centre(doc):
    """A disc beyond the far side of the ring is in no piece (the strip must not run through the centre)."""
    import pyomo.environ as pyo

    from model.direct.bodies import _lane_margin, lane_numbers

    ocp = parse_scenario(doc).ocp
    lane = lane_numbers(ocp.road.roundabout, 0, "entry")
    far_side = _lane_margin(lane, 25.0, -2.0, 1.0)  # leg 0 points west; (25, -2) is east of the ring
    near = _lane_margin(lane, -30.0, -2.0, 1.0)
    assert pyo.value(far_side) < 0 < pyo.value(near)



def test_the_diagnosis_names_an_encroachment_between_the_nodes(doc):
    """Two nodes on the ring a quarter turn apart: both rectangles inside, the chord between them over the island."""
    from types import SimpleNamespace

    from model.search.diagnosis import road_diagnosis

    ocp = parse_scenario(doc).ocp
    states = {"x": np.array([17.0, 0.0]), "y": np.array([0.0, 17.0]), "theta": np.array([math.pi / 2, math.pi]),
              "phi": np.zeros(2), "t": np.array([0.0, 3.0])}  # fmt: skip
    assert min(clearances(ocp, states)["vehicle"]) > 0.5
    diagnosis = road_diagnosis(ocp, SimpleNamespace(columns=states, status="relaxed"), 0.1)
    assert diagnosis["where"] == "between nodes" and 0.0 < diagnosis["at_time_s"] < 3.0
    assert diagnosis["encroachment_m"] > 1.0 and f"{diagnosis['encroachment_m']:.2f} m" in diagnosis["message"]


def write_result(folder, columns: dict, summary: dict) -> None:
    """A road's results folder as road_solve leaves it: summary.json and trajectory.csv (node columns)."""
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps(summary))
    names = list(columns)
    rows = [",".join(f"{columns[n][k]:.6g}" for n in names) for k in range(len(columns[names[0]]))]
    (folder / "trajectory.csv").write_text(",".join(names) + "\n" + "\n".join(rows) + "\n")


def test_the_road_section_labels_every_run_with_its_limits(tmp_path):
    """Each row and figure caption says what the run was held to, numbers from its summary and the preset: a run
    without operational limits says by how much its lateral acceleration exceeds what the preset allows."""
    import os
    import subprocess
    import sys

    from model.vehicles import operational_limits

    roads = ROOT / "workflows" / "roads"
    scenarios = [roads / "truck-straight-on.toml", roads / "truck-straight-on-operational.toml"]
    t = np.linspace(0.0, 10.0, 5)
    free = {"valid": True, "final_time": 10.5, "energy": 500.0, "objective": 10.5, "objective_name": "time",
            "lateral_acceleration": {"max_abs_nodes": 7.25, "max_abs_dense": 7.5}}  # fmt: skip
    held = {**free, "final_time": 18.5, "objective": 18.5,
            "lateral_acceleration": {"max_abs_nodes": 1.75, "max_abs_dense": 1.8, "bound": [-2.0, 2.0]},
            "longitudinal": {"min_acceleration": -2.25, "max_acceleration": 1.25, "min_acceleration_dense": -2.3,
                             "max_acceleration_dense": 1.3}}  # fmt: skip
    base = {"t": t, "x": t, "y": 0 * t, "theta": 0 * t, "phi": 0 * t, "u2": np.array([1.0, -1.0, 1.0, 0.0, 0.0])}
    write_result(tmp_path / "res" / "truck-straight-on", base | {"u1": 0 * t + 10.0}, free)
    write_result(tmp_path / "res" / "truck-straight-on-operational", base | {"v": t, "a": 0 * t, "j": 0 * t}, held)
    out = tmp_path / "70.md"
    subprocess.run([sys.executable, str(ROOT / "workflows" / "scripts" / "roads_section.py"), "--scenarios",
                    *map(str, scenarios), "--results", str(tmp_path / "res"), "--out", str(out)], check=True,
                   cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})  # fmt: skip
    text, lim = out.read_text(), operational_limits("SU-30")
    rows = [line for line in text.splitlines() if line.startswith("| truck-straight-on")]
    setting, solved = (line for line in text.splitlines() if line.startswith("| scenario"))
    heads = [setting] * 2 + [solved] * 2
    assert len(rows) == 4 and all(r.count("|") == h.count("|") for r, h in zip(rows, heads, strict=True))
    # the setting table's limits cell (short); the full notes in the captions and the text
    assert f"none: a_lat 7.25 > {lim.lateral_acceleration:g}" in rows[0]
    assert "held: a_lat 1.75, a -2.25 to 1.25" in rows[1]
    without = (f"kinematic model without operational limits: max lateral acceleration 7.25 m/s^2 (above the SU-30's "
               f"allowed {lim.lateral_acceleration:g} m/s^2)")  # fmt: skip
    at = (f"operational limits of the SU-30: a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}] m/s^2, jerk in "
          f"[{lim.jerk[0]:g}, {lim.jerk[1]:g}] m/s^3, lateral acceleration at most {lim.lateral_acceleration:g} m/s^2; "
          "reached: max lateral acceleration 1.75 m/s^2, a in [-2.25, 1.25] m/s^2")  # fmt: skip
    captions = [line for line in text.splitlines() if line.startswith("![truck-straight-on")]
    assert without in captions[0] and at in captions[1]
    assert "$T_f$ = 18.50 s" in text and "truck-straight-on without the limits: $T_f$ = 10.50 s" in text
