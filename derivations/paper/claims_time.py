"""Section 3 of the paper: time-optimal control, (5)-(15), Propositions 1 and 2."""

from __future__ import annotations

from functools import cache

import sympy as sp

from derivations.paper.checking import Claim, check_expression, compare, decide, is_zero, nonvanishing
from derivations.paper.extremals import Extremal, T, describe, holds_all, on_extremal, verify
from derivations.paper.problems import U1MAX, U2MAX, toctaco, toctpco
from derivations.paper.symbols import DIST, PAPER_PSI1, R, d, mu, phi, pph, pth, px, py, theta, u1, u2, x, xo, y, yo
from derivations.pmp import PMPSystem, derive
from derivations.symbolic import derivative_symbol
from model.vehicles import sym

SECTION = "3 Time-optimal control"
PSI1 = PAPER_PSI1

# PAPER (claims under test), typed from the text.
PAPER_H5 = -1 + mu * (R - DIST) + PSI1 * u1 + pph * u2
PAPER_ADJ6 = {
    "x": mu * (x - xo) / DIST,
    "y": mu * (y - yo) / DIST,
    "theta": (px * sp.sin(theta) - py * sp.cos(theta)) * u1,
    "phi": -pth * u1 * (1 + sp.tan(phi) ** 2) / d,
}
PAPER_PSI8 = {"u1": PSI1, "u2": pph}
PAPER_H10 = -1 + PSI1 * u1 + pph * u2


@cache
def with_obstacle() -> PMPSystem:
    return derive(toctpco())


@cache
def without_obstacle() -> PMPSystem:
    return derive(toctaco())


def _mu_flip(expr: sp.Expr) -> dict[str, sp.Expr]:
    return {"mu_paper = -mu, i.e. the paper's multiplier is <= 0": expr.subs(mu, -mu)}


# -- explicit extremals ---------------------------------------------------------
def straight(system: PMPSystem, heading: sp.Expr | None = None) -> Extremal:
    """Full speed along a fixed heading, u2 = 0 singular, p = (cos, sin)/u1max, H = 0."""
    heading = sp.Integer(0) if heading is None else heading
    c, s = sp.cos(heading), sp.sin(heading)
    values = {x: U1MAX * c * T, y: U1MAX * s * T, theta: heading, phi: sp.Integer(0),
              px: c / U1MAX, py: s / U1MAX, pth: sp.Integer(0), pph: sp.Integer(0),
              u1: sp.Float(U1MAX), u2: sp.Integer(0)}
    values.update({m: sp.Integer(0) for m in system.multipliers})
    return Extremal(f"straight line at heading {heading}", values, horizon=0.3)


def steer_in_place(system: PMPSystem) -> Extremal:
    """u1 = 0 (singular, psi1 = 0), u2 = u2max: wheels turn, the truck stands still; H = 0."""
    values = {x: sp.Integer(0), y: sp.Integer(0), theta: sp.Integer(0), phi: U2MAX * T,
              px: sp.Integer(0), py: sp.Integer(0), pth: sp.Integer(0), pph: sp.Float(1 / U2MAX),
              u1: sp.Integer(0), u2: sp.Float(U2MAX)}
    values.update({m: sp.Integer(0) for m in system.multipliers})
    return Extremal("steering in place", values, horizon=1.0)


def boundary_arc(speed: float = U1MAX, rho: float = 1 / U1MAX) -> Extremal:
    """Counter-clockwise along the circle c = 0 at constant ``speed``: tan(phi) = d/R, u2 = 0,
    p = rho (cos theta, sin theta), p_theta = p_phi = 0, mu = rho * speed / R."""
    alpha = sp.pi + T * speed / R
    th = alpha + sp.pi / 2
    values = {x: xo + R * sp.cos(alpha), y: yo + R * sp.sin(alpha), theta: th,
              phi: sp.atan(d / R), px: rho * sp.cos(th), py: rho * sp.sin(th),
              pth: sp.Integer(0), pph: sp.Integer(0), u1: sp.Float(speed), u2: sp.Integer(0),
              mu: rho * speed / R}
    return Extremal(f"boundary arc (ccw, speed {speed:g})", values, horizon=0.5)


def abnormal_both_singular() -> Extremal:
    """p0 = 0: u1 = 0, u2 = u2max/2, p = (-sin th0, cos th0, 0, 0): psi1 = psi2 = 0."""
    values = {x: sp.Integer(0), y: sp.Integer(0), theta: sp.Integer(0), phi: U2MAX / 2 * T,
              px: sp.Integer(0), py: sp.Integer(1), pth: sp.Integer(0), pph: sp.Integer(0),
              u1: sp.Integer(0), u2: sp.Float(U2MAX / 2)}
    return Extremal("abnormal, both controls singular", values, horizon=1.0)


# -- (5)-(11) ---------------------------------------------------------------------
def eq5_eq6() -> list[Claim]:
    sys_ = with_obstacle()
    out = [check_expression("eq5.hamiltonian", SECTION, "(5): H = -1 + μ(R - dist) + ψ1 u1 + p_φ u2",
                            PAPER_H5, sys_.hamiltonian, _mu_flip(PAPER_H5), "H")]
    own = all(compare(PAPER_ADJ6[s.name], -sp.diff(PAPER_H5, s)).equal for s in sys_.states)
    out.append(Claim("eq6.consistent_with_eq5", SECTION, "(6) = -dH/dX with the paper's own H (5)",
                     decide(own), "each line of (6) equals -∂H₅/∂state"))
    for s in sys_.states:
        printed = PAPER_ADJ6[s.name]
        out.append(check_expression(f"eq6.p_{s.name}", SECTION, f"(6): p_{s.name}' = {sp.sstr(printed)}",
                                    printed, sys_.adjoint_of(s.name), _mu_flip(printed),
                                    f"p_{s.name}'"))
    out.append(eq6_mu_sign())
    return out


def eq6_mu_sign() -> Claim:
    """The multiplier a boundary arc needs: ours mu = 1/R >= 0; the paper's (6) needs -1/R."""
    sys_ = with_obstacle()
    arc = boundary_arc()
    ok = verify(sys_, arc)
    mu_paper = sp.simplify(sp.diff(arc.at(px), T) * arc.at(DIST) / arc.at(x - xo))
    printed = bool(sp.simplify(mu_paper).is_nonnegative)
    return Claim(
        "eq6.mu_sign", SECTION,
        "(5)-(6) with a multiplier μ ≥ 0 (the sign of a multiplier of an inequality; "
        "the paper never states it)",
        decide(printed, holds_all(ok), "μ_paper = -μ ≤ 0; equivalently H = ... + μ(dist - R), μ ≥ 0"),
        f"on the ccw full-speed boundary arc the project's convention gives μ = {sp.latex(arc.at(mu))} "
        f"≥ 0 and every PMP condition holds ({describe(ok)}); the paper's (6) needs "
        f"μ_paper = ${sp.latex(mu_paper)}$ < 0 on the same extremal",
    )


def eq8_eq11() -> list[Claim]:
    sys_p, sys_a = with_obstacle(), without_obstacle()
    out = [check_expression(f"eq8.psi_{u}", SECTION, f"(8): ψ for {u} = {sp.sstr(PAPER_PSI8[u])}",
                            PAPER_PSI8[u], sys_p.law(u).switching, what=f"∂H/∂{u}")
           for u in ("u1", "u2")]
    out.append(eq9_law())
    out.append(check_expression("eq10.hamiltonian", SECTION, "(10): obstacle-free H", PAPER_H10,
                                sys_a.hamiltonian, what="H"))
    zero = is_zero(sys_a.adjoint_of("x")) and is_zero(sys_a.adjoint_of("y"))
    out.append(Claim("eq10.adjoint_xy", SECTION, "Without obstacle p_x' = p_y' = 0", decide(zero),
                     "the engine's adjoints for x, y vanish without the μc term"))
    affine = compare(sys_a.hamiltonian - sys_a.p0 * sys_a.lagrangian,
                     PAPER_PSI8["u1"] * u1 + PAPER_PSI8["u2"] * u2).equal
    out.append(Claim("eq11.maximum", SECTION, "(11): H* = -1 + max(ψ1 u1 + ψ2 u2)", decide(affine),
                     "H - p0 L = ψ1 u1 + ψ2 u2 exactly, so maximising H is maximising ψ·u"))
    out.append(eq12_cases())
    return out


def eq9_law() -> Claim:
    """Bang-bang law; with ψ = 0 the whole closed interval maximises H, not only the open one."""
    sys_ = without_obstacle()
    law = sys_.law("u1")
    bang = list(law.choose([1.0, -1.0])) == [law.upper, law.lower]
    at_psi0 = {px: 0, py: 0, pth: 0}  # a point where psi1 = 0
    values = [sys_.hamiltonian.subs(at_psi0).subs(u1, v) for v in (law.lower, 0.0, law.upper)]
    closed = all(compare(v, values[1]).equal for v in values)
    return Claim("eq9.bang_bang", SECTION, "(9): u = umax if ψ > 0, -umax if ψ < 0, "
                 "in ]-umax, umax[ if ψ = 0",
                 decide(bang and not closed, bang and closed,
                        "with ψ = 0 every u in the closed interval [-umax, umax] maximises H"),
                 "ψ > 0 → upper, ψ < 0 → lower as printed; at a point with ψ1 = 0, H takes the same value "
                 "at u1 = -1, 0, 1, so a singular control may also sit on a bound")


def eq12_cases() -> Claim:
    """Do the four printed cases cover the maximiser for every sign pattern of (ψ1, ψ2)?"""
    sys_ = without_obstacle()
    l1, l2 = sys_.law("u1"), sys_.law("u2")
    patterns = [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)]
    chosen = [(float(l1.choose(a)), float(l2.choose(b))) for a, b in patterns]
    printed_case1 = [(abs(U1MAX), abs(U2MAX))]
    printed = all(c in printed_case1 for c in chosen)
    corrected = all(abs(a) == U1MAX and abs(b) == U2MAX for a, b in chosen)
    return Claim("eq12.cases", SECTION, "(12) Case 1: u1 = |u1max|, u2 = |u2max| (bang on both)",
                 decide(printed, corrected, "u_i = sign(ψ_i) u_i^max, four sign combinations"),
                 f"maximisers for ψ sign patterns {patterns}: {chosen}; "
                 "printed Case 1 has only the (+, +) one")


# -- Proposition 1 ------------------------------------------------------------------
def prop1() -> list[Claim]:
    sys_ = without_obstacle()
    out = [check_expression("prop1.case2.psi2", SECTION, "Proof of Prop. 1, Case 2: ψ2 = p_θ", pth,
                            sys_.law("u2").switching, {"ψ2 = p_φ as in (8)": pph}, "ψ2 = ∂H/∂u2")]
    out.append(prop1_case2_chain(sys_))
    straight_ok = verify(sys_, straight(sys_))
    arc = sys_.singular_arc("u2", max_order=4, on=on_extremal(sys_, straight(sys_)))
    out.append(Claim(
        "prop1.case2.no_singular_arc", SECTION,
        "Prop. 1, Case 2: no singular arc of u2 (the proof ends with u2 = 0, a straight line)",
        decide(not holds_all(straight_ok)),
        f"the straight extremal u = (u1max, 0), p = (1/u1max, 0, 0, 0), H = 0 satisfies every PMP "
        f"condition ({describe(straight_ok)}) with ψ2 ≡ 0 and u2 = 0 interior: a singular arc. "
        f"Its order is {arc.q} (first u2 in d^{arc.order}ψ2/dt^{arc.order}), Kelley expression "
        f"${sp.latex(arc.kelley)}$ ≤ 0, so the generalised Legendre-Clebsch condition holds and "
        "does not exclude it (order 2: junctions with bang arcs chatter, Fuller)",
    ))
    out.append(prop1_case3(sys_))
    out.append(prop1_case4(sys_))
    place_ok = verify(sys_, steer_in_place(sys_))
    out.append(Claim(
        "prop1.statement", SECTION, "Prop. 1: time-optimal obstacle-free controls are bang-bang",
        decide(not (holds_all(straight_ok) or holds_all(place_ok))),
        "two extremals with a singular control are time-optimal: the straight drive to a goal ahead "
        "(Tf = distance/u1max, the lower bound) and steering in place to a goal differing only in φ "
        "(Tf = |Δφ|/u2max, the lower bound, attained only with u1 ≡ 0)",
    ))
    return out


def prop1_case2_chain(sys_: PMPSystem) -> Claim:
    """ψ2 ≡ 0 ⇒ p_θ = 0 ⇒ p ∥ heading ⇒ (H = 0) tan φ = 0 ⇒ u2 = 0, computed."""
    rho = sp.Symbol("rho", real=True)
    dpsi2 = sys_.time_derivative(pph)
    step1 = compare(dpsi2, -pth * u1 * (1 + sp.tan(phi) ** 2) / d).equal  # zero iff p_theta = 0
    g = px * sp.sin(theta) - py * sp.cos(theta)
    step2 = compare(sys_.time_derivative(pth).subs(pth, 0), g * u1).equal
    on_surface = {px: rho * sp.cos(theta), py: rho * sp.sin(theta), pth: 0, pph: 0}
    h_val = sp.solve(sys_.hamiltonian.subs(on_surface), rho)  # H = 0 fixes rho = 1/u1
    dg = sp.simplify(sys_.time_derivative(g).subs(on_surface).subs(rho, h_val[0]))
    step3 = compare(dg, sp.tan(phi) / d).equal
    ok = step1 and step2 and step3 and len(h_val) == 1
    return Claim("prop1.case2.chain", SECTION,
                 "Prop. 1 Case 2 (with ψ2 = p_φ): p_θ = 0, p_x sinθ - p_y cosθ = 0, φ = 0, u2 = 0",
                 decide(ok),
                 rf"$\dot\psi_2 = {sp.latex(dpsi2)}$ ⇒ $p_\theta = 0$; "
                 rf"then $\dot p_\theta = u_1(p_x\sin\theta - p_y\cos\theta)$ "
                 rf"⇒ $p = \rho(\cos\theta, \sin\theta)$; H = 0 gives ρ = {h_val}; "
                 rf"then $\frac{{d}}{{dt}}(p_x\sin\theta - p_y\cos\theta) = {sp.latex(dg)} = 0$ "
                 "⇒ φ = 0, u2 = 0")


def prop1_case3(sys_: PMPSystem) -> Claim:
    place = steer_in_place(sys_)
    ok = verify(sys_, place)
    psi2 = sp.solve((sys_.hamiltonian - PAPER_PSI8["u1"] * u1).subs(pph, sym("psi2")), sym("psi2"))
    return Claim(
        "prop1.case3", SECTION, "Prop. 1 Case 3 (ψ1 ≡ 0, u2 = ±u2max) is not feasible",
        decide(not holds_all(ok)),
        f"with ψ1 = 0, H = 0 gives ψ2 = {psi2} (a non-zero constant, not ψ2 = p_θ' = 0 as printed); "
        f"the extremal u1 = 0, u2 = u2max, p = (0, 0, 0, 1/u2max) satisfies every PMP condition "
        f"({describe(ok)}), and it is time-optimal for a goal that differs only in φ",
    )


def prop1_case4(sys_: PMPSystem) -> Claim:
    h_case4 = sp.simplify(sys_.hamiltonian - PAPER_PSI8["u1"] * u1 - PAPER_PSI8["u2"] * u2)
    normal = compare(h_case4, -1).equal
    abn = derive(toctaco(), abnormal=True)
    abn_ok = verify(abn, abnormal_both_singular())
    return Claim("prop1.case4", SECTION, "Prop. 1 Case 4 (ψ1 ≡ ψ2 ≡ 0): H = -1 contradicts H = 0",
                 decide(normal),
                 f"with both ψ = 0, H = p0 = {h_case4} ≠ 0 for normal extremals. The paper ignores "
                 f"abnormal ones (p0 = 0): u1 = 0, u2 = u2max/2, p = (0, 1, 0, 0) is an abnormal "
                 f"extremal with both controls singular ({describe(abn_ok)})")


# -- Proposition 2 ------------------------------------------------------------------
def prop2() -> list[Claim]:
    sys_ = with_obstacle()
    g = px * sp.sin(theta) - py * sp.cos(theta)
    eq13 = compare(g / (px * sp.cos(theta)), sp.tan(theta) - py / px).equal
    out = [Claim("prop2.eq13", SECTION, "(13): on a Case-2 arc θ = arctan(p_y/p_x), p_x ≠ 0",
                 decide(eq13), "p_θ = 0 ⇒ p_x sinθ - p_y cosθ = 0 ⇔ tanθ = p_y/p_x (θ modulo π)")]
    theta0 = sp.solve(sp.sin(theta) - sp.cos(theta), theta)
    printed = is_zero(g.subs({py: px, theta: 0}).subs(px, 1))
    line = straight(sys_, sp.pi / 4)
    line_ok = verify(sys_, line)
    out.append(Claim("prop2.case2.px_eq_py", SECTION, "Prop. 2 Case 2: if p_x = p_y then θ = 0 (nπ)",
                     decide(printed, holds_all(line_ok), "θ = π/4 + nπ (tan θ = 1)"),
                     f"p_x = p_y ≠ 0 in p_x sinθ - p_y cosθ = 0 gives θ ∈ {theta0} (+ nπ), not 0; the "
                     f"straight extremal at θ = π/4 with p_x = p_y satisfies every PMP condition "
                     f"({describe(line_ok)})"))
    out.append(prop2_phi())
    out += prop2_psi1(sys_)
    out.append(prop2_case3(sys_))
    h4 = sp.simplify(sys_.hamiltonian - PAPER_PSI8["u1"] * u1 - PAPER_PSI8["u2"] * u2)
    case4 = compare(h4.subs(mu, 0), -1).equal  # complementarity: mu*c = 0
    out.append(Claim("prop2.case4", SECTION, "Prop. 2 Case 4: H = -1 + μ(R - dist) = 0 is impossible",
                     decide(case4), f"with both ψ ≡ 0, H = ${sp.latex(h4)}$ = -1 by μc = 0: contradiction "
                     "with H = 0 (normal extremals)"))
    arc_ok = verify(sys_, boundary_arc())
    out.append(Claim(
        "prop2.conclusion", SECTION,
        "Prop. 2 conclusion: singular arcs only in Case 2 with p_x ≠ p_y (u2) and in Case 3 (u1); "
        "statement: singular arcs where the control direction varies at constant norm",
        decide(False, holds_all(arc_ok) and holds_all(line_ok),
               "singular u2-arcs are straight lines (any p_x, p_y, also p_x = p_y) off the obstacle and "
               "boundary arcs with tan φ = d/R on it; on both the control is constant (u1max, 0)"),
        f"straight singular extremal with p_x = p_y: {describe(line_ok)}; boundary arc: {describe(arc_ok)}",
    ))
    return out


def prop2_phi() -> Claim:
    """φ on a Case-2 arc from d/dt(p_x sinθ - p_y cosθ) = 0, with ṗ kept as symbols."""
    a, b = sp.symbols("pdot_x pdot_y", real=True)
    tphi = sp.Symbol("tanphi", real=True)
    rho = sp.sqrt(px**2 + py**2)
    dg = a * sp.sin(theta) - b * sp.cos(theta) + (px * sp.cos(theta) + py * sp.sin(theta)) * u1 * tphi / d
    sol = sp.solve(dg.subs({sp.cos(theta): px / rho, sp.sin(theta): py / rho}), tphi)
    paper = d * (b * px - a * py) / (u1 * (px**2 + py**2))
    ok = len(sol) == 1 and compare(sol[0], paper).equal
    return Claim("prop2.case2.phi", SECTION,
                 r"Prop. 2 Case 2: $\phi = \arctan\frac{d(\dot p_y p_x - \dot p_x p_y)}{u_1(p_x^2+p_y^2)}$",
                 decide(ok), f"solving d/dt(p_x sinθ - p_y cosθ) = 0 for tanφ gives ${sp.latex(sol)}$; "
                 "off the obstacle μ = 0 so ṗ = 0 and φ = 0 (straight); curved only on the boundary")


def prop2_psi1(sys_: PMPSystem) -> list[Claim]:
    """ψ1', the unnumbered ψ1'' line and (15) against the engine's derivatives."""
    dot = {s: sys_.time_derivative(s) for s in (px, py)}
    ddot = {s: sys_.time_derivative(dot[s]) for s in (px, py)}
    thd, phd, phdd = u1 * sp.tan(phi) / d, u2, derivative_symbol(u2, 1)
    sec2 = 1 + sp.tan(phi) ** 2
    paper_d1 = dot[px] * sp.cos(theta) + dot[py] * sp.sin(theta) + pth / d * sec2 * phd
    d1, d2 = sys_.switching_derivatives("u1", 2)[1:]
    common = (ddot[px] * sp.cos(theta) + ddot[py] * sp.sin(theta)
              - (dot[px] * sp.sin(theta) - dot[py] * sp.cos(theta)) * thd
              + pth / d * (sec2 * phdd + 2 * sp.tan(phi) * sec2 * phd**2))
    line1 = common + pth / d * sec2 * phd
    line1_dot = common + sys_.time_derivative(pth) / d * sec2 * phd
    eq15 = common + (px * sp.sin(theta) - py * sp.cos(theta)) * u1 / d * sec2 * phd
    return [
        check_expression("prop2.psi1_dot", SECTION,
                         "Prop. 2 Case 3: ψ1' = ṗx cosθ + ṗy sinθ + p_θ(1+tan²φ)φ'/d",
                         paper_d1, d1, what="{ψ1, H}"),
        check_expression("prop2.psi1_ddot", SECTION, "Prop. 2 Case 3: the printed ψ1'' before (15) "
                         "(4th term p_θ(1+tan²φ)φ'/d)", line1, d2,
                         {"ṗ_θ instead of p_θ in the 4th term (typo)": line1_dot}, "d²ψ1/dt²"),
        check_expression("prop2.eq15", SECTION, "(15): ψ1'' after substituting ṗ_θ and θ'", eq15, d2,
                         what="d²ψ1/dt²"),
    ]


def prop2_case3(sys_: PMPSystem) -> Claim:
    """Does ψ1'' = 0 determine u1 on a Case-3 arc off the obstacle (μ = 0)?"""
    d2 = sys_.switching_derivatives("u1", 2)[2]
    coef = sp.diff(d2, u1)
    generic = nonvanishing(coef.subs({sym("u2'"): 0}))
    surface = {mu: 0, derivative_symbol(mu, 1): 0, pth: 0, px: 0, py: 0}
    on_surface = sp.simplify(coef.subs(surface))
    determined = generic and not is_zero(on_surface)
    return Claim("prop2.case3", SECTION, "Prop. 2 Case 3: (15) = 0 implicitly defines the singular u1",
                 decide(determined),
                 f"generic coefficient of u1 in ψ1'' non-zero: {generic}; but off the obstacle "
                 "ψ1 = ψ1' = ψ1'' = 0 "
                 rf"with u1 ≠ 0 forces p_θ = p_x = p_y = 0, where it is {sp.latex(on_surface)}: u1 is "
                 "left undetermined (the steering-in-place family of prop1.case3)")


def claims() -> list[Claim]:
    return [*eq5_eq6(), *eq8_eq11(), *prop1(), *prop2()]
