"""The road MPC benchmark's Opti peer (benchmarks/bench_mpc_road.py) solves the MPC's own horizon problem."""

import numpy as np
import pytest

from benchmarks.bench_mpc_road import OptiPeer, Shadowed
from model.problem.closed_loop import ControlSettings
from model.problem.scenario import load_scenario
from model.simulation.mpc import MPC, MPCSettings
from tests.conftest import ROOT


@pytest.fixture(scope="module")
def road():
    sc = load_scenario(ROOT / "workflows" / "roads" / "truck-straight-on.toml")
    return sc.ocp.solve(intervals=sc.intervals)


def test_the_opti_peer_solves_the_mpcs_horizon_problem(road):
    """Same rows, Params, bounds and warm start: the peer's optimum has the MPC's first controls."""
    ipopt = {**MPCSettings().ipopt, "tol": 1e-9, "acceptable_iter": 0, "max_iter": 300}
    mpc = MPC(road, ControlSettings(0.1, 20), settings=MPCSettings(budget=100.0, ipopt=ipopt))
    peer = OptiPeer(mpc)
    shadow = Shadowed(mpc, peer)
    cols = road.columns
    for t in (0.0, 0.1):
        y = np.array([np.interp(t, cols["t"], cols[k]) for k in road.ocp.vehicle.states])
        y[1] += 0.1
        shadow.make_step(t, y, np.zeros((0, 2)))
        assert mpc.steps[-1]["status"] == "optimal"
        assert peer.status[-1] == "Solve_Succeeded"
        assert peer.du[-1] < 1e-4
    assert len(peer.seconds) == 2
