"""Warm-started re-solves of a built model after a parameter change."""

from dataclasses import replace

import pytest

from model import Circle
from model.direct.resolve import Resolver
from model.search.multistart import solve_pass
from tests.conftest import paper_energy_problem


@pytest.fixture(scope="module")
def cold():
    return solve_pass(paper_energy_problem(4.5), 60, "ccw")


def test_final_time_change_matches_a_cold_solve_with_fewer_iterations(cold):
    warm = Resolver(cold).solve(final_time=4.3)
    ref = solve_pass(paper_energy_problem(4.3), 60, "ccw")
    assert warm.ok and ref.ok
    assert warm.final_time == 4.3 and warm.ocp.final_time == 4.3
    assert warm.objective == pytest.approx(ref.objective, rel=1e-6)
    assert warm.iterations < ref.iterations / 2


def test_boundary_and_obstacle_changes_take_effect(cold):
    r = Resolver(cold)
    moved = r.solve(final={"y": 0.05})
    assert moved.ok and moved.trajectory["y"].iloc[-1] == pytest.approx(0.05, abs=1e-8)
    bigger = r.solve(obstacles={0: Circle((0.5, 0.03), 0.22, 0.05)})
    assert bigger.ok and bigger.validation["measures"]["min_clearance"] > -1e-6
    assert bigger.objective > moved.objective  # a larger keep-out disc costs energy
    assert cold.ocp.obstacles[0].radius == 0.2  # the original problem is untouched


def test_time_objective_refuses_final_time_parameter():
    from tests.conftest import straight_time

    sol = solve_pass(straight_time(), 20, "none")
    with pytest.raises(ValueError, match="variable"):
        Resolver(sol).solve(final_time=2.0)


def test_a_solution_of_the_search_re_solves_in_its_own_pass_direction():
    """``OCP.solve`` tries both pass directions on one built model; the answer's model may be left set to the
    other one, and a re-solve must not inherit it (it then ended "infeasible" at the answer's own Tf)."""
    first = replace(paper_energy_problem(4.5), passing="auto").solve(intervals=100)  # as the README's example
    again = Resolver(first).solve(final_time=first.final_time)
    assert first.ok and again.ok, (first.status, again.status)
    assert again.objective == pytest.approx(first.objective, rel=1e-6)
