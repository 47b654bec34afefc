"""The CasADi-backed pynumero NLP: derivatives against finite differences, duals' sign."""

import dataclasses

import numpy as np
import pytest

from model import OCP, Circle, Energy, Time, Unicycle
from model.direct.transcription import build_model
from model.nlp.casadi_nlp import CasadiNLP
from tests.conftest import paper_energy_problem, straight_time


def _unicycle() -> OCP:
    return OCP(
        vehicle=Unicycle(), cost=Energy(), final_time=3.0, bounds={"u1": (-1, 1), "u2": (-1, 1)},
        initial={"x": 0, "y": 0, "theta": 0}, final={"x": 1, "y": 0.2},
        obstacles=[Circle((0.5, 0.0), 0.1)], passing="cw",
    )  # fmt: skip


PROBLEMS = {
    "energy": (paper_energy_problem, "ccw"),
    "time": (straight_time, None),
    "time_rate_penalty": (lambda: dataclasses.replace(straight_time(), cost=Time(rate_penalty=1e-2)), None),
    "unicycle": (_unicycle, "cw"),
}


@pytest.fixture(scope="module", params=list(PROBLEMS))
def nlp(request):
    make, passing = PROBLEMS[request.param]
    return CasadiNLP(build_model(make(), intervals=6, passing=passing))


def _fd(fun, x, eps=1e-6):
    cols = []
    for i in range(len(x)):
        e = np.zeros_like(x)
        e[i] = eps
        cols.append((fun(x + e) - fun(x - e)) / (2 * eps))
    return np.array(cols).T


def test_gradient_and_jacobian_match_finite_differences(nlp):
    rng = np.random.default_rng(1)
    x = rng.uniform(0.1, 0.9, nlp.n_primals())

    def obj(z):
        nlp.set_primals(z)
        return np.atleast_1d(nlp.evaluate_objective())

    def cons(z):
        nlp.set_primals(z)
        return nlp.evaluate_constraints()

    nlp.set_primals(x)
    grad = nlp.evaluate_grad_objective()
    jac = nlp.evaluate_jacobian().toarray()
    np.testing.assert_allclose(grad, _fd(obj, x)[0], atol=1e-7)
    np.testing.assert_allclose(jac, _fd(cons, x), atol=1e-6)


def test_hessian_of_lagrangian_matches_finite_differences(nlp):
    rng = np.random.default_rng(2)
    x = rng.uniform(0.1, 0.9, nlp.n_primals())
    y = rng.normal(size=nlp.n_constraints())
    sigma = 0.7

    def grad_lag(z):
        nlp.set_primals(z)
        return sigma * nlp.evaluate_grad_objective() + nlp.evaluate_jacobian().toarray().T @ y

    nlp.set_primals(x)
    nlp.set_duals(y)
    nlp.set_obj_factor(sigma)
    lower = nlp.evaluate_hessian_lag().toarray()
    assert np.all(np.triu(lower, 1) == 0)  # Ipopt wants the lower triangle only
    full = lower + np.tril(lower, -1).T
    np.testing.assert_allclose(full, _fd(grad_lag, x), atol=1e-5)


def test_jacobian_out_argument_is_filled_in_place(nlp):
    nlp.set_primals(np.full(nlp.n_primals(), 0.3))
    jac = nlp.evaluate_jacobian()
    data_id = id(jac.data)
    nlp.set_primals(np.full(nlp.n_primals(), 0.6))
    again = nlp.evaluate_jacobian(out=jac)
    assert again is jac and id(jac.data) == data_id
    np.testing.assert_allclose(jac.toarray(), nlp.evaluate_jacobian().toarray())


def test_presolve_keeps_solution_and_recovers_multipliers():
    """Eliminating dX = Tf f changes nothing Pyomo sees: same primal values and duals."""
    import pyomo.environ as pyo

    from model.direct.solve import load_values
    from model.nlp.ipopt import run_ipopt
    from model.search.guess import initial_guess

    ocp = paper_energy_problem()
    duals, values = [], []
    for presolve in (False, True):
        m = build_model(ocp, intervals=30, passing="ccw")
        load_values(m, initial_guess(ocp, "ccw", 30, 4.5))
        nlp = CasadiNLP(m, presolve=presolve)
        res = run_ipopt(nlp, {"tol": 1e-10})
        assert res.status == "optimal"
        nlp.load_primals(res.x)
        nlp.load_duals(res.mult_g, res.x)
        duals.append(np.array([m.dual[c] for c in nlp.constraints]))
        values.append(np.array([v.value for v in nlp.variables]))
        if presolve:
            eliminated = 4 * 31 + 30 + 31  # dX, sweep steps, running cost
            assert nlp.n_primals() < len(nlp.variables) and len(nlp._elim) == eliminated
            assert all(abs(pyo.value(c.body)) < 1e-8 for c in m.ode_x.values())
    np.testing.assert_allclose(values[1], values[0], atol=1e-6)
    np.testing.assert_allclose(duals[1], duals[0], atol=1e-5)


def test_refresh_re_reads_param_bounds_and_the_bound_rows():
    """Row bounds given by Params and singleton rows (presolved into variable bounds) follow a
    changed Param after ``refresh_parameters`` exactly as a freshly built NLP reads them (the
    constant bounds are read once, the tightened variable bounds cached until the refresh)."""
    import pyomo.environ as pyo

    m = pyo.ConcreteModel()
    m.p = pyo.Param(mutable=True, initialize=1.0)
    m.x = pyo.Var(range(3), bounds=(-10.0, 10.0), initialize=0.5)
    m.row = pyo.Constraint(expr=m.x[0] + m.x[1] >= m.p)
    m.fixed_row = pyo.Constraint(expr=m.x[0] - m.x[1] <= 4.0)
    m.bound_row = pyo.Constraint(expr=2.0 * m.x[2] <= 3.0 * m.p)
    m.obj = pyo.Objective(expr=sum(m.x[i] ** 2 for i in range(3)))
    nlp = CasadiNLP(m)
    before = (nlp.constraints_lb(), nlp.constraints_ub(), nlp.primals_lb(), nlp.primals_ub())
    m.p.set_value(2.0)
    nlp.refresh_parameters()
    fresh = CasadiNLP(m)
    after = (nlp.constraints_lb(), nlp.constraints_ub(), nlp.primals_lb(), nlp.primals_ub())
    for got, want in zip(after, (fresh.constraints_lb(), fresh.constraints_ub(), fresh.primals_lb(),
                                 fresh.primals_ub()), strict=True):  # fmt: skip
        np.testing.assert_array_equal(got, want)
    assert not all(np.array_equal(a, b) for a, b in zip(before, after, strict=True))
    assert 2.0 in after[0] and 3.0 in after[3]  # the row's Param bound; the bound row's x2 <= 3 p / 2


def test_first_order_in_one_call_matches_the_separate_evaluations(nlp):
    """``evaluate_first_order``: g, the gradient and the Jacobian's values of the current primals, copies."""
    rng = np.random.default_rng(3)
    for _ in range(2):  # a second point: the buffers are refilled, not stale
        nlp.set_primals(rng.uniform(0.1, 0.9, nlp.n_primals()))
        g, grad, jac = nlp.evaluate_first_order()
        np.testing.assert_array_equal(g, nlp.evaluate_constraints())
        np.testing.assert_array_equal(grad, nlp.evaluate_grad_objective())
        np.testing.assert_array_equal(jac, nlp.evaluate_jacobian().data)
    g[:] = np.nan  # a copy: the next call is untouched
    assert np.all(np.isfinite(nlp.evaluate_first_order()[0]))


def test_compiled_first_order_matches_and_is_cached(tmp_path):
    """gcc-compiled first-order functions: the interpreted values, and the library reused from the cache."""
    model = build_model(paper_energy_problem(), intervals=6)
    nlp = CasadiNLP(model)
    x = np.random.default_rng(4).uniform(0.1, 0.9, nlp.n_primals())
    nlp.set_primals(x)
    interpreted = nlp.evaluate_first_order()
    assert nlp.compile_first_order(tmp_path)
    (library,) = tmp_path.glob("first_order_*.so")
    stamp = library.stat().st_mtime_ns
    for a, b in zip(nlp.evaluate_first_order(), interpreted, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)
    again = CasadiNLP(model)  # same structure: loaded from the cache, not compiled again
    assert again.compile_first_order(tmp_path)
    assert list(tmp_path.glob("first_order_*.so")) == [library] and library.stat().st_mtime_ns == stamp


def test_compile_failure_warns_and_keeps_the_interpreted_functions(tmp_path):
    nlp = CasadiNLP(build_model(paper_energy_problem(), intervals=6))
    nlp.set_primals(np.full(nlp.n_primals(), 0.4))
    before = nlp.evaluate_first_order()
    with pytest.warns(RuntimeWarning, match="stay interpreted"):
        assert not nlp.compile_first_order(tmp_path, compiler="no-such-compiler-xyz")
    assert not list(tmp_path.glob("*.so"))
    for a, b in zip(nlp.evaluate_first_order(), before, strict=True):
        np.testing.assert_array_equal(a, b)


def test_settled_heap_freezes_the_survivors_in_its_block_and_frees_its_garbage():
    """``settled_heap`` collects the cyclic garbage there is, keeps the survivors out of the collector's scans
    inside the block and gives them back after it (a long-lived caller keeps collecting them)."""
    import gc
    import weakref

    from model.nlp.imports import settled_heap

    class Node:
        pass

    cycle = Node()
    cycle.self = cycle
    dead = weakref.ref(cycle)
    del cycle
    gc.disable()  # only settled_heap may collect the cycle
    try:
        assert dead() is not None
        with settled_heap():
            assert dead() is None and gc.get_freeze_count() > 0
        assert gc.get_freeze_count() == 0
    finally:
        gc.enable()


def test_a_run_after_one_that_ended_in_restoration_sees_the_objective():
    """pynumero's wrapper assumes an objective factor of 1 at its start; the restoration phase sets 0."""
    from model.nlp.ipopt import run_ipopt

    nlp = CasadiNLP(build_model(paper_energy_problem(), intervals=20))
    x0 = nlp.init_primals()
    fresh = run_ipopt(nlp, {"print_level": 0}, x0=x0)
    nlp.set_obj_factor(0.0)  # where a restoration phase leaves it
    again = run_ipopt(nlp, {"print_level": 0}, x0=x0)
    assert fresh.status == again.status == "optimal"
    assert again.iterations == fresh.iterations and np.allclose(again.x, fresh.x, atol=1e-10)
