"""Solving: the paper's scenarios, analytic cases, costate signs, failures."""

import json

import numpy as np
import pytest

from model import InputError
from model.analysis.validation import validate
from model.problem.scenario import load_scenario
from tests.conftest import SCENARIOS, paper_energy_problem, straight_energy, straight_time


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_paper_scenario_solves_and_validates(path):
    sc = load_scenario(path)
    sol = sc.ocp.solve(intervals=sc.intervals)
    assert sol.status == "optimal", sol.solver_message
    assert sol.validation["passed"], sol.validation["checks"]
    # the requested grid, or twice it where the re-integrated goal drift asked for it
    assert len(sol.trajectory) == sol.intervals + 1
    assert sol.intervals == sc.intervals or (sol.accuracy["intervals_requested"] == sc.intervals
                                             and sol.intervals == 2 * sc.intervals)  # fmt: skip
    assert sol.accuracy["reached"]
    # the energy can never exceed what the control bounds allow
    (a, b), (c, d) = sc.ocp.bounds["u1"], sc.ocp.bounds["u2"]
    assert 0 < sol.energy <= 0.5 * (max(a * a, b * b) + max(c * c, d * d)) * sol.final_time


def test_time_optimal_straight_drive_takes_length_over_top_speed():
    sol = straight_time(length=1.0).solve(intervals=50)
    assert sol.ok
    assert sol.final_time == pytest.approx(1.0 / 1.0, rel=1e-6)
    assert np.allclose(sol.trajectory["u1"], 1.0, atol=1e-6)
    # free final time: H = 0 along the extremal, p_x = 1 / u1max
    assert np.allclose(sol.trajectory["H"], 0.0, atol=1e-6)
    assert np.allclose(sol.trajectory["p_x"], 1.0, atol=1e-6)


def test_energy_straight_drive_costate_sign_and_scale():
    """u1 = L/Tf is optimal, and the maximum condition u1 = p_x cos(theta) fixes p_x = L/Tf > 0."""
    sol = straight_energy(length=1.0, tf=2.0).solve(intervals=40)
    assert sol.ok
    tr = sol.trajectory
    assert np.allclose(tr["u1"], 0.5, atol=1e-7)
    assert np.allclose(tr["p_x"], 0.5, atol=1e-7)
    assert sol.energy == pytest.approx(0.5 * 0.5**2 * 2.0, rel=1e-9)
    assert np.allclose(tr["H"], 0.5 * 0.5**2, atol=1e-7)  # H = -L + p.f = u1^2/2


def test_costates_satisfy_the_maximum_condition_with_an_obstacle(example_solution):
    tr = example_solution.trajectory
    assert example_solution.ok
    # energy problem: u = projection of the unconstrained maximiser psi onto the box
    # up to Ipopt's complementarity tolerance (compl_inf_tol = 1e-4): next to a bound,
    # |u - clip(psi)| = z / h with z * gap <= 1e-4, i.e. a few 1e-4 at the most
    assert np.max(np.abs(np.clip(tr["psi_u1"], -1, 1) - tr["u1"])) < 1e-3
    assert np.max(np.abs(np.clip(tr["psi_u2"], -0.35, 0.35) - tr["u2"])) < 1e-3
    assert (tr["mu"] >= 0).all()
    # autonomous: H constant along each arc off the obstacle; across a touch point the
    # discrete jump of p changes H by O(h) only (it is continuous in the limit)
    h, touching = tr["H"].to_numpy(), tr["mu"].to_numpy() > 1e-3
    assert touching.any()
    cuts = np.flatnonzero(touching)
    arcs = [h[1 : cuts[0] - 1], h[cuts[-1] + 2 : -1]]  # end nodes carry half-step costates
    for arc in arcs:
        assert len(arc) > 10 and np.ptp(arc) < 0.02 * abs(np.median(arc))
    assert abs(np.median(arcs[0]) - np.median(arcs[1])) < 0.05 * abs(np.median(h))


def test_validation_rejects_a_perturbed_solution(example_solution):
    tr = example_solution.trajectory[["t", "x", "y", "theta", "phi", "u1", "u2"]].copy()
    tr.loc[50, "y"] += 1e-3
    report = validate(example_solution.ocp, tr, example_solution.final_time, "ccw")
    assert not report["passed"] and not report["checks"]["defects"]["passed"]


def test_infeasible_final_time_is_reported_as_failure():
    sol = paper_energy_problem(tf=2.0).solve(intervals=40)
    assert sol.status != "optimal" and not sol.ok


def test_energy_without_final_time_is_an_input_error():
    with pytest.raises(InputError, match="final_time"):
        straight_energy().__class__(
            vehicle=straight_energy().vehicle,
            bounds=straight_energy().bounds,
            initial=straight_energy().initial,
            final_time=None,
        )


def test_summary_is_full_precision_json(example_solution, tmp_path):
    example_solution.write(tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    for key in (
        "status",
        "objective",
        "final_time",
        "energy",
        "intervals",
        "iterations",
        "solve_seconds",
        "min_clearance",
    ):
        assert key in summary
    header = (tmp_path / "trajectory.csv").read_text().splitlines()[0]
    assert header.startswith("t,x,y,theta,phi,u1,u2,")
    row = (tmp_path / "trajectory.csv").read_text().splitlines()[30].split(",")
    assert max(len(v.replace("-", "").replace(".", "").lstrip("0")) for v in row) >= 12


def test_pass_direction_holds_on_a_coarse_grid():
    """With 5 intervals a step sweeps more than 90 degrees; the constraint must still hold."""
    solved = {}
    for passing in ("ccw", "cw"):
        ocp = paper_energy_problem()
        ocp.passing = passing
        sol = ocp.solve(intervals=5)
        solved[passing] = sol.ok
        if sol.ok:  # never a solution going round the wrong way
            swept = sol.validation["measures"]["swept_angle"]
            assert swept > 0 if passing == "ccw" else swept < 0
    assert solved["ccw"]


def test_a_drifting_solution_is_refined_on_a_finer_grid_until_its_goal_drift_is_within_tolerance():
    from model.search.accuracy import goal_drift

    ocp = load_scenario(SCENARIOS[0].parent / "s3.toml").ocp
    coarse = ocp.solve(intervals=40, accuracy=None)  # 40 steps: the heading at the goal drifts 6.7x too far
    assert coarse.ok and goal_drift(coarse)[0] > 1.0
    refined = ocp.solve(intervals=40)
    assert refined.intervals == 80 and refined.accuracy["intervals_requested"] == 40
    assert goal_drift(refined)[0] < goal_drift(coarse)[0] / 3  # second order: about 4x smaller


def test_weighted_energy_from_a_scenario_file_trades_steering_for_speed():
    import tomllib

    from model.problem.scenario import parse_scenario

    doc = tomllib.loads((SCENARIOS[0].parent / "s2-case1.toml").read_text())
    plain = parse_scenario(doc).ocp.solve(intervals=60)
    doc["problem"]["weights"] = {"u1": 1, "u2": 4}
    weighted = parse_scenario(doc).ocp.solve(intervals=60)
    assert plain.ok and weighted.ok and weighted.certificate["passed"]
    cols_p, cols_w = plain.columns, weighted.columns
    steer = [float(np.trapezoid(c["u2"] ** 2, c["t"])) for c in (cols_p, cols_w)]
    assert steer[1] < steer[0]  # steering costs 4x: the optimum steers less
    assert weighted.objective > weighted.energy  # the objective is the weighted J, energy the plain one
    for bad, says in (({"u3": 1}, "unknown"), ({"u1": 0}, "> 0"), (3, "table")):
        doc["problem"]["weights"] = bad
        with pytest.raises(InputError, match=says):
            parse_scenario(doc)
