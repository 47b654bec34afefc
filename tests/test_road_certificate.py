"""The PMP certificate of road solves: the bodies' corridor rows (and the articulation bound) adjoined.

Each body's island and corridor rows enter H with their NLP multipliers (trajectory columns
``mu_<body>_<kind>``), so the discrete adjoint holds on a road; a perturbed road multiplier, or a
trajectory without the gradients, must not pass silently.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from derivations.pmp import render_pmp
from model.analysis.certificate import certify_trajectory
from model.problem.scenario import load_scenario
from tests.conftest import ROOT

TRUCK = ROOT / "examples" / "roundabout-truck.toml"
SEMI = ROOT / "examples" / "roundabout-semitrailer.toml"


@pytest.fixture(scope="module")
def truck():
    return load_scenario(TRUCK).ocp.solve(intervals=40, search="quick", accuracy=None)


@pytest.fixture(scope="module")
def semitrailer():
    return load_scenario(SEMI).ocp.solve(intervals=40, search="quick", accuracy=None)


@pytest.fixture(scope="module")
def jackknife_limited():
    """The semitrailer with the articulation held to 0.4 rad: the bound is active on both sides."""
    ocp = load_scenario(SEMI).ocp
    ocp = dataclasses.replace(ocp, bounds={**ocp.bounds, "articulation": (-0.4, 0.4)})
    return ocp.solve(intervals=40, search="quick", accuracy=None)


@pytest.mark.parametrize("which", ["truck", "semitrailer"])
def test_road_certificate_passes_with_nonzero_road_multipliers(which, request):
    sol = request.getfixturevalue(which)
    assert sol.ok
    cert = sol.summary()["certificate"]
    assert cert["passed"] is True, cert
    assert "not_applicable" not in cert
    assert cert["items"]["adjoint"]["value"] < 1e-6
    assert cert["items"]["adjoint"]["judged_nodes"] >= 30
    for name in ("hamiltonian", "transversality", "complementarity", "multiplier_sign"):
        assert cert["items"][name]["passed"] is True, name
    bodies = ["vehicle"] + (["trailer"] if which == "semitrailer" else [])
    families = [f"{b}_{k}" for b in bodies for k in ("island", "corridor")]
    assert set(cert["adjoined"]) >= set(families)
    for f in families:
        mu = sol.trajectory[f"mu_{f}"].to_numpy()
        assert (mu >= -1e-9).all()
    assert max(float(sol.trajectory[f"mu_{f}"].max()) for f in families) > 1e-2  # the corridor holds the body
    assert (sol.trajectory["mu"] == 0).all()  # the disc-obstacle column keeps its meaning
    if which == "semitrailer":
        assert "mu_articulation" in sol.trajectory


def _road_family(sol) -> str:
    """The road family with the largest multiplier."""
    return max(sol.adjoined, key=lambda a: float(np.max(np.abs(sol.columns[f"mu_{a.name}"])))).name


def test_perturbed_road_multiplier_fails_adjoint(truck):
    traj = truck.trajectory.copy()
    assert certify_trajectory(truck.ocp, traj, adjoined=truck.adjoined)["passed"] is True
    name = f"mu_{_road_family(truck)}"
    mu = traj[name].to_numpy().copy()
    k = int(np.argmax(mu))
    mu[k] *= 1.2
    traj[name] = mu
    cert = certify_trajectory(truck.ocp, traj, adjoined=truck.adjoined)
    assert cert["passed"] is False
    assert cert["items"]["adjoint"]["passed"] is False


def test_active_articulation_bound_is_adjoined(jackknife_limited):
    sol = jackknife_limited
    assert sol.ok
    cert = sol.certificate
    assert cert["passed"] is True, cert
    assert cert["items"]["adjoint"]["value"] < 1e-6
    mu = sol.columns["mu_articulation"]
    angle = sol.columns["theta"] - sol.columns["theta1"]
    upper, lower = angle > 0.4 - 1e-6, angle < -0.4 + 1e-6
    assert upper.any() and lower.any()
    assert mu[upper].min() < -1e-2 and mu[lower].max() > 1e-2  # signed: <= 0 at the upper bound, >= 0 at the lower
    assert (np.abs(mu[~(upper | lower)]) < 1e-3).all()
    traj = sol.trajectory.copy()
    traj["mu_articulation"] = 0.0
    assert certify_trajectory(sol.ocp, traj, adjoined=sol.adjoined)["items"]["adjoint"]["passed"] is False


def test_dropped_road_multipliers_fail_adjoint(truck):
    traj = truck.trajectory.copy()
    for a in truck.adjoined:
        traj[f"mu_{a.name}"] = 0.0
    cert = certify_trajectory(truck.ocp, traj, adjoined=truck.adjoined)
    assert cert["items"]["adjoint"]["passed"] is False
    assert cert["items"]["adjoint"]["value"] > 1e-3  # what the certificate measured before the rows were adjoined


def test_road_trajectory_alone_is_not_applicable_with_a_reason(truck):
    cert = certify_trajectory(truck.ocp, truck.trajectory)
    for name in ("adjoint", "hamiltonian", "transversality"):
        item = cert["items"][name]
        assert item["status"] == "not applicable"
        assert "corridor" in item["reason"]
    assert set(cert["not_applicable"]) == {"adjoint", "hamiltonian", "transversality"}
    assert cert["items"]["maximum"]["passed"] is True
    assert cert["passed"] is None  # not established: neither a silent false nor a true without the adjoint


def test_derive_prints_the_adjoined_road_terms():
    text = render_pmp(load_scenario(TRUCK).ocp)
    assert "Path constraints adjoined to H" in text
    assert "vehicle_corridor: mu_vehicle_corridor[i]" in text and "vehicle_island" in text
    p_x = next(line for line in text.splitlines() if line.strip().startswith("p_x' ="))
    assert "mu_vehicle_corridor[i]" in p_x and "c_vehicle_corridor_X[i]" in p_x
    assert "adjoined to H" in text and "corridor" in text.split("Note:")[-1]
    latex = render_pmp(load_scenario(TRUCK).ocp, fmt="latex")
    assert "mu_{vehicle corridor}" in latex or "vehicle_corridor" in latex


def test_derive_of_the_semitrailer_adjoins_the_articulation_bound():
    text = render_pmp(load_scenario(SEMI).ocp)
    p_theta1 = next(line for line in text.splitlines() if line.strip().startswith("p_theta1' ="))
    assert "mu_articulation" in p_theta1 and "mu_trailer_corridor[i]" in p_theta1
    assert "articulation" not in next(line for line in text.splitlines() if "are not adjoined" in line)
