"""Section 4 of the paper: energy-optimal control, (18)-(30), Proposition 3, Hypothesis 1, 4.4."""

from __future__ import annotations

from functools import cache

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from derivations.paper.checking import Claim, check_expression, compare, decide, fmt, is_zero
from derivations.paper.claims_time import boundary_arc
from derivations.paper.extremals import Extremal, T, describe, holds_all, verify
from derivations.paper.problems import U2MAX, eetppco
from derivations.paper.symbols import DIST, PAPER_PSI1, R, d, mu, phi, pph, pth, px, py, theta, u1, u2
from derivations.pmp import PMPSystem, derive
from derivations.symbolic import derivative_symbol

SECTION = "4 Energy-optimal control"
A1 = PAPER_PSI1
SEC2 = 1 + sp.tan(phi) ** 2

# PAPER (claims under test), typed from the text.
PAPER_H18 = -(u1**2 + u2**2) / 2 + mu * (R - DIST) + A1 * u1 + pph * u2
PAPER_PSI20 = {"u1": -u1**2 / 2 + A1 * u1, "u2": -u2**2 / 2 + pph * u2}
PAPER_U23 = {"u1": A1, "u2": pph}
PAPER_U1_PROP3 = 2 * (px * sp.cos(theta) + px * sp.sin(theta) + pth * sp.tan(phi) / d)  # "p_x sin θ"
PAPER_U2_PROP3 = 2 * pth


@cache
def energy() -> PMPSystem:
    return derive(eetppco())


def _flip(expr: sp.Expr) -> dict[str, sp.Expr]:
    return {"mu_paper = -mu (the paper's multiplier is <= 0)": expr.subs(mu, -mu)}


def rest(system: PMPSystem) -> Extremal:
    """Start = goal: u = 0, p = 0, mu = 0 is a normal extremal with H = 0."""
    values = {s: sp.Integer(0) for s in [*system.states, *system.costates, *system.time_functions]}
    return Extremal("standing still", values, horizon=1.0)


# -- (18)-(25) ---------------------------------------------------------------------
def hamiltonian_claims() -> list[Claim]:
    sys_ = energy()
    out = [check_expression("eq18.hamiltonian", SECTION, "(18): the energy Hamiltonian", PAPER_H18,
                            sys_.hamiltonian, _flip(PAPER_H18), "H")]
    rate = sys_.hamiltonian_rate()
    expected = sum((law.switching * derivative_symbol(law.control, 1) for law in sys_.laws), sp.Integer(0))
    expected += sum((c * derivative_symbol(m, 1) for m, c in
                     zip(sys_.multipliers, sys_.constraints, strict=True)), sp.Integer(0))
    const = compare(rate, expected).equal
    out.append(Claim("eq18.H_constant", SECTION, "(18): H is constant along extremals (autonomous)",
                     decide(const),
                     r"$\dot H = \sum_i H_{u_i}\dot u_i + c\,\dot\mu$ exactly; $H_{u_i} = 0$ on interior "
                     r"arcs, $\dot u_i = 0$ on saturated ones, and $c\dot\mu = 0$ (c = 0 on the boundary, "
                     r"$\mu \equiv 0$ off it)"))
    still = verify(sys_, rest(sys_))
    h0 = compare(rest(sys_).at(sys_.hamiltonian), 0).equal
    out.append(Claim("eq18.H_nonzero", SECTION, "(18): H ≠ 0 because the final time is fixed",
                     decide(not (holds_all(still) and h0)),
                     f"a fixed Tf only drops the condition H = 0; the extremal u = 0, p = 0 (start = goal) "
                     f"satisfies every condition ({describe(still)}) and has H = 0"))
    split = compare(PAPER_H18.subs(mu, 0), PAPER_PSI20["u1"] + PAPER_PSI20["u2"]).equal
    out.append(Claim("eq19_20.split", SECTION, "(19)-(20): H = μ(R - dist) + ψ1(u1) + ψ2(u2)",
                     decide(split), "H is separable; the paper's ψ_i are the u_i-parts of H (not the "
                     "usual switching functions ∂H/∂u_i)"))
    curv = all(compare(sys_.law(u).curvature, -1).equal for u in ("u1", "u2"))
    out.append(Claim("eq22.curvature", SECTION, "(22): ∂²ψ_i/∂u_i² = -1 < 0", decide(curv),
                     "engine: d²H/du_i² = -1 for both controls"))
    for u in ("u1", "u2"):
        out.append(check_expression(f"eq23.{u}", SECTION, f"(23): {u}~ = {sp.sstr(PAPER_U23[u])}",
                                    PAPER_U23[u], sys_.law(u).stationary, what="stationary point"))
    out.append(eq24_projection(sys_))
    return out


def eq24_projection(sys_: PMPSystem) -> Claim:
    """argmax over [lo, hi] of -u²/2 + ũu equals clip(ũ) (checked on a fine grid)."""
    law = sys_.law("u2")
    grid = np.linspace(law.lower, law.upper, 20001)
    worst = 0.0
    for tilde in np.linspace(-1.0, 1.0, 41):
        best = grid[np.argmax(-grid**2 / 2 + tilde * grid)]
        worst = max(worst, abs(best - float(law.choose(tilde))))
    ok = worst < 1e-4
    return Claim("eq24_25.projection", SECTION, "(24)-(25): u* = projection of ũ onto the bounds",
                 decide(ok), f"grid argmax vs clip(ũ) for 41 values of ũ: max gap {fmt(worst)}")


# -- Proposition 3 -------------------------------------------------------------------
def prop3() -> list[Claim]:
    sys_ = energy()
    a, b = sys_.law("u1").stationary, sys_.law("u2").stationary
    roots = sp.solve(PAPER_PSI20["u1"], u1)
    out = [
        check_expression("prop3.psi1_zero", SECTION, "Prop. 3: ψ1 = 0 gives u1 = 2(p_x cosθ + p_x sinθ + "
                         "p_θ tanφ/d)", PAPER_U1_PROP3, a,
                         {"p_y sin θ (typo), factor 2 kept": 2 * A1, "p_y sin θ and no factor 2": A1},
                         "maximiser (23)"),
        check_expression("prop3.psi2_zero", SECTION, "Prop. 3: ψ2 = 0 gives u2 = 0 or u2 = 2 p_θ",
                         PAPER_U2_PROP3, b, {"p_φ (typo), factor 2 kept": 2 * pph, "p_φ, no factor 2": pph},
                         "maximiser (23)"),
    ]
    out[0].evidence += (f"; the roots of ψ1(u1) = 0 are {roots}: u1 = 2ũ1 is where the u1-part of H "
                        "returns to its value at u1 = 0, not its maximum (which is at u1 = ũ1)")
    out += [prop3_cond1(sys_), prop3_cond2(sys_), prop3_cond3(sys_), prop3_cond4(sys_),
            prop3_statement(sys_)]
    return out


def _off_obstacle(expr: sp.Expr) -> sp.Expr:
    return expr.subs({mu: 0, derivative_symbol(mu, 1): 0})


def prop3_cond1(sys_: PMPSystem) -> Claim:
    """u2 = p_φ ≡ 0 interior: p_θ = 0, then ũ1' = 0 off the obstacle; on it H = u1²/2 fixes u1."""
    a = sys_.law("u1").stationary
    step = compare(sys_.time_derivative(pph), -pth * u1 * SEC2 / d).equal
    da = sp.simplify(_off_obstacle(sys_.time_derivative(a)).subs({pth: 0, u2: 0}))
    h_int = sys_.maximised_hamiltonian().subs({pph: 0, pth: 0})
    on_boundary = compare(h_int.subs(mu, 0), a.subs(pth, 0) ** 2 / 2).equal
    ok = step and is_zero(da) and on_boundary
    return Claim("prop3.cond1", SECTION, "Prop. 3 Condition 1 (u2 = 0): u1 constant, u2 = 0", decide(ok),
                 rf"with the correct maximiser: $p_\phi \equiv 0$ ⇒ $p_\theta u_1 = 0$ ⇒ "
                 rf"$p_\theta = 0$; then "
                 rf"$\dot{{\tilde u}}_1 = {sp.latex(da)}$ off the obstacle, and H = ũ1²/2 (μc = 0) on it. "
                 "The paper's intermediate H = μ(R - dist) holds only for its u1 = 2ũ1")


def prop3_cond2(sys_: PMPSystem) -> Claim:
    """On interior arcs H = (u1² + u2²)/2 + μc, so H constant and μc = 0 give |u|² constant."""
    hmax = sys_.maximised_hamiltonian()
    a, b = sys_.law("u1").stationary, sys_.law("u2").stationary
    ok = compare(hmax, (a**2 + b**2) / 2 + mu * sys_.constraints[0]).equal
    return Claim("prop3.cond2", SECTION, "Prop. 3 Condition 2: u1² + u2² = C (constant) on the arc",
                 decide(ok),
                 rf"at the interior maximiser $H = {sp.latex(hmax)}$ = (u1² + u2²)/2 + μc, and μc = 0, so "
                 "|u|² = 2H is constant on every arc where neither control saturates (on or off the "
                 "boundary); J = ½ C Tf needs one such arc over the whole of [0, Tf]")


def prop3_cond3(sys_: PMPSystem) -> Claim:
    """u2 saturated, u1 interior: ũ1' = p_θ sec²φ u2/d off the obstacle, not 0."""
    a = sys_.law("u1").stationary
    da = sp.simplify(_off_obstacle(sys_.time_derivative(a)))
    point = {pth: 1, phi: 0, u2: U2MAX, d: 0.1, derivative_symbol(u2, 1): 0}
    value = float(da.subs(point))
    return Claim("prop3.cond3", SECTION, "Prop. 3 Condition 3 (u2 = ±u2max): u1 constant",
                 decide(is_zero(da)),
                 rf"off the obstacle $\dot{{\tilde u}}_1 = {sp.latex(da)}$; at p_θ = 1, φ = 0, u2 = {U2MAX}, "
                 rf"d = 0.1 it is {fmt(value)} ≠ 0, and dH/dt = 0 holds identically there (gives no "
                 "information), so the printed step u̇1 u1 = 0 does not follow")


def prop3_cond4(sys_: PMPSystem) -> Claim:
    """u1 saturated, u2 = p_φ interior: u2' = p_φ' = -p_θ u1 sec²φ/d, not 0."""
    du2 = sys_.time_derivative(sys_.law("u2").stationary)
    value = float(du2.subs({pth: 1, u1: 1.0, phi: 0, d: 0.1}))
    return Claim("prop3.cond4", SECTION, "Prop. 3 Condition 4 (u1 = ±u1max): u2 constant",
                 decide(is_zero(du2)),
                 rf"$\dot{{\tilde u}}_2 = {sp.latex(du2)}$, = {fmt(value)} at p_θ = 1, u1 = 1, φ = 0, "
                 "d = 0.1; only p_θ ≡ 0 makes u2 constant, which the paper does not establish")


def interior_extremal(sys_: PMPSystem, horizon: float = 0.5) -> dict[str, np.ndarray]:
    """Integrate the normal energy extremal from x = (-2, 0, 0, 0), p = (0.5, 0, 0.01, 0), μ = 0."""
    params = dict(sys_.parameters)
    u_sub = {law.control: law.stationary for law in sys_.laws}
    rhs = [e.subs(u_sub).subs(mu, 0).subs(params) for e in [*sys_.dynamics, *sys_.adjoint]]
    f = sp.lambdify([*sys_.states, *sys_.costates], rhs, "numpy")
    ctrl = sp.lambdify([*sys_.states, *sys_.costates], [law.stationary.subs(params) for law in sys_.laws])
    sol = solve_ivp(lambda _t, z: f(*z), (0.0, horizon), [-2, 0, 0, 0, 0.5, 0, 0.01, 0],
                    rtol=1e-10, atol=1e-12, dense_output=True)
    ts = np.linspace(0.0, horizon, 11)
    z = sol.sol(ts)
    u = np.array([ctrl(*z[:, k]) for k in range(ts.size)], dtype=float)
    return {"t": ts, "u1": u[:, 0], "u2": u[:, 1], "z": z}


def prop3_statement(sys_: PMPSystem) -> Claim:
    """With μ ≡ 0 (constant), an interior extremal whose u2 varies."""
    run = interior_extremal(sys_)
    lo, hi = sys_.law("u2").lower, sys_.law("u2").upper
    interior = bool(np.all((run["u2"] > lo) & (run["u2"] < hi)) and np.all(np.abs(run["u1"]) < 1))
    varies = float(np.ptp(run["u2"])) > 1e-3
    return Claim("prop3.statement", SECTION,
                 "Prop. 3: with μ constant, energy-optimal controls are constant on the phase",
                 decide(not (interior and varies)),
                 f"integrating the normal extremal (μ ≡ 0) from p = (0.5, 0, 0.01, 0): both controls stay "
                 f"interior ({interior}) while u2 goes from {fmt(run['u2'][0])} to {fmt(run['u2'][-1])} "
                 f"and u1 from {fmt(run['u1'][0])} to {fmt(run['u1'][-1])} in 0.5 s")


# -- Hypothesis 1 and Section 4.4 ---------------------------------------------------
def hypothesis1() -> list[Claim]:
    sys_ = energy()
    f1, f2 = sp.Function("u1")(T), sp.Function("u2")(T)
    phase_rate = sp.diff(sp.atan(f2 / f1), T)
    paper29 = (f1 * sp.diff(f2, T) - f2 * sp.diff(f1, T)) / (f1**2 + f2**2)
    ok29 = sp.simplify(phase_rate - paper29) == 0
    hess = sys_.hessian
    definite = all(v.is_negative for v in hess.eigenvals())
    abn = derive(eetppco(), abnormal=True)
    return [
        Claim("hyp1.eq29", SECTION, "(29): ψ' = (u1 u2' - u2 u1')/(u1² + u2²) for ψ = arctan(u2/u1)",
              decide(ok29), "d/dt arctan(u2/u1) simplifies to (29)"),
        Claim("hyp1.singular", SECTION,
              "Hypothesis 1: a singular arc is an arc of constant |u| with varying direction",
              decide(not definite),
              rf"normal case: $\partial^2 H/\partial u^2 = {sp.latex(hess)}$ is negative definite, so the "
              "maximiser u = Π(ũ) is unique and no singular arc exists; constant |u| is just the regular "
              f"interior arc (prop3.cond2). Only abnormal extremals (p0 = 0) are affine in u: "
              f"{[law.kind for law in abn.laws]}"),
    ]


def section44() -> list[Claim]:
    sys_ = energy()
    a, b = sys_.law("u1").stationary, sys_.law("u2").stationary
    da, db = sys_.time_derivative(a), sys_.time_derivative(b)
    dot = {s: sys_.time_derivative(s) for s in (px, py)}
    paper30 = {"u1": 2 * (dot[px] * sp.cos(theta) + dot[py] * sp.sin(theta) + pth * SEC2 / d * u2),
               "u2": 2 * (-pth * u1 * SEC2 / d)}
    out = [check_expression("sec44.u_star", SECTION, "4.4: u1* = 2(p_x cosθ + p_y sinθ + p_θ tanφ/d), "
                            "u2* = 2 p_φ", 2 * a, a, {"without the factor 2 (as (23))": a}, "ũ1")]
    for u, derived in (("u1", da), ("u2", db)):
        out.append(check_expression(f"sec44.eq30.{u}", SECTION, f"(30): derivative of {u}*",
                                    paper30[u], derived, {"without the factor 2": paper30[u] / 2},
                                    f"d/dt ũ for {u}"))
    out += [sec44_phase(), sec44_u2_nonzero(sys_), sec44_norm(), sec44_transversality()]
    return out


def sec44_phase() -> Claim:
    """ψ' = 0 does not imply u2' = 0: u = (1 + t)(1, 1/10)."""
    f1, f2 = 1 + T, (1 + T) / 10
    rate = sp.simplify((f1 * sp.diff(f2, T) - f2 * sp.diff(f1, T)) / (f1**2 + f2**2))
    implies = is_zero(sp.diff(f2, T)) or not is_zero(rate)
    return Claim("sec44.phase_rate", SECTION, "4.4: ψ' = 0 implies u2' = 0 (with u2 = 0 or u1' = 0)",
                 decide(implies), f"u = (1 + t)(1, 1/10) has ψ' = {rate} but u2' = 1/10")


def sec44_u2_nonzero(sys_: PMPSystem) -> Claim:
    """An energy boundary arc with u2 = 0: speed 0.5, p = 0.5 (cos θ, sin θ), μ = 0.25/R."""
    arc = boundary_arc(speed=0.5, rho=0.5)
    ok = verify(sys_, arc)
    return Claim("sec44.u2_nonzero", SECTION, "4.4: u2 = 0 is not feasible in the presence of an obstacle",
                 decide(not holds_all(ok)),
                 f"driving along the circle at u1 = 0.5 with φ = arctan(d/R), u2 = 0, is an energy "
                 f"extremal: {describe(ok)}")


def sec44_norm() -> Claim:
    """p_x ṗ_x + p_y ṗ_y = 0 gives |p| constant, not |p| = 0; and the printed ratio relation."""
    c0 = sp.Symbol("C_0", positive=True)
    on = {px: c0 * sp.cos(theta), py: c0 * sp.sin(theta)}
    printed = is_zero((px**2 + py**2).subs(on))
    corrected = compare((px**2 + py**2).subs(on), c0**2).equal
    a, b = sp.symbols("pdot_x pdot_y", real=True)
    ratio_printed = compare(py * a + px * b, px * a + py * b).equal  # py/px = -ṗy/ṗx
    return Claim("sec44.norm", SECTION, "4.4: p_x ṗ_x + p_y ṗ_y = 0, hence p_x² + p_y² = 0, "
                 "p = C0 (cos θ, sin θ)",
                 decide(printed, corrected, "p_x² + p_y² = C0² (constant), consistent with p = C0(cos, sin)"),
                 "d/dt(p_x² + p_y²) = 2(p_x ṗ_x + p_y ṗ_y) = 0 gives a constant; = 0 would force "
                 "p_x = p_y = 0. "
                 f"Also the printed p_y/p_x = -ṗ_y/ṗ_x is equivalent to p_x ṗ_x + p_y ṗ_y = 0: "
                 f"{ratio_printed} (the two arctans give p_y/p_x = -ṗ_x/ṗ_y)")


def sec44_transversality() -> Claim:
    """Which final-state condition gives p_φ(Tf) = 0: free φ(Tf) (engine), not fixed (paper)."""
    free_sys = energy()
    fixed = eetppco()
    fixed.final = {**fixed.final, "phi": 0.0}
    fixed_sys = derive(fixed)
    names = lambda s: [str(eq.lhs) for eq in s.transversality()]  # noqa: E731
    printed = "p_phi(T_f)" in names(fixed_sys)
    corrected = "p_phi(T_f)" in names(free_sys)
    return Claim("sec44.transversality", SECTION,
                 "4.4: if φ(Tf) is fixed, the adjoint satisfies p_θ(Tf) = 0, so u2*(Tf) = 0",
                 decide(printed, corrected, "p_φ(Tf) = 0 when φ(Tf) is FREE, hence u2*(Tf) = 0 then"),
                 f"engine transversality with φ(Tf) fixed: {names(fixed_sys)}; free: {names(free_sys)}")


def claims() -> list[Claim]:
    return [*hamiltonian_claims(), *prop3(), *hypothesis1(), *section44()]
