"""The transcription's options (model/direct/options.py) and the NLP's accessors of named components."""

from __future__ import annotations

import dataclasses

import numpy as np
import pyomo.environ as pyo
import pytest

from model.direct.options import Horizon, TranscriptionOptions
from model.direct.transcription import build_model, energy
from model.nlp.casadi_nlp import CasadiNLP
from model.problem.costs import Energy
from tests.conftest import paper_energy_problem, straight_time

HORIZON = Horizon(scales={"x": 1.0, "y": 1.0, "theta": 1.0, "phi": 1.0}, time_scale=2.0, energy_scale=3.0)


def ramp(m: pyo.ConcreteModel, seed: int = 0) -> None:
    """Give every variable of ``m`` a distinct value."""
    rng = np.random.default_rng(seed)
    for v in m.component_data_objects(pyo.Var):
        v.set_value(float(rng.uniform(0.1, 0.9)), skip_validation=True)


def test_no_options_is_the_scenario_model():
    ocp = paper_energy_problem()
    plain, empty = build_model(ocp, 10), build_model(ocp, 10, options=TranscriptionOptions())
    for m in (plain, empty):
        ramp(m)
    assert pyo.value(plain.objective) == pyo.value(empty.objective)
    assert not hasattr(empty, "keep_out_slack") and not hasattr(empty, "d_hat") and hasattr(empty, "final_x")


def test_columns_and_rows_of_named_components():
    m = build_model(paper_energy_problem(), 10, options=TranscriptionOptions(soft_penalty=1.0, horizon=HORIZON))
    ramp(m)
    nlp = CasadiNLP(m)
    x = nlp.init_primals()
    cols = nlp.columns_of("y")
    assert len(cols) == len(m.nodes) and np.all(cols >= 0)
    assert x[cols] == pytest.approx([m.y[t].value for t in m.nodes])
    assert np.all(nlp.columns_of(m.dx) == -1)  # defined variables: eliminated by the presolve
    rows = nlp.rows_of(m.terminal)
    assert len(rows) == 4 and np.all(rows >= 0)
    g = nlp.constraint_values_at(x)[nlp.constraint_rows()]
    assert g[rows] == pytest.approx([pyo.value(m.terminal[k].body) for k in m.state_set])
    assert np.all(nlp.rows_of("initial_x") == -1)  # a singleton row: a bound


def test_soft_keep_out_has_a_slack_and_its_price():
    ocp = paper_energy_problem()
    m = build_model(ocp, 10, options=TranscriptionOptions(soft_penalty=7.0))
    ramp(m)
    ob, t = ocp.obstacles[0], m.nodes[3]
    m.x[t].set_value(ob.center[0])
    m.y[t].set_value(ob.center[1] + 0.5 * ob.keep_out)  # inside the disc by half its radius
    m.keep_out_slack[0, t].set_value(0.5 * ob.keep_out)  # exactly enough slack
    assert m.obstacle[0, t].slack() == pytest.approx(0.0, abs=1e-12)
    m.keep_out_slack[0, t].set_value(0.4 * ob.keep_out)  # too little: violated
    assert m.obstacle[0, t].slack() < -1e-3
    before = pyo.value(m.objective)
    m.keep_out_slack[0, t].set_value(0.4 * ob.keep_out + 0.1)
    assert pyo.value(m.objective) - before == pytest.approx(7.0 * 0.1)


def test_rate_disturbance_enters_every_state_rate():
    m = build_model(paper_energy_problem(), 4, options=TranscriptionOptions(rate_disturbance=True))
    ramp(m)
    t = m.nodes[2]
    before = {k: pyo.value(m.component(f"ode_{k}")[t].body) for k in ("x", "theta")}
    m.d_hat["x"].set_value(0.3)
    assert pyo.value(m.ode_x[t].body) - before["x"] == pytest.approx(-pyo.value(m.tf) * 0.3)
    assert pyo.value(m.ode_theta[t].body) == pytest.approx(before["theta"])


def test_energy_honours_the_weights():
    ocp = dataclasses.replace(paper_energy_problem(), cost=Energy(weights={"u1": 2.0, "u2": 5.0}))
    m = build_model(ocp, 8)
    ramp(m)
    for t in m.nodes:
        m.running_cost[t].set_value(pyo.value(m.running_cost_rate[t].body - m.running_cost[t]) * -1.0)
    u1, u2 = (np.array([m.component(c)[t].value for t in m.nodes]) for c in ("u1", "u2"))
    rate = (2.0 * u1**2 + 5.0 * u2**2) / 2 * pyo.value(m.tf)
    want = (rate.sum() - (rate[0] + rate[-1]) / 2) / 8
    assert pyo.value(energy(m, ocp)) == pytest.approx(want, rel=1e-12)
    assert pyo.value(m.objective) == pytest.approx(want, rel=1e-12)  # the objective's own sum
    unit = build_model(paper_energy_problem(), 8)
    ramp(unit)
    assert pyo.value(energy(unit, paper_energy_problem())) != pytest.approx(pyo.value(energy(m, ocp)))


def test_horizon_objective_soft_target_and_node_hook():
    ocp = straight_time()
    m = build_model(ocp, 6, options=TranscriptionOptions(soft_penalty=1.0, horizon=HORIZON))
    assert not any(m.component(f"final_{k}") is not None for k in ocp.final)
    assert isinstance(m.tf, pyo.Var) and len(m.node_time) == 7 and m.node_parameters == []
    ramp(m)
    for k in m.state_set:
        m.above[k].set_value(0.0)
        m.below[k].set_value(0.0)
    m.time_weight.set_value(1.0)
    m.energy_weight.set_value(0.0)
    assert pyo.value(m.objective) == pytest.approx(pyo.value(m.tf) / 2.0)
    m.target_weight["x"].set_value(2.0)
    m.above["x"].set_value(0.1)
    assert pyo.value(m.objective) == pytest.approx(pyo.value(m.tf) / 2.0 + 2.0 * (100.0 * 0.1 + 10.0 * 0.01))
    m.time_weight.set_value(0.0)
    m.energy_weight.set_value(1.0)
    m.above["x"].set_value(0.0)
    assert pyo.value(m.objective) == pytest.approx(pyo.value(energy(m, ocp)) / 3.0)
