"""The Pyomo model: the trapezoid transformation and the transcription of an OCP."""

import math

import numpy as np
import pyomo.environ as pyo
import pytest
from pyomo.dae import ContinuousSet, DerivativeVar

import model.direct.trapezoid  # noqa: F401
from model.direct.transcription import build_model
from tests.conftest import straight_energy


def test_trapezoid_transformation_on_linear_ode():
    m = pyo.ConcreteModel()
    m.t = ContinuousSet(bounds=(0, 2))
    m.x = pyo.Var(m.t)
    m.dx = DerivativeVar(m.x, wrt=m.t)
    m.ode = pyo.Constraint(m.t, rule=lambda m, t: m.dx[t] == -m.x[t])
    pyo.TransformationFactory("dae.trapezoid").apply_to(m, wrt=m.t, nfe=3)
    points = list(m.t)
    assert points == pytest.approx([0, 2 / 3, 4 / 3, 2], abs=0)  # exactly uniform, not rounded
    assert len(m.ode) == 4 and len(m.dx_trapezoid) == 3
    # x_{k+1} = x_k (1 - h/2) / (1 + h/2) solves both sets of equations
    h = 2 / 3
    for k, t in enumerate(points):
        m.x[t].value = ((1 - h / 2) / (1 + h / 2)) ** k
        m.dx[t].value = -m.x[t].value
    for con in m.component_data_objects(pyo.Constraint):
        assert pyo.value(con.body) - pyo.value(con.upper) == pytest.approx(0, abs=1e-14)
    m.x[points[2]].value += 1e-3  # and a perturbed state violates the rule
    assert abs(pyo.value(m.dx_trapezoid[2].body)) > 1e-4


def test_truck_constraints_against_hand_computed_case():
    ocp = straight_energy(length=1.0, tf=2.0)
    m = build_model(ocp, intervals=2)
    nodes = list(m.tau)
    assert nodes == [0, 0.5, 1]
    vals = {
        "x": [0, 0.3, 0.9],
        "y": [0, 0.01, 0.05],
        "theta": [0, 0.1, 0.2],
        "phi": [0, 0.2, 0.1],
        "u1": [0.4, 0.5, 0.6],
        "u2": [0.1, -0.2, 0.3],
    }
    for name, column in vals.items():
        for t, v in zip(nodes, column, strict=True):
            m.component(name)[t].value = v
    tf, d, h = 2.0, 0.1, 1.0

    def f(k):
        th, ph, u1, u2 = vals["theta"][k], vals["phi"][k], vals["u1"][k], vals["u2"][k]
        return {"x": u1 * math.cos(th), "y": u1 * math.sin(th), "theta": u1 * math.tan(ph) / d, "phi": u2}

    for s in ("x", "y", "theta", "phi"):
        for k, t in enumerate(nodes):
            m.component(f"d{s}")[t].value = tf * f(k)[s]  # satisfies the ODE rows exactly
            assert pyo.value(m.component(f"ode_{s}")[t].body) == pytest.approx(0, abs=1e-14)
        for k in (1, 2):
            expected = vals[s][k] - vals[s][k - 1] - h / 2 * (f(k - 1)[s] + f(k)[s])
            assert pyo.value(m.component(f"d{s}_trapezoid")[k].body) == pytest.approx(expected, rel=1e-12)
    L = [0.5 * (u1**2 + u2**2) for u1, u2 in zip(vals["u1"], vals["u2"], strict=True)]
    for k, t in enumerate(nodes):
        m.running_cost[t].value = tf * L[k]  # the defined running cost Tf L(U)
        assert pyo.value(m.running_cost_rate[t].body) == pytest.approx(0, abs=1e-14)
    assert pyo.value(m.objective) == pytest.approx(h / 2 * (L[0] + L[1]) + h / 2 * (L[1] + L[2]), rel=1e-14)


def test_final_time_is_variable_only_for_time_objective():
    from tests.conftest import straight_time

    assert isinstance(build_model(straight_time(), 4).tf, pyo.Var)
    assert not isinstance(build_model(straight_energy(), 4).tf, pyo.Var)


def test_grid_is_uniform_for_awkward_n():
    m = build_model(straight_energy(), intervals=3200)
    assert np.max(np.abs(np.diff(np.array(list(m.tau))) - 1 / 3200)) < 1e-15


@pytest.mark.parametrize("built, solved", [("ccw", "cw"), ("cw", "ccw")])
def test_a_model_turned_to_the_other_pass_solves_as_one_built_for_it(built, solved):
    """The search's two pass directions share one built model: the swept angle's bounds are Params."""
    from model.direct.transcription import set_pass_direction
    from model.nlp.casadi_nlp import CasadiNLP
    from model.nlp.ipopt import run_ipopt
    from tests.conftest import paper_energy_problem

    ocp = paper_energy_problem()
    fresh = CasadiNLP(build_model(ocp, 30, solved))
    m = build_model(ocp, 30, built)
    turned = CasadiNLP(m)
    set_pass_direction(m, solved)
    turned.refresh_parameters()
    row = turned.rows_of("pass_direction")
    assert (turned.constraints_lb()[row], turned.constraints_ub()[row]) == (fresh.constraints_lb()[row],
                                                                           fresh.constraints_ub()[row])  # fmt: skip
    a, b = run_ipopt(fresh), run_ipopt(turned)
    assert a.status == b.status and a.iterations == b.iterations
    np.testing.assert_array_equal(a.x, b.x)
