"""The final-time homotopy: from a generous Tf down to the requested one by warm re-solves."""

from __future__ import annotations

import dataclasses

import pytest

from model import load_scenario
from model.search.continuation import final_time_homotopy
from model.search.multistart import solve_ocp
from tests.conftest import EXAMPLE


def test_the_homotopy_reaches_the_requested_final_time_and_the_direct_optimum():
    ocp = dataclasses.replace(load_scenario(EXAMPLE).ocp, final_time=3.6, passing="ccw")
    direct = solve_ocp(ocp, 40, continuation=False)
    assert direct.ok
    lines = []
    found = final_time_homotopy(ocp, lambda easy: solve_ocp(easy, 40, continuation=False), lines.append)
    assert found is not None and found.ok
    assert found.final_time == pytest.approx(3.6)
    assert found.ocp.final_time == pytest.approx(3.6)
    assert found.objective <= direct.objective * (1 + 1e-3)  # the same local optimum or a better one
    assert lines and lines[0].startswith("continuation: Tf x2")


def test_no_homotopy_for_a_free_final_time():
    from model import Time

    ocp = dataclasses.replace(load_scenario(EXAMPLE).ocp, cost=Time(), final_time=None)
    assert final_time_homotopy(ocp, lambda easy: pytest.fail("must not solve")) is None


def test_a_minimum_time_solution_slowed_down_is_a_feasible_energy_start():
    """Driftless models: the time-optimal trajectory driven slower reaches the goal at any Tf >= T_min."""
    from model.search.continuation import slowed_minimum_time

    ocp = dataclasses.replace(load_scenario(EXAMPLE).ocp, final_time=3.6, passing="ccw")
    found, least = slowed_minimum_time(ocp, lambda problem, guess=None: solve_ocp(problem, 40, guess=guess,
                                                                                 continuation=False))  # fmt: skip
    assert least is not None and least < 3.6
    assert found is not None and found.ok and found.final_time == pytest.approx(3.6)
    too_short = dataclasses.replace(ocp, final_time=0.95 * least)
    none, least_again = slowed_minimum_time(too_short, lambda problem, guess=None: solve_ocp(
        problem, 40, guess=guess, continuation=False))  # fmt: skip
    assert none is None and least_again == pytest.approx(least, rel=1e-6)


def test_no_homotopy_below_the_least_time_found(monkeypatch):
    """Tf = 2.1 s, below the example's minimum time (2.65 s on N = 40) and above its bounds: the search reports
    the least time found and does not walk a homotopy towards a Tf no start reached."""
    import model.search.continuation as continuation

    monkeypatch.setattr(continuation, "final_time_homotopy", lambda *a, **k: pytest.fail("homotopy tried"))
    lines = []
    ocp = dataclasses.replace(load_scenario(EXAMPLE).ocp, final_time=2.1, passing="ccw")
    found = solve_ocp(ocp, 40, progress=lines.append)
    assert not found.ok
    assert found.diagnosis["least_time_found_s"] > 2.1 * 1.02
    assert any(line.startswith("no final-time homotopy") for line in lines)
