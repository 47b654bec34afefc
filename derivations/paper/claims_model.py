"""Section 2 of the paper: the truck model (1), rolling constraints (2), obstacle (3)."""

from __future__ import annotations

import sympy as sp

from derivations.paper.checking import Claim, compare, decide, is_zero, nonvanishing
from derivations.symbolic import circle_constraint, obstacle_symbols
from model.vehicles import Truck, sym

SECTION = "2 Model"
x, y, theta, phi = (sym(n) for n in ("x", "y", "theta", "phi"))
u1, u2, d = sym("u1"), sym("u2"), sym("d")
t = sp.Symbol("t", real=True)

# PAPER (claims under test), typed from the text.
PAPER_EQ1 = {"x": u1 * sp.cos(theta), "y": u1 * sp.sin(theta), "theta": u1 * sp.tan(phi) / d, "phi": u2}


def _velocity() -> dict[str, sp.Expr]:
    return Truck().dynamics()


def eq1_dynamics() -> Claim:
    f = _velocity()
    ok = all(compare(PAPER_EQ1[k], f[k]).equal for k in PAPER_EQ1)
    return Claim("eq1.dynamics", SECTION, "System (1): x'=u1 cos θ, y'=u1 sin θ, θ'=u1 tan φ/d, φ'=u2",
                 decide(ok), "model.vehicles.Truck.dynamics() agrees component by component")


def eq1_speed() -> Claim:
    f = _velocity()
    ok = compare(sp.sqrt(f["x"] ** 2 + f["y"] ** 2), sp.Abs(u1)).equal
    return Claim("eq1.speed", SECTION, r"$|u_1| = \sqrt{\dot x^2 + \dot y^2}$", decide(ok),
                 r"$\dot x^2 + \dot y^2 = u_1^2(\cos^2\theta + \sin^2\theta)$")


def eq1_theta_arctan() -> Claim:
    """θ = arctan(y/x) against a trajectory of (1): the straight drive x = 1 + t, y = 1, θ = 0."""
    traj = {x: 1 + t, y: sp.Integer(1), theta: sp.Integer(0), phi: sp.Integer(0), u1: sp.Integer(1),
            u2: sp.Integer(0)}
    f = _velocity()
    solves = all(compare(sp.diff(traj[s], t), f[s.name].subs(traj)).equal for s in (x, y, theta, phi))
    printed = solves and compare(traj[theta], sp.atan(traj[y] / traj[x])).equal
    heading = compare(sp.tan(theta) * f["x"], f["y"]).equal  # tan θ = y'/x'
    gap = sp.atan(traj[y] / traj[x]).subs(t, 0) - traj[theta]
    return Claim(
        "eq1.theta_arctan", SECTION, r"(1): $\theta = \arctan(y/x)$",
        decide(printed, heading, r"$\tan\theta = \dot y/\dot x$ (heading of the velocity), not $y/x$"),
        f"x = 1 + t, y = 1, θ = φ = 0, u = (1, 0) solves (1): {solves}; at t = 0 "
        f"arctan(y/x) - θ = ${sp.latex(gap)}$ ≠ 0. The heading relation holds: {heading}",
    )


def eq2_rolling() -> list[Claim]:
    f = _velocity()
    rear = f["x"] * sp.sin(theta) - f["y"] * sp.cos(theta)
    front = f["x"] * sp.sin(theta + phi) - f["y"] * sp.cos(theta + phi) - d * sp.cos(phi) * f["theta"]
    return [
        Claim("eq2.rear", SECTION, r"(2a): $\dot x \sin\theta - \dot y\cos\theta = 0$ along (1)",
              decide(is_zero(rear)), "substituting (1) gives 0 identically"),
        Claim("eq2.front", SECTION,
              r"(2b): $\dot x\sin(\theta+\phi) - \dot y\cos(\theta+\phi) - d\cos\phi\,\dot\theta = 0$",
              decide(is_zero(front)), r"substituting (1): $u_1\sin\phi - u_1 \sin\phi = 0$"),
    ]


def _bracket(f: sp.Matrix, g: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """Lie bracket [f, g] = Dg f - Df g."""
    return g.jacobian(q) * f - f.jacobian(q) * g


def eq2_nonholonomic() -> Claim:
    """Constraints (2) non-integrable: the control vector fields and brackets span R^4."""
    q = sp.Matrix([x, y, theta, phi])
    rhs = sp.Matrix(Truck().rhs(numeric=False))
    g1, g2 = rhs.diff(u1), rhs.diff(u2)
    g3 = _bracket(g1, g2, q)
    g4 = _bracket(g1, g3, q)
    det = sp.simplify(sp.Matrix.hstack(g1, g2, g3, g4).det())
    nonzero = nonvanishing(det)
    return Claim("eq2.nonholonomic", SECTION, "Constraints (2) are non-integrable (nonholonomic)",
                 decide(bool(nonzero)),
                 rf"$\det[g_1, g_2, [g_1,g_2], [g_1,[g_1,g_2]]] = {sp.latex(det)} \ne 0$ for "
                 r"$|\phi| < \pi/2$: bracket-generating, so no integral (Frobenius/Chow)")


def eq3_obstacle() -> Claim:
    xo, yo, radius = obstacle_symbols(0, 1)
    c = circle_constraint(x, y, xo, yo, radius)
    paper4 = radius - sp.sqrt((x - xo) ** 2 + (y - yo) ** 2)
    ok = compare(paper4, -c).equal
    return Claim("eq3.obstacle", SECTION, r"(3) $\sqrt{(x-x_{obs})^2+(y-y_{obs})^2} \ge R$ and (4)'s "
                 r"$R - \sqrt{\cdot} \le 0$ are the project's $c = \mathrm{dist} - R \ge 0$",
                 decide(ok), "(4)'s constraint function is -c")


def claims() -> list[Claim]:
    return [eq1_dynamics(), eq1_speed(), eq1_theta_arctan(), *eq2_rolling(), eq2_nonholonomic(),
            eq3_obstacle()]
