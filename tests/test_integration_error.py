"""Accuracy that scales with the manoeuvre (issue 22, item 4): the one-step integration error against the clearance."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from model.analysis.validation import INTEGRATION_TOL, one_step, validate
from model.problem.scenario import parse_scenario
from tests.conftest import ROOT


def lane_drive(steer_rate: float, intervals: int = 3, seconds: float = 6.0, speed: float = 4.0) -> tuple:
    """Straight down the middle of the entry lane, phi = 0 at every node, u2 = +-steer_rate alternating.

    The trapezoid rule sees nothing (phi's defect is h/2 (u2_k + u2_k+1) = 0, tan(phi) = 0 at the
    nodes), but the controls, integrated between the nodes, steer the truck off the line.
    """
    doc = tomllib.loads((ROOT / "examples" / "roundabout-truck.toml").read_text())
    ocp = parse_scenario(doc).ocp
    t = np.linspace(0.0, seconds, intervals + 1)
    x = ocp.initial["x"] + speed * t
    traj = {"t": t, "x": x, "y": np.full_like(t, ocp.initial["y"]), "theta": np.zeros_like(t),
            "phi": np.zeros_like(t), "u1": np.full_like(t, speed),
            "u2": steer_rate * (-1.0) ** np.arange(intervals + 1)}  # fmt: skip
    return ocp, traj, seconds


def test_the_trapezoid_rule_cannot_see_steering_between_the_nodes():
    ocp, traj, tf = lane_drive(0.5)
    result = validate(ocp, traj, tf)
    assert result["checks"]["defects"]["passed"] and result["checks"]["body_clearance"]["passed"]
    error = result["measures"]["integration_error"]
    assert error["integration_error_max"] > 1.0 and error["body_error"] > error["clearance"] > 0.5
    assert error["within_clearance"] is False
    # the integrated motion leaves the 4 m lane: the check fails, with the numbers
    assert result["measures"]["min_clearance_integrated"] < -1.0
    assert not result["checks"]["dense_clearance"]["passed"] and not result["passed"]


def test_without_the_steering_the_same_drive_is_exact():
    ocp, traj, tf = lane_drive(0.0)
    result = validate(ocp, traj, tf)
    assert result["measures"]["integration_error"]["integration_error_max"] < 1e-6 < INTEGRATION_TOL
    assert result["measures"]["integration_error"]["within_clearance"] and result["checks"]["dense_clearance"]["passed"]
    assert result["measures"]["min_clearance_integrated"] == pytest.approx(0.75, abs=1e-6)  # 4 m lane, 2.5 m truck


def test_one_step_starts_every_interval_at_its_node():
    ocp, traj, _ = lane_drive(0.5)
    v = ocp.vehicle
    X = np.array([traj[s] for s in v.states])
    paths = one_step(ocp, traj["t"], X, np.array([traj[c] for c in v.controls]))
    assert paths.shape == (len(v.states), 3, 11)
    assert np.array_equal(paths[:, :, 0], X[:, :-1])
    phi = paths[v.states.index("phi")]
    assert phi[:, -1] == pytest.approx(0.0, abs=1e-9)  # u2 linear from +a to -a: phi back to 0 at the node
    assert np.max(np.abs(phi)) == pytest.approx(0.5 * 2.0 / 4, rel=1e-6)  # a h / 4 half way
