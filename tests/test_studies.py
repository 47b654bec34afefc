"""Arc structure, chattering detection, observed orders, shooting, continuation, regularisation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from model.analysis.arcs import chattering, control_arcs
from model.indirect.shooting import example_problem, richardson, shoot
from model.problem.costs import Energy, Time
from model.problem.scenario import load_scenario
from model.studies.sweeps import observed_orders, pareto_front
from tests.conftest import ROOT, straight_time


def _frame(u: np.ndarray) -> pd.DataFrame:
    t = np.linspace(0.0, 1.0, len(u))
    return pd.DataFrame({"t": t, "u2": u, "psi_u2": u})


def test_bang_bang_arcs_and_switch_times():
    u = np.where(np.linspace(0, 1, 101) < 0.305, 0.35, -0.35)
    u[31] = 0.0  # the grid's picture of one switch
    arcs = control_arcs(_frame(u), "u2", (-0.35, 0.35))
    assert arcs["structure"] == "+ -"
    assert arcs["switching_times"] == [pytest.approx(0.31, abs=0.011)]
    assert chattering(_frame(u), "u2", (-0.35, 0.35)) == []


def test_chattering_is_detected_and_located():
    u = np.full(101, -0.35)
    u[40:56:2] = 0.35
    spans = chattering(_frame(u), "u2", (-0.35, 0.35))
    assert len(spans) == 1
    assert 0.38 <= spans[0]["t0"] <= 0.41 and 0.53 <= spans[0]["t1"] <= 0.57


def test_observed_orders_and_richardson():
    h = np.array([1, 0.5, 0.25, 0.125])
    values = list(2.0 + 3 * h**2)
    assert observed_orders(values) == [pytest.approx(2.0), pytest.approx(2.0)]
    assert richardson(values) == pytest.approx(2.0)


def test_shooting_matches_extrapolated_direct_solution():
    ocp = example_problem()
    sols = [ocp.solve(intervals=n) for n in (100, 200)]
    assert all(s.ok for s in sols)
    p0 = np.array([sols[0].trajectory[f"p_{s}"].iloc[0] for s in ocp.vehicle.states])
    shot = shoot(ocp, p0)
    assert shot.success and shot.max_control_ratio < 1
    assert abs(shot.objective - richardson([s.objective for s in sols])) < 1e-6


def test_energy_decreases_along_the_front():
    t_min = straight_time(1.0).solve(intervals=40)
    assert t_min.ok and t_min.final_time == pytest.approx(1.0, abs=1e-6)
    energy = dataclasses.replace(t_min.ocp, cost=Energy(), final_time=2.0)
    front = pareto_front(energy, t_min, [1.2, 1.6, 2.4], intervals=40)
    assert front.ok.all()
    assert np.all(np.diff(front.objective) < 0)
    assert front.objective.tolist() == pytest.approx([0.5 / tf for tf in (1.2, 1.6, 2.4)], rel=1e-6)


def test_rate_penalty_smooths_switches_at_a_small_cost_in_time():
    ocp = load_scenario(ROOT / "workflows" / "scenarios" / "time-free.toml").ocp
    plain = ocp.solve(intervals=60)
    smooth = dataclasses.replace(ocp, cost=Time(rate_penalty=1e-4)).solve(intervals=60, guess=plain.trajectory)
    assert plain.ok and smooth.ok
    assert plain.final_time < smooth.final_time < plain.final_time * 1.05


def test_the_time_optimal_section_sets_the_real_truck_beside_a_design_vehicles_limits():
    """The real-scale rows (the seed paper's model, kept) each say their lateral acceleration against the SU-30's
    allowed one; the paper-scale rows (d = 0.02 m, not a vehicle) are not compared."""
    import sys

    from model.vehicles import operational_limits

    scripts = str(ROOT / "workflows" / "scripts")
    sys.path.insert(0, scripts)
    try:
        import studies_time
    finally:
        sys.path.remove(scripts)
    allowed = operational_limits(studies_time.REFERENCE_PRESET).lateral_acceleration
    real = {"name": "time-real-s1", "wheelbase": 5.0, "max_abs_lateral_acceleration": 4.5 * allowed}
    paper = {"name": "time-s1", "wheelbase": 0.02, "max_abs_lateral_acceleration": 4.4}
    lines = studies_time.limits_lines([paper, real])
    assert "without operational limits" in lines[0] and not any("time-s1" in line for line in lines)
    assert (f"- `time-real-s1`: kinematic model without operational limits: max lateral acceleration "
            f"{4.5 * allowed:.2f} m/s^2 (above the SU-30's allowed {allowed:g} m/s^2)") in lines[2]
    assert studies_time.limits_lines([paper]) == []
