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
