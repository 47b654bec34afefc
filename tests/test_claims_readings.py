"""Tests of the readings checks (derivations/paper/claims_readings.py): the computed quantities, then the verdicts."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from derivations.paper import claims, claims_readings
from derivations.paper.checking import CORRECTED, FAILS, compare
from derivations.paper.claims_energy import energy
from derivations.paper.claims_time import straight, without_obstacle
from derivations.paper.extremals import holds_all, on_extremal, verify

IDS = ["sec57.J_CTf.from_cost", "sec57.energy_vs_time", "sec6.bang_bang_energy", "sec44.constant_phase_bang",
       "sec5.geometry.radial_projection"]
C, TF, L = claims_readings.C, claims_readings.TF, claims_readings.L


@pytest.fixture(scope="module")
def readings():
    return {c.id: c for c in claims_readings.claims()}


def test_constant_norm_cost_is_half_c_tf_from_16_and_32():
    j16, j32 = claims_readings.cost_on_constant_norm()
    assert compare(j16, C * TF / 2).equal and compare(j32, C * TF / 2).equal
    assert not compare(j16, C * TF).equal


def test_straight_drive_energy_falls_with_final_time():
    j = claims_readings.straight_energy(energy())
    assert compare(j, L**2 / (2 * TF)).equal
    assert compare(sp.diff(j, TF), -(L**2) / (2 * TF**2)).equal
    assert j.subs({L: 1, TF: 2.5}) < j.subs({L: 1, TF: 1.53})
    assert holds_all(verify(energy(), claims_readings.straight_energy_extremal(1 / 1.53, 1.53)))


def test_energy_maximiser_is_continuous_and_ramps():
    lips = claims_readings.clip_lipschitz(energy())
    assert all(0.99 < v <= 1 + 1e-9 for v in lips.values())
    run = claims_readings.saturating_extremal()
    assert run["clearance"].min() > 0
    steps = list(claims_readings.largest_steps(run).values())
    assert steps == sorted(steps, reverse=True) and steps[-1] < 1e-3  # a jump of 0.7 would not shrink
    start, end = claims_readings.ramp(run)
    assert end - start > 0.1
    assert run["u2"].max() == pytest.approx(0.35) and run["u2"].min() == pytest.approx(-0.35)


def test_constant_phase_extremals_are_not_bang():
    energy_case = claims_readings.phase_case(energy(), claims_readings.straight_energy_extremal(0.5, 1.0))
    assert holds_all(energy_case["pmp"]) and energy_case["rate"] == 0 and not energy_case["bang"]
    assert energy_case["switching"] == [0.0, 0.0] and energy_case["u"] == [0.5, 0.0]
    sys_t = without_obstacle()
    ext = straight(sys_t)
    time_case = claims_readings.phase_case(sys_t, ext)
    assert holds_all(time_case["pmp"]) and time_case["rate"] == 0 and not time_case["bang"]
    assert sys_t.singular_arc("u2", max_order=4, on=on_extremal(sys_t, ext)).order == 4


def test_radial_projection_arc_exceeds_every_reach():
    centre = np.array([0.5, 0.03])
    a, b = np.array([0.0, 0.0]) - centre, np.array([1.0, 0.0]) - centre
    angle = math.acos(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    geo = claims_readings.radial_projection()
    assert geo["arc"] == pytest.approx(angle, abs=1e-12) and geo["arc"] == pytest.approx(3.0217, abs=1e-4)
    assert geo["on_circle"] == pytest.approx(geo["arc"], abs=1e-9)
    assert geo["scan_min"] >= geo["arc"] - 1e-9
    assert geo["arc"] > 1.0 * 2.5  # u1max times the longest printed Tf
    rho, r = sp.Symbol("rho", positive=True), sp.Symbol("r", positive=True)
    assert compare(claims_readings.radial_length_slope(), sp.sqrt(rho**2 - r**2) / rho).equal


def test_verdicts_and_evidence(readings):
    assert list(readings) == IDS
    assert readings["sec57.J_CTf.from_cost"].verdict.startswith(CORRECTED)
    assert all(readings[i].status == FAILS for i in IDS[1:])
    assert "3.02174" in readings["sec5.geometry.radial_projection"].evidence
    assert "0.2 at Tf = 2.5" in readings["sec57.energy_vs_time"].evidence
    assert "0.858713" in readings["sec57.J_CTf.from_cost"].evidence


def test_registered_in_all_claims():
    assert claims_readings in claims.MODULES
