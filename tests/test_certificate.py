"""The PMP certificate passes on real solves and fails visibly on perturbed ones."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from model.analysis.certificate import certify_trajectory
from model.problem.costs import Time
from model.problem.scenario import load_scenario
from tests.conftest import ROOT

S2 = ROOT / "workflows" / "scenarios" / "s2-case1.toml"


@pytest.fixture(scope="module")
def energy_solution():
    return load_scenario(S2).ocp.solve(intervals=60)


@pytest.fixture(scope="module")
def time_solution():
    ocp = load_scenario(S2).ocp
    return dataclasses.replace(ocp, cost=Time(), final_time=None).solve(intervals=60)


@pytest.mark.parametrize("which", ["energy_solution", "time_solution"])
def test_certificate_passes_and_is_in_summary(which, request):
    sol = request.getfixturevalue(which)
    assert sol.ok
    cert = sol.summary()["certificate"]
    assert cert["passed"], cert
    for name in ("adjoint", "hamiltonian", "maximum", "transversality", "complementarity"):
        item = cert["items"][name]
        assert set(item) >= {"value", "tolerance", "passed"}
    assert cert["items"]["adjoint"]["value"] < 1e-6
    if which == "time_solution":
        assert cert["items"]["hamiltonian"]["reference"] == 0.0


def _failed(sol, column: str, change) -> set[str]:
    traj = sol.trajectory.copy()
    traj[column] = change(traj[column].to_numpy().copy())
    cert = certify_trajectory(sol.ocp, traj)
    assert not cert["passed"]
    return {k for k, v in cert["items"].items() if not v["passed"]}


def _bump(values: np.ndarray, size: float) -> np.ndarray:
    values[len(values) // 3] += size
    return values


@pytest.mark.parametrize("which", ["energy_solution", "time_solution"])
def test_perturbed_costate_fails_adjoint(which, request):
    sol = request.getfixturevalue(which)
    assert "adjoint" in _failed(sol, "p_theta", lambda p: _bump(p, 0.05))


@pytest.mark.parametrize("which", ["energy_solution", "time_solution"])
def test_perturbed_state_fails_adjoint(which, request):
    sol = request.getfixturevalue(which)
    assert "adjoint" in _failed(sol, "theta", lambda th: _bump(th, 0.02))


def test_perturbed_control_fails_maximum_condition(energy_solution, time_solution):
    assert "maximum" in _failed(energy_solution, "u1", lambda u: u * 0.9)
    failed = _failed(time_solution, "u2", lambda u: np.clip(-u, -0.35, 0.35))
    assert "maximum" in failed


def test_scaled_costates_fail_hamiltonian_of_time_problem(time_solution):
    assert "hamiltonian" in _failed(time_solution, "p_x", lambda p: p + 0.5)
