"""Scenario files with presets, bodies and the articulation bound."""

from __future__ import annotations

import pytest

from model import InputError
from model.problem.scenario import parse_scenario
from model.vehicles import preset

SEMI = {
    "vehicle": {"preset": "WB-62"},
    "bounds": {"u1": [-10.0, 10.0], "u2": [-0.5, 0.5], "articulation": [-0.1, 0.1]},
    "initial": {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0, "theta1": 0.0},
    "final": {"x": 60.0, "y": 15.0, "theta": 0.6},
    "problem": {"objective": "energy", "final_time": 20.0, "intervals": 40},
}


def with_vehicle(**vehicle):
    return {**SEMI, "vehicle": vehicle}


def test_a_preset_fills_the_vehicle_its_bodies_and_bounds():
    ocp = parse_scenario(SEMI).ocp
    wb62 = preset("WB-62")
    assert ocp.vehicle.model == "tractor-trailer"
    assert ocp.vehicle.trailer_wheelbase == pytest.approx(wb62["trailer_wheelbase"])
    assert ocp.bodies["trailer"].length == pytest.approx(wb62["trailer_body"]["length"])
    assert ocp.bounds["phi"] == pytest.approx(wb62["bounds"]["phi"])


def test_keys_beside_a_preset_override_it():
    ocp = parse_scenario(with_vehicle(preset="WB-62", wheelbase=6.5, body={"length": 8.0, "width": 2.6,
                                                                            "rear_overhang": 0.7})).ocp
    assert ocp.vehicle.wheelbase == 6.5
    assert (ocp.bodies["vehicle"].length, ocp.bodies["vehicle"].width) == (8.0, 2.6)
    assert ocp.bodies["trailer"].length == pytest.approx(preset("WB-62")["trailer_body"]["length"])
    data = {**SEMI, "bounds": {**SEMI["bounds"], "phi": [-0.3, 0.3]}}
    assert parse_scenario(data).ocp.bounds["phi"] == (-0.3, 0.3)


@pytest.mark.parametrize(
    ("vehicle", "key"),
    [
        ({"preset": "WB62"}, "vehicle.preset"),
        ({"preset": "WB-62", "body": {"length": 7.0, "width": 2.6, "rear_overhang": 0.6, "mass": 3}},
         "vehicle.body.mass"),
        ({"preset": "WB-62", "trailer_wheelbase": -1.0}, "vehicle.trailer_wheelbase"),
        ({"model": "truck", "wheelbase": 5.0, "trailer_body": {"length": 7.0, "width": 2.6, "rear_overhang": 0.6}},
         "vehicle.trailer_body"),
        ({"model": "truck", "wheelbase": 5.0, "body": {"length": 7.0, "width": 2.6}}, "vehicle.body.rear_overhang"),
        ({"model": "truck", "wheelbase": 5.0, "body": "big"}, "vehicle.body"),
    ],
)
def test_bad_vehicle_tables_name_the_key(vehicle, key):
    data = {**SEMI, "vehicle": vehicle}
    if vehicle.get("model") == "truck":
        data = {**data, "initial": {k: v for k, v in SEMI["initial"].items() if k != "theta1"},
                "bounds": {k: v for k, v in SEMI["bounds"].items() if k != "articulation"} | {"phi": [-0.5, 0.5]}}
    with pytest.raises(InputError) as err:
        parse_scenario(data)
    assert err.value.key == key


def test_the_articulation_bound_holds_in_the_solution():
    sol = parse_scenario(SEMI).ocp.solve(intervals=40)
    assert sol.ok, sol.status
    gap = (sol.trajectory["theta"] - sol.trajectory["theta1"]).abs().max()
    assert gap == pytest.approx(0.1, abs=1e-6)  # the bound is active: without it the trailer swings wider
