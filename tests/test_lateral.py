"""Driving as designed: the lateral-acceleration bound and the steering weight (issue 18, item 4).

The two road examples solved with ``[bounds] lateral_acceleration = [-2, 2]`` keep |a_lat| <= 2 at
every node (recomputed here from trajectory columns with NumPy, not through the project's expression)
and within 5 % between the nodes on the dense re-integration; the steering weight makes u2 change
sign less often; bad values of both keys are one InputError naming the key.
"""

from __future__ import annotations

import copy
import subprocess
import sys
import tomllib
from dataclasses import dataclass

import numpy as np
import pytest
import sympy as sp

from model.errors import InputError
from model.plotting.roads import steering_changes
from model.problem.costs import Time
from model.problem.ocp import OCP
from model.problem.scenario import parse_scenario
from model.vehicles import VEHICLES, Roles, Vehicle, sym
from tests.conftest import ROOT

TRUCK = ROOT / "examples" / "roundabout-truck.toml"
SEMITRAILER = ROOT / "examples" / "roundabout-semitrailer.toml"
N = 60  # moderate: the examples use 100 and 200
BOUND = 2.0


def document(path, **changes) -> dict:
    """The example's TOML document with [bounds] / [problem] keys changed (None removes one)."""
    data = tomllib.loads(path.read_text())
    data["problem"]["intervals"] = N
    for dotted, value in changes.items():
        table, key = dotted.split("__")
        if value is None:
            data[table].pop(key, None)
        else:
            data[table][key] = value
    return data


def solve(path, **changes):
    sc = parse_scenario(document(path, **changes), default_name=path.stem)
    return sc.ocp.solve(intervals=N, accuracy=None)


def node_lateral(sol) -> np.ndarray:
    """u1^2 tan(phi) / d of the (tractor's) rear axle, from the node columns."""
    cols = sol.columns
    return cols["u1"] ** 2 * np.tan(cols["phi"]) / sol.ocp.vehicle.wheelbase


@pytest.fixture(scope="module")
def bounded():
    """Both examples, time-optimal with |a_lat| <= 2 m/s^2."""
    return {p.stem: solve(p, bounds__lateral_acceleration=[-BOUND, BOUND]) for p in (TRUCK, SEMITRAILER)}


@pytest.fixture(scope="module")
def truck_plain():
    return solve(TRUCK)


@pytest.fixture(scope="module")
def truck_smooth():
    return solve(TRUCK, problem__steering_weight=1.0)


# -- the expression, once per vehicle ------------------------------------------------------------


@pytest.mark.parametrize("model", sorted(VEHICLES))
def test_the_lateral_acceleration_is_speed_times_yaw_rate(model):
    v = VEHICLES[model]()
    f = v.dynamics()
    theta = sym("theta")
    speed = f["x"] * sp.cos(theta) + f["y"] * sp.sin(theta)
    assert sp.simplify(v.lateral_acceleration - speed * f["theta"]) == 0


def test_a_vehicle_without_the_expression_cannot_be_bounded():
    @dataclass
    class Point(Vehicle):
        model = "point"
        states = ("x", "y")
        controls = ("u1", "u2")
        roles = Roles(heading=None, steering=None, speed=None, steering_rate=None)  # a point: a position only

        def dynamics(self):
            return {"x": sym("u1"), "y": sym("u2")}

    with pytest.raises(InputError) as err:
        OCP(
            vehicle=Point(), cost=Time(), bounds={"u1": (-1, 1), "u2": (-1, 1), "lateral_acceleration": (-2, 2)},
            initial={"x": 0.0, "y": 0.0}, final={"x": 1.0, "y": 0.0},
        )  # fmt: skip
    assert err.value.key == "bounds.lateral_acceleration"
    assert "defines no lateral-acceleration expression" in str(err.value)


# -- bad input -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ([2.0, -2.0], "below the upper bound"),
        ([2.0, 2.0], "below the upper bound"),
        ([0.5, 2.0], "must contain 0"),
        ([-2.0, -0.5], "must contain 0"),
        ([-float("inf"), 2.0], "finite"),
        ([-2.0, float("nan")], "finite"),
        (["a", 2.0], "two numbers"),
        ([2.0], "two numbers"),
        (2.0, "two numbers"),
        ([True, 2.0], "two numbers"),
    ],
)
def test_bad_lateral_acceleration_bounds_name_the_key(value, words):
    with pytest.raises(InputError) as err:
        parse_scenario(document(TRUCK, bounds__lateral_acceleration=value))
    assert err.value.key == "bounds.lateral_acceleration"
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("value", "objective", "words"),
    [
        (-1.0, "time", ">= 0"),
        (float("inf"), "time", ">= 0"),
        ("a", "time", "must be a number"),
        (True, "time", "must be a number"),
        (1.0, "energy", "time objective only"),
    ],
)
def test_bad_steering_weights_name_the_key(value, objective, words):
    data = document(TRUCK, problem__steering_weight=value, problem__objective=objective)
    if objective == "energy":
        data["problem"]["final_time"] = 20.0
    with pytest.raises(InputError) as err:
        parse_scenario(data)
    assert err.value.key == "problem.steering_weight"
    assert words in str(err.value)


def test_the_command_exits_2_with_one_line_naming_the_key(tmp_path):
    text = TRUCK.read_text().replace("phi = [-0.6, 0.6]", "phi = [-0.6, 0.6]\nlateral_acceleration = [3.0, 2.0]")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    run = subprocess.run([sys.executable, "-m", "model.cli", "check", str(path)], capture_output=True, text=True)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "bounds.lateral_acceleration" in lines[0]


# -- the cost and the Pontryagin system ------------------------------------------------------------


def test_the_steering_weight_is_part_of_the_lagrangian_and_derive_reads_it():
    sc = parse_scenario(document(SEMITRAILER, problem__steering_weight=0.5, bounds__lateral_acceleration=[-2, 2]))
    u2 = sym("u2")
    assert sp.simplify(sc.ocp.cost.lagrangian(sc.ocp.vehicle) - (1 + u2**2 / 2)) == 0
    pmp = sc.ocp.pmp()
    law = pmp.law("u2")
    assert law.kind == "projection" and sp.simplify(law.stationary - sym("p_phi")) == 0
    assert pmp.law("u1").kind == "bang-singular"
    assert any("lateral_acceleration" in note for note in pmp.notes)
    assert Time().lagrangian(sc.ocp.vehicle) == 1  # the plain time cost is unchanged


def test_derive_prints_the_weighted_system():
    path = ROOT / "workflows" / "roads" / "semitrailer-left-turn-design.toml"
    run = subprocess.run([sys.executable, "-m", "model.cli", "derive", str(path)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "u2**2" in run.stdout and "u2 = clip(" in run.stdout


# -- solves ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("example", [TRUCK.stem, SEMITRAILER.stem])
def test_the_bound_holds_at_the_nodes_and_within_5_percent_between_them(bounded, example):
    sol = bounded[example]
    assert sol.ok, sol.status
    assert np.max(np.abs(node_lateral(sol))) <= BOUND + 1e-6
    measured = sol.summary()["lateral_acceleration"]
    assert measured["max_abs_nodes"] == pytest.approx(np.max(np.abs(node_lateral(sol))), abs=1e-9)
    assert measured["max_abs_dense"] <= 1.05 * BOUND
    assert measured["max_abs_dense"] >= measured["max_abs_nodes"] - 1e-9  # the dense samples include the nodes
    assert sol.validation["checks"]["lateral_acceleration_dense"]["passed"]


def test_the_bound_binds_and_costs_time(bounded, truck_plain):
    plain = truck_plain.summary()["lateral_acceleration"]["max_abs_nodes"]
    assert plain > 1.5 * BOUND  # time-optimal: far beyond a comfortable lateral acceleration
    assert bounded[TRUCK.stem].final_time > truck_plain.final_time
    cert = bounded[TRUCK.stem].certificate
    assert cert["passed"] is None and "lateral_acceleration" in cert["not_applicable"]


def test_the_steering_weight_reduces_the_sign_changes_of_u2(truck_plain, truck_smooth):
    assert truck_plain.ok and truck_smooth.ok
    before = steering_changes(truck_plain.ocp, truck_plain.columns)
    after = steering_changes(truck_smooth.ocp, truck_smooth.columns)
    assert before >= 10  # bang-bang
    assert after < before / 2


def test_the_weighted_objective_is_the_final_time_plus_the_steering_integral(truck_smooth):
    s = truck_smooth.summary()
    assert s["steering_weight"] == 1.0
    assert s["objective"] == pytest.approx(s["final_time"] + s["steering_integral"], rel=1e-9)
    assert s["objective"] > s["final_time"]


def test_a_scenario_without_the_keys_is_unchanged():
    before = tomllib.loads(TRUCK.read_text())
    sc = parse_scenario(copy.deepcopy(before))
    assert "lateral_acceleration" not in sc.ocp.bounds
    assert sc.ocp.cost == Time()
