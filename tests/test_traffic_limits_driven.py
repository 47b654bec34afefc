"""model.traffic.run.limits_driven: what the truck drove against its bounds, row by row."""

from __future__ import annotations

import numpy as np
import pytest

from model.problem.scenario import load_scenario
from model.traffic.run import limits_driven

TEMPLATE = "workflows/scenarios/traffic/truck.toml"


def rows(ocp, speed: float, steering: float, n: int = 5) -> dict[str, np.ndarray]:
    """Constant rows: straight ahead at ``speed`` with the wheels at ``steering`` (rad)."""
    v = ocp.vehicle
    cols = {name: np.zeros(n) for name in v.states + v.controls}
    cols["t"] = np.linspace(0.0, 0.4, n)
    cols[v.roles.speed] = np.full(n, speed)
    cols[v.roles.steering] = np.full(n, steering)
    return cols


def test_a_run_within_its_bounds_keeps_them_and_one_beyond_the_lateral_bound_does_not():
    ocp = load_scenario(TEMPLATE).ocp
    d = ocp.vehicle.parameters()["d"]
    bound = ocp.bounds["lateral_acceleration"][1]
    speed = 6.0
    inside = np.arctan(0.9 * bound * d / speed**2)  # a_lat = v^2 tan(phi) / d = 0.9 x the bound
    kept = limits_driven(load_scenario(TEMPLATE), rows(ocp, speed, inside))
    assert kept["within"] and kept["lateral_acceleration"]["max"] == pytest.approx(0.9 * bound)
    beyond = np.arctan(1.01 * bound * d / speed**2)  # 1 % over: no tolerance hides it
    broken = limits_driven(load_scenario(TEMPLATE), rows(ocp, speed, beyond))
    assert not broken["within"] and not broken["lateral_acceleration"]["within"]
    assert broken[ocp.vehicle.roles.speed]["within"]
