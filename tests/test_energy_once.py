"""The numeric energy is written once (issue 44): ``model.problem.costs.Energy`` makes the symbolic running cost and
the numeric energy of a trajectory's columns from the same weighted squares, and no other module of ``model/``
integrates squared controls itself.

Before, five copies computed 1/2 integral of sum u_i^2 (the solution's trapezoid, the MPC's cost scale, the
figures' cumulative energy, the closed loop's zero-order hold, the traffic run's), none with ``Energy.weights``.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp

from model.problem.costs import RULES, Energy, Time
from model.vehicles import VEHICLES, sym
from tests.conftest import ROOT

T = np.array([0.0, 0.5, 1.5, 2.0])
COLUMNS = {"t": T, "u1": np.array([1.0, 2.0, -1.0, 0.5]), "u2": np.array([0.1, -0.3, 0.2, 0.0])}


def test_the_numeric_energy_is_the_lagrangian_integrated():
    cost = Energy(weights={"u1": 2.0, "u2": 5.0})
    truck = VEHICLES["truck"]()
    rate = sp.lambdify([sym("u1"), sym("u2")], cost.lagrangian(truck))(COLUMNS["u1"], COLUMNS["u2"])
    assert cost.rate(COLUMNS, ("u1", "u2")) == pytest.approx(rate, rel=1e-15)
    assert cost.integral(COLUMNS, ("u1", "u2")) == pytest.approx(float(np.trapezoid(rate, T)), rel=1e-15)
    assert cost.integral(COLUMNS, ("u1", "u2"), rule="zoh") == pytest.approx(float(np.sum(np.diff(T) * rate[:-1])))
    assert cost.cumulative(COLUMNS, ("u1", "u2"))[-1] == pytest.approx(cost.integral(COLUMNS, ("u1", "u2")))
    assert cost.cumulative(COLUMNS, ("u1", "u2"))[0] == 0.0


def test_unit_weights_give_the_former_copies_numbers_bit_for_bit():
    u = [COLUMNS["u1"], COLUMNS["u2"]]
    plain, controls = Energy(), ("u1", "u2")
    assert plain.integral(COLUMNS, controls) == float(np.trapezoid(0.5 * sum(c**2 for c in u), T))
    assert plain.integral(COLUMNS, controls, rule="zoh") == float(
        0.5 * np.sum(np.diff(T) * sum(c[:-1] ** 2 for c in u))
    )
    rate = 0.5 * sum(c**2 for c in u)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(T) * (rate[1:] + rate[:-1]))])
    assert np.array_equal(plain.cumulative(COLUMNS, controls), cumulative)


def test_the_weights_count_and_a_cost_names_its_energy():
    weighted = Energy(weights={"u2": 4.0})
    assert weighted.energy is weighted and Time().energy == Energy() and Time(steering_weight=2.0).energy == Energy()
    extra = 1.5 * float(np.trapezoid(COLUMNS["u2"] ** 2, T))  # 1/2 (4 - 1) integral of u2^2
    assert weighted.integral(COLUMNS, ("u1", "u2")) == pytest.approx(Energy().integral(COLUMNS, ("u1", "u2")) + extra)
    with pytest.raises(ValueError, match="rule must be one of"):
        Energy().integral(COLUMNS, ("u1",), rule="simpson")
    assert RULES == ("trapezoid", "zoh")


def test_no_module_integrates_squared_controls_itself():
    """The forms the five copies had (a sum of squared controls next to a trapezoid or a diff of t) appear nowhere
    in model/ but in model/problem/costs.py; model/traffic/run.py's is listed until it is folded (issue 44)."""
    squares = re.compile(r"(\[c\](\[:-1\]|\.to_numpy\(\))?|asarray\(c\)) ?\*\* ?2 for c in")  # a control squared
    found = sorted(
        str(path.relative_to(ROOT))
        for path in (ROOT / "model").rglob("*.py")
        if squares.search(path.read_text(encoding="utf-8"))
    )
    assert found in (["model/traffic/run.py"], [])
