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


def test_a_failed_finer_re_solve_keeps_the_search_evidence(tmp_path, monkeypatch):
    """The accuracy refinement may keep a failed 2N re-solve (between-node checks): its answer must carry the
    search's diagnosis (the design table's WB-62 cells ended as 'validation_failed' with none)."""
    import copy

    import model.search.multistart as multistart

    def refine(sol, solve, accuracy, progress):  # a finer grid's failed re-solve, with no diagnosis of its own
        finer = copy.copy(sol)
        finer.diagnosis, finer.intervals, finer.status = None, 2 * sol.intervals, "validation_failed"
        finer.validation = {**sol.validation, "checks": {"dense_clearance": {"passed": False}}}
        return finer, {}

    monkeypatch.setattr(multistart, "refine_for_accuracy", refine)
    text = EXAMPLE.read_text().replace("final_time = 4.5", "final_time = 1.2")
    path = tmp_path / "short.toml"
    path.write_text(text.replace("intervals = 100", "intervals = 30"))
    sol = load_scenario(path).ocp.solve(intervals=30)
    assert not sol.ok and sol.status == "validation_failed"
    d = sol.diagnosis
    assert d["kind"] == "solver" and d["refined_to"] == {"intervals": 60, "status": "validation_failed",
                                                         "failed_checks": ["dense_clearance"]}
    assert "no infeasibility proof" in d["message"] and "re-solved on N = 60" in d["message"]
