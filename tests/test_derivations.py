"""Tests of the PMP engine, the claim checks and the numerical confirmation."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from derivations.numerics import confirm, straight_drive
from derivations.paper.checking import FAILS, HOLDS, check_expression, compare
from derivations.paper.claims import all_claims
from derivations.paper.problems import eetppco, toctaco, toctpco
from derivations.paper.report import main as report_main
from derivations.pmp import derive, render_pmp
from model import OCP, Circle, Energy, Time, Truck, Unicycle
from model.vehicles import sym

x, y, theta, phi = (sym(n) for n in ("x", "y", "theta", "phi"))
px, py, pth, pph = (sym(n) for n in ("p_x", "p_y", "p_theta", "p_phi"))
u1, u2, d, mu = sym("u1"), sym("u2"), sym("d"), sym("mu")
xo, yo = sym("x_obs"), sym("y_obs")
DIST = sp.sqrt((x - xo) ** 2 + (y - yo) ** 2)

# Independently written adjoint equations of the truck, p' = -dH/dx, mu >= 0 convention.
TRUCK_ADJOINT = {
    "x": -mu * (x - xo) / DIST,
    "y": -mu * (y - yo) / DIST,
    "theta": u1 * (px * sp.sin(theta) - py * sp.cos(theta)),
    "phi": -pth * u1 / (d * sp.cos(phi) ** 2),
}


@pytest.fixture(scope="module")
def claims():
    return {c.id: c for c in all_claims()}


def test_truck_adjoint_matches_hand_written():
    system = derive(toctpco())
    for state, expected in TRUCK_ADJOINT.items():
        assert compare(system.adjoint_of(state), expected).equal, state


def test_energy_maximiser_and_time_switching_functions():
    energy, time = derive(eetppco()), derive(toctaco())
    a1 = px * sp.cos(theta) + py * sp.sin(theta) + pth * sp.tan(phi) / d
    assert energy.law("u1").kind == "projection" and compare(energy.law("u1").stationary, a1).equal
    assert compare(energy.law("u2").stationary, pph).equal
    assert time.law("u1").kind == "bang-singular" and compare(time.law("u1").switching, a1).equal
    assert compare(time.law("u2").switching, pph).equal
    assert [str(e.lhs) for e in time.transversality()] == ["p_phi(T_f)", "H(T_f)"]


def test_abnormal_energy_is_affine():
    assert [law.kind for law in derive(eetppco(), abnormal=True).laws] == ["bang-singular"] * 2


def test_straight_singular_arc_has_order_two_and_kelley_holds():
    from derivations.paper.claims_time import straight
    from derivations.paper.extremals import on_extremal

    system = derive(toctaco())
    arc = system.singular_arc("u2", max_order=4, on=on_extremal(system, straight(system)))
    assert arc.order == 4 and arc.q == 2
    assert compare(arc.kelley, -1 / d**2).equal


def test_every_claim_has_a_computed_verdict(claims):
    assert len(claims) >= 60
    for c in claims.values():
        assert c.status in (HOLDS, FAILS, "holds after correction"), c.id
        assert c.statement and c.evidence and c.section


@pytest.mark.parametrize(
    "claim_id, status",
    [
        ("eq1.dynamics", HOLDS),
        ("eq1.theta_arctan", "holds after correction"),
        ("eq2.front", HOLDS),
        ("eq6.p_phi", HOLDS),
        ("eq6.p_x", "holds after correction"),
        ("eq6.mu_sign", "holds after correction"),
        ("prop1.case2.psi2", "holds after correction"),
        ("prop1.case2.no_singular_arc", FAILS),
        ("prop1.case3", FAILS),
        ("prop1.case4", HOLDS),
        ("prop1.statement", FAILS),
        ("prop2.case2.px_eq_py", "holds after correction"),
        ("prop2.eq15", HOLDS),
        ("prop2.psi1_ddot", "holds after correction"),
        ("prop3.psi1_zero", "holds after correction"),
        ("prop3.cond2", HOLDS),
        ("prop3.cond3", FAILS),
        ("prop3.statement", FAILS),
        ("hyp1.singular", FAILS),
        ("sec44.norm", "holds after correction"),
        ("sec5.energy_bound.s2c1", FAILS),
        ("sec5.start_goal_outside", "holds after correction"),
        ("sec5.J_CTf", "holds after correction"),
    ],
)
def test_specific_verdicts(claims, claim_id, status):
    assert claims[claim_id].status == status, claims[claim_id].evidence


def test_wrong_claims_are_reported_as_failing():
    system = derive(toctpco())
    flipped = -TRUCK_ADJOINT["phi"]
    bad = check_expression("bad.adjoint", "test", "flipped sign", flipped, system.adjoint_of("phi"))
    assert bad.verdict == FAILS
    energy = derive(eetppco())
    wrong = 2 * energy.law("u2").stationary
    bad_max = check_expression("bad.max", "test", "u2 = 2 p_phi", wrong, energy.law("u2").stationary)
    assert bad_max.verdict == FAILS
    good = check_expression("good", "test", "right", TRUCK_ADJOINT["phi"], system.adjoint_of("phi"))
    assert good.verdict == HOLDS


def test_unicycle_goes_through_the_engine():
    ocp = OCP(
        vehicle=Unicycle(),
        cost=Time(),
        bounds={"u1": (-1, 1), "u2": (-1, 1)},
        initial={"x": 0, "y": 0, "theta": 0},
        final={"x": 1, "y": 1},
        obstacles=[Circle((0.5, 0.0), 0.1)],
        final_time=2.0,
    )
    system = derive(ocp)
    assert compare(system.adjoint_of("theta"), u1 * (px * sp.sin(theta) - py * sp.cos(theta))).equal
    assert compare(system.law("u2").switching, pth).equal
    assert [str(e.lhs) for e in system.transversality()] == ["p_theta(T_f)", "H(T_f)"]
    assert "p_theta" in render_pmp(ocp) and r"\dot{p_{\theta}}" in render_pmp(ocp, "latex")


FAR_OBSTACLE = (Circle((0.5, 2.0), 0.2, 0.05),)


def _open_road(cost=None, final_time: float = 2.0, obstacles=FAR_OBSTACLE) -> OCP:
    """A straight drive to x = 1; the default obstacle is far off the road."""
    return OCP(
        vehicle=Truck(0.1),
        cost=cost or Energy(),
        final_time=final_time,
        bounds={"u1": (-1, 1), "u2": (-0.35, 0.35)},
        initial={"x": 0, "y": 0, "theta": 0, "phi": 0},
        final={"x": 1, "y": 0, "theta": 0},
        obstacles=list(obstacles),
    )


def test_confirmation_on_exact_extremal_and_on_a_corrupted_one():
    ocp = _open_road()
    good = confirm(straight_drive(ocp, 0.5), ocp)
    assert good.agrees() and good.summary["max adjoint residual"] < 1e-12
    corrupted = straight_drive(ocp, 0.5)
    corrupted["u1"] = 0.6
    bad = confirm(corrupted, ocp)
    assert not bad.agrees() and bad.summary["max |u - argmax| u1"] == pytest.approx(0.1)


def test_confirmation_time_optimal_singular_nodes():
    ocp = _open_road(Time(), final_time=1.0, obstacles=())
    res = confirm(straight_drive(ocp, 1.0), ocp)
    assert res.agrees() and res.summary["fraction u2 singular"] == 1.0
    assert np.isnan(res.nodes["u2_argmax"]).all()


def test_report_writes_json_and_markdown(tmp_path):
    assert report_main(["--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "claims.json").read_text())
    assert {"id", "section", "statement", "verdict", "evidence"} <= set(data[0])
    text = (tmp_path / "report.md").read_text()
    assert "| claim | section | verdict |" in text and "$$H =" in text
