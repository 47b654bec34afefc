"""Sections 5 and 6 of the paper: consistency of the printed numbers and of the J = C Tf remarks."""

from __future__ import annotations

import math

import sympy as sp

from derivations.paper.checking import Claim, decide, fmt
from derivations.paper.problems import OBSTACLE, U1MAX, U2MAX

SECTION5 = "5 Numerical results"
SECTION6 = "6 Comparison PMP / numerics"

# PAPER (claims under test): Section 5's printed parameters and results.
PRINTED_CENTRE = (0.5, 0.03)
PRINTED_R_OBS = 1.0
PRINTED_START = (0.0, 0.0)
PRINTED_GOAL = (1.0, 0.0)  # "imposed for Scenarios 2 and 3"; Scenario 1's goal is not printed
PRINTED_RESULTS = [
    # (id, label, Tf, E, goal printed?)
    ("s1", "Scenario 1", 1.15, 27.7, False),
    ("s2c1", "Scenario 2 case 1", 1.53, 71.0, True),
    ("s2c2", "Scenario 2 case 2", 1.7, 61.0, True),
    ("s2c3", "Scenario 2 case 3", 2.5, 43.67, True),
    ("s3", "Scenario 3", 1.22, 62.82, True),
]


def max_energy(tf: float) -> float:
    """The largest J = 1/2 ∫(u1² + u2²) the bounds allow; the trapezoid sum (32) has the same bound."""
    return 0.5 * (U1MAX**2 + U2MAX**2) * tf


def shortest_around_disc(a: tuple[float, float], b: tuple[float, float],
                         centre: tuple[float, float], radius: float) -> float:
    """Length of the shortest path from a to b avoiding the open disc (inf if a or b is inside):
    the straight segment, or two tangent segments plus the shorter arc."""
    ax, ay = a[0] - centre[0], a[1] - centre[1]
    bx, by = b[0] - centre[0], b[1] - centre[1]
    da, db = math.hypot(ax, ay), math.hypot(bx, by)
    if da < radius or db < radius:
        return math.inf
    seg = (bx - ax, by - ay)
    s = max(0.0, min(1.0, -(ax * seg[0] + ay * seg[1]) / (seg[0] ** 2 + seg[1] ** 2)))
    if math.hypot(ax + s * seg[0], ay + s * seg[1]) >= radius:
        return math.hypot(*seg)
    gap = math.acos(max(-1.0, min(1.0, (ax * bx + ay * by) / (da * db))))
    arc = gap - math.acos(radius / da) - math.acos(radius / db)
    return math.sqrt(da**2 - radius**2) + math.sqrt(db**2 - radius**2) + radius * arc


def energy_bounds() -> list[Claim]:
    out = []
    for key, label, tf, energy, _ in PRINTED_RESULTS:
        emax = max_energy(tf)
        out.append(Claim(f"sec5.energy_bound.{key}", SECTION5, f"{label}: Tf = {tf} s, E = {energy}",
                         decide(energy <= emax),
                         f"|u1| ≤ {U1MAX}, |u2| ≤ {U2MAX} give E ≤ ½(u1max² + u2max²)Tf = "
                         f"{fmt(0.5 * (U1MAX**2 + U2MAX**2))}·Tf = {fmt(emax)}; printed E is "
                         f"{fmt(energy / emax)} times that"))
    return out


def start_goal() -> Claim:
    ds = [math.dist(p, PRINTED_CENTRE) for p in (PRINTED_START, PRINTED_GOAL)]
    outside = all(v >= PRINTED_R_OBS for v in ds)
    project = all(v >= OBSTACLE.keep_out for v in ds)
    return Claim("sec5.start_goal_outside", SECTION5,
                 f"start {PRINTED_START} and goal {PRINTED_GOAL} are admissible for the obstacle centred "
                 f"{PRINTED_CENTRE} with r_obs = {PRINTED_R_OBS} (R = r_obs + d_s ≥ 1)",
                 decide(outside, project, f"with the project's R = {OBSTACLE.keep_out} both lie outside"),
                 f"distances to the centre: {fmt(ds[0])}, {fmt(ds[1])} < {PRINTED_R_OBS}: both lie inside "
                 "the forbidden disc, so no admissible trajectory exists")


def reachability() -> list[Claim]:
    out = []
    l_printed = shortest_around_disc(PRINTED_START, PRINTED_GOAL, PRINTED_CENTRE, PRINTED_R_OBS)
    l_project = shortest_around_disc(PRINTED_START, PRINTED_GOAL, PRINTED_CENTRE, OBSTACLE.keep_out)
    for key, label, tf, _, goal_printed in PRINTED_RESULTS:
        if not goal_printed:
            continue
        reach = U1MAX * tf
        out.append(Claim(f"sec5.reach.{key}", SECTION5,
                         f"{label}: (1, 0) is reached from (0, 0) around the obstacle within Tf = {tf} s",
                         decide(l_printed <= reach, l_project <= reach,
                                f"with R = {OBSTACLE.keep_out}: shortest path {fmt(l_project)} m ≤ "
                                f"u1max·Tf = {fmt(reach)} m"),
                         f"shortest admissible path with r_obs = {PRINTED_R_OBS}: {fmt(l_printed)} m "
                         f"(inf: start inside); with R = {OBSTACLE.keep_out}: {fmt(l_project)} m; "
                         f"u1max·Tf = {fmt(reach)} m"))
    return out


def j_equals_ctf() -> Claim:
    """5.7 writes J = C Tf where 4.3 has J = ½ C Tf."""
    c, tf, t = sp.symbols("C T_f t", positive=True)
    j = sp.integrate(c / 2, (t, 0, tf))
    return Claim("sec5.J_CTf", SECTION5, "5.7: with |u|² = C the performance index is J = C Tf",
                 decide(sp.simplify(j - c * tf) == 0, sp.simplify(j - c * tf / 2) == 0, "J = ½ C Tf"),
                 f"½∫₀^Tf C dt = {j}")


def implied_c() -> Claim:
    """C = 2E/Tf from the printed numbers against the largest |u|² the bounds allow."""
    cmax = U1MAX**2 + U2MAX**2
    implied = {key: 2 * e / tf for key, _, tf, e, _ in PRINTED_RESULTS}
    ok = all(v <= cmax for v in implied.values())
    return Claim("sec6.C_values", SECTION6, "6: J = ½ C Tf with C = u1² + u2² is confirmed numerically",
                 decide(ok), f"C = 2E/Tf from the printed results: "
                 f"{ {k: round(v, 2) for k, v in implied.items()} }, but C ≤ u1max² + u2max² = {fmt(cmax)}")


def singular_arcs_energy() -> Claim:
    """Section 6: smooth unsaturated segments are 'singular arcs' predicted by the PMP."""
    from derivations.paper.claims_energy import energy

    hess = energy().hessian
    definite = all(v.is_negative for v in hess.eigenvals())
    return Claim("sec6.singular_arcs", SECTION6,
                 "6: the PMP predicts singular arcs (ψ' ≠ 0) in the energy problem, seen as smooth segments",
                 decide(not definite),
                 "H is strictly concave in u (Hessian -I), so u = Π(ũ(x, p)) is unique: no singular arcs; "
                 "smooth unsaturated segments are regular interior arcs, and since Π∘ũ is continuous in "
                 "(x, p), true bang-bang jumps cannot occur where p is continuous")


def claims() -> list[Claim]:
    return [*energy_bounds(), start_goal(), *reachability(), j_equals_ctf(), implied_c(),
            singular_arcs_energy()]
