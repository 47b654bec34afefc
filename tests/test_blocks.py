"""Row blocks on a small generic Pyomo model: both ways of removing defined variables
(linear links and substitution), chunked maps with padding, derivatives by finite
differences, and the same optimum and duals with and without the presolve."""

import casadi as ca
import numpy as np
import pyomo.environ as pyo
import pytest

from model.nlp.blocks import Chunked, pad_columns
from model.nlp.casadi_nlp import CasadiNLP
from model.nlp.ipopt import run_ipopt
from tests.test_bridge import _fd

SIZE = 21  # not a multiple of the chunk: the last chunk is padded


def _model() -> pyo.ConcreteModel:
    m = pyo.ConcreteModel()
    m.I = pyo.RangeSet(0, SIZE - 1)
    m.J = pyo.RangeSet(1, SIZE - 1)
    m.x = pyo.Var(m.I, bounds=(-2, 2), initialize=lambda _m, i: 0.1 * i - 1)
    m.z = pyo.Var(m.I, initialize=0.0)  # enters `link` linearly: a linked definition
    m.w = pyo.Var(m.I, initialize=0.0)  # enters `link` in a product: substituted
    m.c = pyo.Param(mutable=True, initialize=0.3)
    m.def_z = pyo.Constraint(m.I, rule=lambda m, i: m.z[i] == m.x[i] ** 2 + 0.5 * m.x[i])
    m.def_w = pyo.Constraint(m.I, rule=lambda m, i: m.w[i] == pyo.sin(m.x[i]))
    m.link = pyo.Constraint(m.J, rule=lambda m, i: m.z[i] - m.z[i - 1] + m.w[i] * m.x[i - 1] <= 0.5)
    m.start = pyo.Constraint(expr=m.x[0] == -1)
    m.obj = pyo.Objective(expr=sum((m.x[i] - m.c) ** 2 for i in m.I) + 0.1 * pyo.quicksum(m.z[i] for i in m.I))
    return m


def test_chunked_map_pads_and_cuts_the_last_chunk():
    s = ca.SX.sym("s", 2)
    fn = ca.Function("f", [s], [ca.vertcat(s[0] * ca.sin(s[1]), s[1] ** 2)])
    args = np.random.default_rng(0).uniform(size=(2, SIZE))
    chunked = np.array(Chunked(fn, SIZE)(args[:, pad_columns(SIZE)]))[:, :SIZE]
    np.testing.assert_allclose(chunked, np.array(fn.map(SIZE)(args)), rtol=1e-15)


def test_both_definitions_leave_the_nlp():
    nlp = CasadiNLP(_model())
    assert len(nlp._elim) == 2 * SIZE  # z and w
    assert nlp.n_primals() == SIZE and nlp.n_constraints() == SIZE - 1  # x[0] fixed by a bound


@pytest.mark.parametrize("presolve", [True, False])
def test_derivatives_match_finite_differences(presolve):
    nlp = CasadiNLP(_model(), presolve=presolve)
    rng = np.random.default_rng(3)
    x, y, sigma = rng.uniform(-1, 1, nlp.n_primals()), rng.normal(size=nlp.n_constraints()), 0.8

    def at(z, what):
        nlp.set_primals(z)
        return what()

    grad = at(x, nlp.evaluate_grad_objective)
    np.testing.assert_allclose(grad, _fd(lambda z: np.atleast_1d(at(z, nlp.evaluate_objective)), x)[0], atol=1e-7)
    jac = at(x, nlp.evaluate_jacobian).toarray()
    np.testing.assert_allclose(jac, _fd(lambda z: at(z, nlp.evaluate_constraints), x), atol=1e-6)
    nlp.set_duals(y)
    nlp.set_obj_factor(sigma)
    lower = at(x, nlp.evaluate_hessian_lag).toarray()

    def grad_lag(z):
        nlp.set_primals(z)
        return sigma * nlp.evaluate_grad_objective() + nlp.evaluate_jacobian().toarray().T @ y

    np.testing.assert_allclose(lower + np.tril(lower, -1).T, _fd(grad_lag, x), atol=1e-5)


def test_presolve_keeps_optimum_and_duals():
    values, duals = [], []
    for presolve in (False, True):
        m = _model()
        nlp = CasadiNLP(m, presolve=presolve)
        res = run_ipopt(nlp, {"tol": 1e-10})
        assert res.status == "optimal"
        nlp.load_primals(res.x)
        nlp.load_duals(res.mult_g, res.x)
        values.append(np.array([v.value for v in nlp.variables]))
        duals.append(np.array([m.dual[c] for c in nlp.constraints]))
    assert np.abs(duals[0]).max() > 1e-3  # some constraint is active
    np.testing.assert_allclose(values[1], values[0], atol=1e-7)
    np.testing.assert_allclose(duals[1], duals[0], atol=1e-6)
