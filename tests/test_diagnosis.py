"""The diagnosis of a failed solve: a proven bound where one exists, else what the solver ended with."""

from __future__ import annotations

import math

from model import OCP, Energy, Truck, load_scenario
from tests.conftest import EXAMPLE


def test_a_final_time_below_the_reeds_shepp_bound_is_proven_infeasible():
    """Goal 1 m ahead but turned round: the shortest path is longer than u1max * Tf, so no solver can succeed."""
    ocp = OCP(vehicle=Truck(wheelbase=0.5), cost=Energy(), final_time=1.2,
              bounds={"u1": (-1.0, 1.0), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)},
              initial={"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}, final={"x": 1.0, "y": 0.0, "theta": math.pi})
    sol = ocp.solve(intervals=30)
    assert not sol.ok
    d = sol.diagnosis
    assert d["kind"] == "proven bound" and d["minimum_time_lower_bound_s"] > 1.2
    assert "below" in d["message"] and "\n" not in d["message"]


def test_without_a_proof_the_diagnosis_says_so(tmp_path):
    """Tf = 1.2 s clears the obstacle-free bound (1 m at 1 m/s) but not the detour: no proof, the solver's evidence."""
    text = EXAMPLE.read_text().replace("final_time = 4.5", "final_time = 1.2")
    text = text.replace("intervals = 100", "intervals = 30")
    path = tmp_path / "short.toml"
    path.write_text(text)
    sol = load_scenario(path).ocp.solve(intervals=30)
    assert not sol.ok
    assert sol.diagnosis["kind"] == "solver" and "no infeasibility proof" in sol.diagnosis["message"]
    assert sol.diagnosis["last_primal_infeasibility"] > 1e-3
