"""Readings the paper draws from its analysis (Sections 4.4, 5.7, 6) and its printed geometry (Section 5).

Each check recomputes the quantity the reading rests on: J under Hypothesis 1 from the cost (16) and
its discretisation (32), J against Tf at a fixed path length, the energy maximiser's continuity, the
control phase on explicit extremals, and the shortest path around the printed obstacle.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from derivations.paper.checking import Claim, compare, decide, fmt
from derivations.paper.claims_energy import SECTION as SECTION4
from derivations.paper.claims_energy import energy
from derivations.paper.claims_numbers import (
    PRINTED_CENTRE,
    PRINTED_GOAL,
    PRINTED_R_OBS,
    PRINTED_RESULTS,
    PRINTED_START,
    SECTION5,
    SECTION6,
    shortest_around_disc,
)
from derivations.paper.claims_time import straight, without_obstacle
from derivations.paper.extremals import Extremal, T, describe, holds_all, on_extremal, verify
from derivations.paper.problems import U1MAX, U2MAX
from derivations.paper.symbols import mu, phi, pph, pth, px, py, theta, u1, u2, x, y
from derivations.pmp import PMPSystem

C, TF, L = sp.Symbol("C", positive=True), sp.Symbol("T_f", positive=True), sp.Symbol("L", positive=True)
SCENARIO2 = [r for r in PRINTED_RESULTS if r[0].startswith("s2")]
"""Scenario 2, cases 1-3: the same start and goal, three final times."""


def _printed(key: str) -> tuple[str, str, float, float, bool]:
    return next(r for r in PRINTED_RESULTS if r[0] == key)


# -- 1. J = C Tf (5.7) against Hypothesis 1 ----------------------------------------------
def cost_on_constant_norm() -> tuple[sp.Expr, sp.Expr]:
    """J of (16) and of the trapezoid sum (32) for u = √C (cos ψ(t), sin ψ(t)), any phase ψ(t)."""
    lag = energy().lagrangian
    phase = sp.Function("psi")(T)
    on_circle = {u1: sp.sqrt(C) * sp.cos(phase), u2: sp.sqrt(C) * sp.sin(phase)}
    j16 = sp.integrate(sp.simplify(lag.subs(on_circle)), (T, 0, TF))
    n, k = sp.Symbol("N", positive=True, integer=True), sp.Symbol("k", integer=True)
    h = TF / n
    j32 = sp.Rational(1, 2) * sp.summation(h / 2 * (C + C), (k, 0, n - 1))  # |u_k|² = C at every node
    return sp.simplify(j16), sp.simplify(j32)


def j_ctf() -> Claim:
    j16, j32 = cost_on_constant_norm()
    printed = compare(C * TF, j16).equal and compare(C * TF, j32).equal
    corrected = compare(C * TF / 2, j16).equal and compare(C * TF / 2, j32).equal
    cmax = U1MAX**2 + U2MAX**2
    _, label, tf, energy_printed, _ = _printed("s2c1")
    return Claim("sec57.J_CTf.from_cost", SECTION5,
                 "5.7: \"Since the control norm reaches its maximum value, the constant C attains its upper bound, "
                 "and therefore the performance index J = C T_f depends primarily on the final time T_f\"; "
                 "Hypothesis 1 (4.3): u_1²(t) + u_2²(t) = C and J = ½∫(u_1² + u_2²)dt = ½ C T_f",
                 decide(printed, corrected, "J = ½ C Tf, as in Hypothesis 1"),
                 f"the engine's Lagrangian ${sp.latex(energy().lagrangian)}$ on u = √C(cos ψ(t), sin ψ(t)) for "
                 f"an arbitrary phase ψ(t): (16) gives J = ${sp.latex(j16)}$ and the trapezoid sum (32) with "
                 f"|u_k|² = C and h = Tf/N gives J = ${sp.latex(j32)}$; printed C Tf is twice that. At the upper "
                 f"bound C = u1max² + u2max² = {fmt(cmax)} and {label}'s Tf = {tf}: ½ C Tf = {fmt(cmax * tf / 2)}, "
                 f"C Tf = {fmt(cmax * tf)} (printed E = {energy_printed})")


# -- 2. minimising energy = minimising time (5.7) -----------------------------------------
def straight_energy_extremal(speed: float, horizon: float) -> Extremal:
    """Energy extremal (normal, μ = 0) along y = -1, far from the obstacle: u = (speed, 0), p = (speed, 0, 0, 0)."""
    zero = sp.Integer(0)
    values = {x: -3 + sp.Float(speed) * T, y: sp.Integer(-1), theta: zero, phi: zero,
              px: sp.Float(speed), py: zero, pth: zero, pph: zero, u1: sp.Float(speed), u2: zero, mu: zero}
    return Extremal(f"straight drive at speed {speed:g}", values, horizon=horizon)


def straight_energy(system: PMPSystem) -> sp.Expr:
    """J(L, Tf) = ∫ L_cost dt of the constant-speed straight drive of length L in time Tf."""
    speed = L / TF
    return sp.integrate(system.lagrangian.subs({u1: speed, u2: 0}), (T, 0, TF))


def energy_time() -> Claim:
    sys_ = energy()
    j = straight_energy(sys_)
    slope = sp.simplify(sp.diff(j, TF))
    increasing = bool(sp.ask(sp.Q.positive(slope)))
    decreasing = bool(sp.ask(sp.Q.negative(slope)))
    length = math.dist(PRINTED_START, PRINTED_GOAL)
    example = {tf: float(j.subs({L: length, TF: tf})) for _, _, tf, _, _ in SCENARIO2}
    ext = straight_energy_extremal(length / SCENARIO2[0][2], SCENARIO2[0][2])
    ok = verify(sys_, ext)
    printed_e = [(tf, e) for _, _, tf, e, _ in sorted(SCENARIO2, key=lambda r: r[2])]
    falls = all(b[1] < a[1] for a, b in zip(printed_e, printed_e[1:], strict=False))
    return Claim("sec57.energy_vs_time", SECTION5,
                 "5.7: \"According to Hypothesis 1, the performance index reduces to J = ½ C T_f. Therefore, "
                 "minimizing the energy becomes equivalent to minimizing the final time when the control norm "
                 "remains constant.\"",
                 decide(increasing and not decreasing),
                 f"C is not free: covering a length L at constant speed L/Tf (u2 = 0) gives C = L²/Tf² and "
                 f"J = ${sp.latex(j)}$, dJ/dTf = ${sp.latex(slope)}$ < 0 (SymPy: negative = {decreasing}), so less "
                 f"energy needs MORE time. This drive is a normal energy extremal ({describe(ok)}), and by "
                 f"Cauchy-Schwarz J ≥ (∫|u1|)²/(2Tf) ≥ L²/(2Tf) for any path of length ≥ L. With L = "
                 f"{fmt(length)} (printed start to goal): J = "
                 + ", ".join(f"{fmt(v)} at Tf = {tf}" for tf, v in example.items())
                 + ". The paper's own Scenario 2 numbers (same start and goal) fall with Tf too: "
                 + ", ".join(f"E = {e} at Tf = {tf}" for tf, e in printed_e) + f" (strictly decreasing: {falls})")


# -- 3. bang-bang energy controls confirm the PMP (6) ------------------------------------------
def clip_lipschitz(system: PMPSystem) -> dict[str, float]:
    """max |u*(a) - u*(b)| / |a - b| of each maximiser u* = law.choose over a fine grid of ψ = ũ."""
    out = {}
    for law in system.laws:
        grid = np.linspace(-3.0, 3.0, 60001)
        steps = np.abs(np.diff(law.choose(grid))) / np.diff(grid)
        out[law.control.name] = float(steps.max())
    return out


@cache
def saturating_extremal(horizon: float = 1.2) -> dict[str, np.ndarray]:
    """Integrate a normal energy extremal off the obstacle (μ = 0) with u = clip(ũ(x, p)): start at
    x = (-3, -1, 0, 0), p = (0.8, 0, 0.02, 0.5), where ũ2 = 0.5 > u2max; p_φ then falls through the bounds."""
    sys_ = energy()
    params = dict(sys_.parameters)
    rhs = sp.lambdify([*sys_.states, *sys_.costates, *sys_.controls],
                      [e.subs(mu, 0).subs(params) for e in [*sys_.dynamics, *sys_.adjoint]], "numpy")
    tilde = sp.lambdify([*sys_.states, *sys_.costates], [law.stationary.subs(params) for law in sys_.laws])

    def control(z: np.ndarray) -> list[float]:
        return [float(law.choose(v)) for law, v in zip(sys_.laws, tilde(*z), strict=True)]

    sol = solve_ivp(lambda _t, z: rhs(*z, *control(z)), (0.0, horizon), [-3, -1, 0, 0, 0.8, 0, 0.02, 0.5],
                    rtol=1e-10, atol=1e-12, max_step=0.01, dense_output=True)
    ts = np.linspace(0.0, horizon, 12001)
    z = sol.sol(ts)
    u = np.array([control(z[:, k]) for k in range(ts.size)])
    clearance = sp.lambdify(sys_.states, sys_.constraints[0].subs(params), "numpy")(*z[:4])
    return {"t": ts, "u1": u[:, 0], "u2": u[:, 1], "clearance": np.asarray(clearance, dtype=float)}


def largest_steps(run: dict[str, np.ndarray], counts: tuple[int, ...] = (100, 1000, 12000)) -> dict[int, float]:
    """Largest |u2(t_{k+1}) - u2(t_k)| when the run is sampled at ``count`` intervals (a jump would not shrink)."""
    n = run["t"].size - 1
    return {c: float(np.max(np.abs(np.diff(run["u2"][:: n // c])))) for c in counts}


def ramp(run: dict[str, np.ndarray], tol: float = 1e-9) -> tuple[float, float]:
    """Last time at u2 = +u2max before the first time at u2 = -u2max."""
    t, v = run["t"], run["u2"]
    k = int(np.nonzero(v <= -U2MAX + tol)[0][0])
    j = int(np.nonzero(v[:k] >= U2MAX - tol)[0][-1])
    return float(t[j]), float(t[k])


def bang_bang_energy() -> Claim:
    sys_ = energy()
    kinds = {law.control.name: law.kind for law in sys_.laws}
    lips = clip_lipschitz(sys_)
    run = saturating_extremal()
    steps = largest_steps(run)
    start, end = ramp(run)
    affine = any(k == "bang-singular" for k in kinds.values())
    jump = min(steps.values()) >= U2MAX  # half of the 2 u2max a bang-bang switch jumps
    slopes = ", ".join(f"{k} {fmt(v)}" for k, v in lips.items())
    sampled = ", ".join(f"{fmt(v)} at {k} intervals" for k, v in steps.items())
    return Claim("sec6.bang_bang_energy", SECTION6,
                 "5.7: \"The control strategies in Scenario 1, Scenario 2 (Case 1), and Scenario 3 ... exhibit "
                 "bang-bang behavior for both controls\"; 6: \"In all cases where the PMP analysis predicts a purely "
                 "bang-bang structure, the numerical controls remain piecewise-constant and exhibit sharp switching "
                 "events\" and \"the collocation method captures both the bang-bang and singular behaviors, and the "
                 "correspondence with the PMP analysis validates the theoretical characterization\"",
                 decide(affine or jump),
                 f"engine on EETPPCO (normal, as the paper's (18)): control laws {kinds}, d²H/du² = "
                 f"{[str(law.curvature) for law in sys_.laws]}, so u* = clip(ũ(x, p)) with clip 1-Lipschitz "
                 f"(largest slope on a grid: {slopes}): u* is as continuous as (x, p), which solve an ODE off the "
                 "obstacle (p may jump only at junctions with c = 0); the PMP predicts no bang-bang switching "
                 f"there. Integrated extremal (μ = 0, obstacle constraint c ≥ {fmt(float(run['clearance'].min()))} m "
                 f"throughout): u2 leaves +u2max at t = {fmt(start)} and reaches -u2max at t = {fmt(end)} (a ramp of "
                 f"{fmt(end - start)} s); largest u2 step between samples: {sampled} (shrinks with the grid; a "
                 f"bang-bang switch would stay {fmt(2 * U2MAX)}). Only abnormal extremals (p0 = 0) are affine in u")


# -- 4. ψ' = 0 "corresponding to a bang-bang strategy" (4.4) -----------------------------
def phase_rate(ext: Extremal) -> sp.Expr:
    """(29): ψ' = (u1 u2' - u2 u1')/(u1² + u2²) along an explicit extremal."""
    a, b = ext.at(u1), ext.at(u2)
    return sp.simplify((a * sp.diff(b, T) - b * sp.diff(a, T)) / (a**2 + b**2))


def is_bang(system: PMPSystem, ext: Extremal) -> bool:
    """Every control at a bound at every sample time."""
    ts = np.linspace(0.0, ext.horizon, 9)
    out = True
    for law in system.laws:
        f = sp.lambdify(T, ext.at(law.control).subs(system.parameters), "numpy")
        v = np.broadcast_to(np.asarray(f(ts), dtype=float), ts.shape)
        out &= bool(np.all(np.isclose(np.abs(v), law.upper)))
    return out


def phase_case(system: PMPSystem, ext: Extremal) -> dict:
    """PMP conditions, phase rate (29), bang or not, and ∂H/∂u on one explicit extremal."""
    return {"pmp": verify(system, ext), "rate": phase_rate(ext), "bang": is_bang(system, ext),
            "u": [float(ext.at(law.control)) for law in system.laws],
            "switching": [float(sp.simplify(ext.at(law.switching))) for law in system.laws]}


def _phase_text(system: PMPSystem, ext: Extremal, case: dict) -> str:
    pmp = "all hold" if holds_all(case["pmp"]) else describe(case["pmp"])
    u = ", ".join(fmt(v) for v in case["u"])
    dh = ", ".join(fmt(v) for v in case["switching"])
    return (f"{system.name} {ext.name}: PMP conditions {pmp}, ψ' = {case['rate']}, u = ({u}), "
            f"bang: {case['bang']}, ∂H/∂u on the arc = ({dh})")


def constant_phase() -> Claim:
    sys_e, sys_t = energy(), without_obstacle()
    pairs = [(sys_e, straight_energy_extremal(0.5, 1.0)), (sys_t, straight(sys_t))]
    cases = [phase_case(system, ext) for system, ext in pairs]
    arc = sys_t.singular_arc("u2", max_order=4, on=on_extremal(*pairs[1]))
    constant_not_bang = [c for c in cases if holds_all(c["pmp"]) and compare(c["rate"], 0).equal and not c["bang"]]
    jump = 2 * math.atan2(U2MAX, U1MAX)
    text = "; ".join(_phase_text(system, ext, case) for (system, ext), case in zip(pairs, cases, strict=True))
    return Claim("sec44.constant_phase_bang", SECTION4,
                 "4.4: \"Assuming that ψ'(t) = 0 (i.e., the control direction is constant, corresponding to a "
                 "bang-bang strategy) and according to Equation (21), the optimal control ... is given by u_1^* = "
                 "2(p_x cos θ + p_y sin θ + p_θ tan(φ)/d), u_2^* = 2 p_φ\"",
                 decide(not constant_not_bang and compare(jump, 0).equal),
                 f"{text}. Both have constant direction but are not bang-bang: the energy arc is interior with "
                 "∂H/∂u ≡ 0 on an interval (by the paper's own definitions in Remark 1, 3.2, a singular arc, not "
                 "bang-bang; 4.4's u* = stationary point of (21) is interior by construction), and the time-optimal "
                 f"u2 = 0 is a singular arc (engine: first u2 in d^{arc.order}ψ2/dt^{arc.order}, order q = {arc.q}, "
                 f"Kelley ${sp.latex(arc.kelley)}$). Conversely a bang-bang switch (u1max, u2max) → (u1max, -u2max) "
                 f"turns the direction by 2 arctan(u2max/u1max) = {fmt(jump)} rad, so ψ' ≠ 0 at switches: ψ' = 0 "
                 "marks constant controls, bang or not")


# -- 5. the printed geometry (5) -----------------------------------------------------------
def radial_length_slope() -> sp.Expr:
    """d/dρ of the around-the-disc length √(ρ² - r²) - r·arccos(r/ρ) contributed by one endpoint at radius ρ."""
    rho, r = sp.Symbol("rho", positive=True), sp.Symbol("r", positive=True)
    piece = sp.sqrt(rho**2 - r**2) - r * sp.acos(r / rho)
    return sp.simplify(sp.diff(piece, rho))


def radial_projection(radius: float = PRINTED_R_OBS) -> dict[str, float]:
    """Printed start and goal moved along the rays from the printed centre onto the circle of ``radius``:
    the angular gap, the shorter arc, the around-the-disc length there and its minimum over radii ≥ radius."""
    cx, cy = PRINTED_CENTRE
    angles = [math.atan2(p[1] - cy, p[0] - cx) for p in (PRINTED_START, PRINTED_GOAL)]
    gap = abs(angles[0] - angles[1]) % (2 * math.pi)
    gap = min(gap, 2 * math.pi - gap)

    def point(angle: float, rho: float) -> tuple[float, float]:
        return cx + rho * math.cos(angle), cy + rho * math.sin(angle)

    radii = np.linspace(radius, 3 * radius, 201) * (1 + 1e-12)  # on the circle, not inside by rounding
    scan = min(shortest_around_disc(point(angles[0], a), point(angles[1], b), PRINTED_CENTRE, radius)
               for a in radii for b in radii)
    on_circle = shortest_around_disc(point(angles[0], radii[0]), point(angles[1], radii[0]), PRINTED_CENTRE, radius)
    return {"gap": gap, "arc": radius * gap, "on_circle": on_circle, "scan_min": scan,
            "start_dist": math.dist(PRINTED_START, PRINTED_CENTRE),
            "goal_dist": math.dist(PRINTED_GOAL, PRINTED_CENTRE)}


def geometry() -> Claim:
    geo = radial_projection()
    slope = radial_length_slope()
    scenarios = [(label, tf, U1MAX * tf) for _, label, tf, _, goal in PRINTED_RESULTS if goal]
    printed_ok = all(max(geo["start_dist"], geo["goal_dist"]) >= PRINTED_R_OBS and geo["on_circle"] <= reach
                     for _, _, reach in scenarios)
    repaired = [label for label, _, reach in scenarios if min(geo["arc"], geo["scan_min"]) <= reach]
    return Claim("sec5.geometry.radial_projection", SECTION5,
                 f"5: \"Rear axle of the truck: (x0, y0) = (0,0)\", \"Obstacle center: (x_obs, y_obs) = (0.5, 0.03), "
                 f"obstacle radius: r_obs = 1 m\", \"Control bounds: u_1,k ∈ [-1, 1]\", terminal position (1, 0) for "
                 f"Scenarios 2 and 3, and the printed final times {[tf for _, tf, _ in scenarios]}: a path exists",
                 decide(printed_ok, bool(repaired), f"reachable for {repaired}"),
                 f"start and goal lie {fmt(geo['start_dist'])} and {fmt(geo['goal_dist'])} m from the centre, inside "
                 f"r_obs = {PRINTED_R_OBS}. Moved radially onto the circle they are {fmt(geo['gap'])} rad apart; the "
                 f"shorter arc is {fmt(geo['arc'])} m (around-the-disc length there {fmt(geo['on_circle'])} m), and "
                 f"moving either end further out only lengthens the path (d/dρ = ${sp.latex(slope)}$ ≥ 0; scan of "
                 f"radii {PRINTED_R_OBS}-{3 * PRINTED_R_OBS} on both rays: minimum {fmt(geo['scan_min'])} m). "
                 "u1max·Tf = " + ", ".join(f"{fmt(reach)} m ({label})" for label, _, reach in scenarios)
                 + ": all shorter, so no start/goal on these rays is reachable within any printed Tf")


def claims() -> list[Claim]:
    return [j_ctf(), energy_time(), bang_bang_energy(), constant_phase(), geometry()]
