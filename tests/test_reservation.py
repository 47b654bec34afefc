"""The ``reservation`` driver: first come, first served on the ring's conflict areas (after Dresner and Stone)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from model.problem.scenario import load_scenario
from model.traffic.cooperative import Cooperator
from model.traffic.reservation import ARRIVAL_DISTANCE, Reservation, arrival_time

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "traffic-roundabout.toml"


def straight(s):
    """Straight in along leg 0 (from 180 deg, heading +x) at 5 m/s from x = -40 m."""
    s = np.atleast_1d(np.asarray(s, float))
    return {"x": -40.0 + 5.0 * s, "y": 0 * s, "theta": 0 * s, "phi": 0 * s}


@pytest.fixture(scope="module")
def ocp():
    return load_scenario(EXAMPLE).ocp


def test_the_truck_arrives_when_its_front_comes_within_the_arrival_distance_of_the_outer_curb(ocp):
    """The front bumper 6.5 m ahead of the rear axle: -33.5 + 5 s = -(20 + 10) at s = 0.7 s."""
    outer = ocp.road.roundabout.outer_radius
    expected = (40.0 - 6.5 - outer - ARRIVAL_DISTANCE) / 5.0
    assert arrival_time(ocp, straight, duration=8.0, front=6.5) == pytest.approx(expected, abs=8.0 / 2000)
    assert arrival_time(ocp, straight, duration=0.5, front=6.5) == 0.5  # never within it: the plan's end


def test_only_the_cars_arriving_after_the_truck_are_refused(ocp):
    manager = Reservation(Cooperator(ocp, straight, 8.0, 0.1), arrival=0.7)
    manager.arrived = {"early": 10.0, "there": -math.inf, "same": 12.0}
    assert not manager.later("early") and not manager.later("unknown")  # no reservation of the truck yet
    manager.truck_arrived = 12.0
    assert not manager.later("early") and not manager.later("there")
    assert manager.later("same") and manager.later("unknown")  # a tie, and a car still to arrive


def test_a_reservation_run_keeps_its_distance_and_is_replayed_with_its_speed_commands(tmp_path, contract_replay):
    """``roundabout traffic --driver reservation``: cars arriving after the truck are held out of its windows;
    the contract's replay loop with commands.csv gives traffic.csv (tests/conftest.py, apart from model.traffic)."""
    import csv
    import json

    from model.cli import main

    out = tmp_path / "reservation"
    assert main(["traffic", str(EXAMPLE), "--out", str(out), "--driver", "reservation"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["driver"] == "reservation" and summary["arrived"] and summary["collisions"] == 0
    assert summary["min_distance"] >= 1.0  # the scenario's safety_distance, exact rectangles
    commands: dict[float, dict[str, float]] = {}
    for r in csv.DictReader((out / "sumo" / "commands.csv").open()):
        commands.setdefault(round(float(r["t"]), 6), {})[r["id"]] = float(r["speed"])
    assert commands  # later cars were refused at some steps
    contract_replay(out, commands)
