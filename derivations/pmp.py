"""Pontryagin's maximum principle derived from an OCP definition, for any vehicle and cost.

Convention (project-wide): maximisation, H = p0 L + p . f + sum_j mu_j c_j with p0 = -1
(normal) or 0 (abnormal), each obstacle constraint c_j = dist_j - R_j >= 0 adjoined
directly with a multiplier density mu_j >= 0 and mu_j c_j = 0; p' = -dH/dx.

Path constraints other than the obstacles are adjoined the same way (``PathFamily``): on a road
each body's points (its cover-disc centres, or its corners) stay outside the island and inside the
route's corridor, c(X_i, Y_i) >= 0 with (X_i, Y_i) a point of the body's pose; a bounded output
(the articulation angle) lo <= g(x) <= hi. Their terms are kept apart from ``hamiltonian`` and
``adjoint`` (``path_terms``, ``path_adjoint``): the corridor functions are the transcription's
smooth geometry, not SymPy, so their gradients c_X, c_Y at the points are symbols here and the
certificate takes their values from the NLP (``model.direct.costates``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from derivations.symbolic import (
    circle_constraint,
    costate,
    derivative_symbol,
    multiplier,
    obstacle_symbols,
)
from model.vehicles import expression, sym

if TYPE_CHECKING:
    from model.problem.ocp import OCP


ROAD_KINDS = {
    "island": "the point stays outside the central island (the apron's inner edge where the body may use the apron)",
    "corridor": "the point stays inside the route's corridor: the ring roadway inside the outer curb, the "
    "entry and exit lanes and their fillet corners",
    "keep_out": "the rectangle misses the island, the route's fillet discs and its lane lines outside the "
    "outer curb (corners formulation only; a function of the four corners together)",
}


def road_family(body: str, kind: str) -> str:
    """The name of a road row family, ``<body>_<kind>`` (its trajectory column is ``mu_<name>``)."""
    if kind not in ROAD_KINDS:
        raise ValueError(f"road row kind must be one of {tuple(ROAD_KINDS)}, got {kind!r}")
    return f"{body}_{kind}"


@dataclass
class ControlLaw:
    """The maximum condition for one control, H being separable in the controls.

    ``kind`` is "bang-singular" (H affine in u: u = upper if psi > 0, lower if psi < 0,
    singular if psi = 0 on an interval) or "projection" (H strictly concave in u:
    u = clip(stationary point, lower, upper)). ``switching`` is psi = dH/du.
    """

    control: sp.Symbol
    lower: float
    upper: float
    kind: str
    switching: sp.Expr
    curvature: sp.Expr
    stationary: sp.Expr | None = None

    def choose(self, value: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """The maximiser given psi (bang-singular; NaN where |psi| <= tol) or the stationary point."""
        value = np.asarray(value, dtype=float)
        if self.kind == "projection":
            return np.clip(value, self.lower, self.upper)
        out = np.where(value > tol, self.upper, np.where(value < -tol, self.lower, np.nan))
        return out.astype(float)


@dataclass
class SingularArc:
    """Successive time derivatives of a switching function and the order of a singular arc.

    ``coefficients[k-1]`` is d/du (d^k psi / dt^k), evaluated with the substitutions the
    analysis was asked for; ``order`` is the first k where it is non-zero (None if none up to
    the maximum asked), ``q = order / 2`` and ``kelley`` = (-1)^q * coefficient, which the
    generalised Legendre-Clebsch condition requires to be <= 0 (maximisation).
    """

    control: sp.Symbol
    derivatives: list[sp.Expr]
    coefficients: list[sp.Expr]
    order: int | None
    kelley: sp.Expr | None

    @property
    def q(self) -> int | None:
        return None if self.order is None or self.order % 2 else self.order // 2

    def kelley_holds(self) -> bool | None:
        """True/False when the Kelley expression has a definite sign, else None."""
        if self.kelley is None:
            return None
        if self.kelley.is_nonpositive:
            return True
        if self.kelley.is_positive:
            return False
        return None


@dataclass
class PathFamily:
    """One family of adjoined path constraints: its multiplier, constraint, H term and adjoint term.

    ``name`` is the family (``vehicle_corridor``, ``trailer_island``, ``articulation``); the solve's
    trajectory column of its multiplier density is ``mu_<name>``. ``term`` is its part of H and
    ``adjoint`` its part of p' = -dH/dx, one entry per state. For a body's family the multiplier,
    the constraint value and its gradients ``c_<name>_X``, ``c_<name>_Y`` at the body's point i are
    indexed symbols summed over the points i = 1..n_<body>.
    """

    name: str
    multiplier: sp.Expr
    constraint: sp.Expr
    description: str
    term: sp.Expr
    adjoint: list[sp.Expr]
    point: tuple[sp.Expr, sp.Expr] | None = None


@dataclass
class PMPSystem:
    """Hamiltonian, adjoint equations, maximum condition and boundary conditions of one OCP."""

    name: str
    abnormal: bool
    p0: sp.Integer
    states: list[sp.Symbol]
    costates: list[sp.Symbol]
    controls: list[sp.Symbol]
    dynamics: list[sp.Expr]
    lagrangian: sp.Expr
    constraints: list[sp.Expr]
    multipliers: list[sp.Symbol]
    hamiltonian: sp.Expr
    adjoint: list[sp.Expr]
    laws: list[ControlLaw]
    hessian: sp.Matrix
    parameters: dict[sp.Symbol, float]
    free_final_states: list[sp.Symbol]
    free_final_time: bool
    notes: list[str] = field(default_factory=list)
    path: list[PathFamily] = field(default_factory=list)

    @property
    def path_terms(self) -> sp.Expr:
        """sum_j mu_j c_j of the path families (0 without any): H with them is hamiltonian + this."""
        return sum((f.term for f in self.path), sp.Integer(0))

    @property
    def path_adjoint(self) -> list[sp.Expr]:
        """-d(path_terms)/dx per state: p' = adjoint + path_adjoint."""
        return [sum((f.adjoint[i] for f in self.path), sp.Integer(0)) for i in range(len(self.states))]

    # -- look-ups -------------------------------------------------------------
    def law(self, control: str | sp.Symbol) -> ControlLaw:
        name = control if isinstance(control, str) else control.name
        return next(law for law in self.laws if law.control.name == name)

    def costate_of(self, state: str) -> sp.Symbol:
        return self.costates[[s.name for s in self.states].index(state)]

    def adjoint_of(self, state: str) -> sp.Expr:
        """p_state' = -dH/d(state)."""
        return self.adjoint[[s.name for s in self.states].index(state)]

    @property
    def time_functions(self) -> list[sp.Symbol]:
        """Quantities whose time derivatives appear as new symbols (controls and multipliers)."""
        return [*self.controls, *self.multipliers]

    @property
    def autonomous(self) -> bool:
        t = sp.Symbol("t", real=True)
        return t not in self.hamiltonian.free_symbols

    # -- calculus along extremals --------------------------------------------
    def time_derivative(self, expr: sp.Expr, order: int = 1) -> sp.Expr:
        """d^order/dt^order of expr(x, p, u, mu, ...) along extremals (x' = f, p' = -H_x)."""
        for _ in range(order):
            total = sum(
                (sp.diff(expr, s) * f for s, f in zip(self.states, self.dynamics, strict=True)),
                sp.Integer(0),
            )
            total += sum(
                (sp.diff(expr, p) * a for p, a in zip(self.costates, self.adjoint, strict=True)),
                sp.Integer(0),
            )
            for base in self.time_functions:
                for k in range(0, 8):
                    s = derivative_symbol(base, k)
                    if s in expr.free_symbols:
                        total += sp.diff(expr, s) * derivative_symbol(base, k + 1)
            expr = total
        return expr

    def poisson(self, f: sp.Expr, g: sp.Expr) -> sp.Expr:
        """{f, g} = f_x g_p - f_p g_x; d/dt F(x, p) = {F, H} along extremals."""
        pairs = zip(self.states, self.costates, strict=True)
        return sum((sp.diff(f, x) * sp.diff(g, p) - sp.diff(f, p) * sp.diff(g, x) for x, p in pairs),
                   sp.Integer(0))

    def switching_derivatives(self, control: str, order: int) -> list[sp.Expr]:
        """[psi, psi', ..., psi^(order)] for one control."""
        out = [self.law(control).switching]
        for _ in range(order):
            out.append(self.time_derivative(out[-1]))
        return out

    def singular_arc(self, control: str, max_order: int = 4,
                     on: dict[sp.Symbol, sp.Expr] | None = None) -> SingularArc:
        """Order of a singular arc of ``control`` and its Kelley expression.

        ``on`` substitutes the values that hold on the arc (e.g. a known extremal); without
        it the coefficients are generic and may vanish on the singular surface.
        """
        u = self.law(control).control
        subs = on or {}
        derivs = self.switching_derivatives(control, max_order)
        coeffs: list[sp.Expr] = []
        order = None
        for k in range(1, max_order + 1):
            coef = sp.simplify(sp.diff(derivs[k], u).subs(subs))
            coeffs.append(coef)
            if coef != 0:
                order = k
                break
        kelley = None
        if order is not None and order % 2 == 0:
            kelley = sp.simplify((-1) ** (order // 2) * coeffs[-1])
        return SingularArc(u, derivs, coeffs, order, kelley)

    def hamiltonian_rate(self) -> sp.Expr:
        """dH/dt along extremals; reduces to sum H_u u' + sum c_j mu_j' for an autonomous problem."""
        return sp.simplify(self.time_derivative(self.hamiltonian))

    def maximised_hamiltonian(self) -> sp.Expr:
        """H with every control at its unconstrained maximiser (interior arcs); affine controls stay."""
        subs = {law.control: law.stationary for law in self.laws if law.stationary is not None}
        return sp.simplify(self.hamiltonian.subs(subs))

    def transversality(self) -> list[sp.Eq]:
        """p_i(Tf) = 0 for every free final state, and H(Tf) = 0 if the final time is free."""
        tf = sp.Symbol("T_f", positive=True)
        out = [sp.Eq(sp.Function(p.name)(tf), 0) for p in self._free_costates()]
        if self.free_final_time:
            out.append(sp.Eq(sp.Function("H")(tf), 0))
        return out

    def _free_costates(self) -> list[sp.Symbol]:
        return [self.costate_of(s.name) for s in self.free_final_states]

    # -- renderings -------------------------------------------------------------
    def to_text(self) -> str:
        from derivations.render import pmp_text

        return pmp_text(self)

    def to_latex(self) -> str:
        from derivations.render import pmp_latex

        return pmp_latex(self)


def derive(ocp: OCP, abnormal: bool = False, symbolic_obstacles: bool = True) -> PMPSystem:
    """The PMP system of ``ocp`` (normal p0 = -1, or abnormal p0 = 0).

    Parameters (e.g. the wheelbase d) stay symbolic; their values are in ``parameters``.
    With ``symbolic_obstacles`` each obstacle is (x_obs, y_obs, R) symbols, valued likewise.
    """
    vehicle = ocp.vehicle
    states = vehicle.state_symbols()
    controls = vehicle.control_symbols()
    dynamics = vehicle.rhs(numeric=False)
    lagrangian = sp.nsimplify(expression(ocp.cost.lagrangian(vehicle)), rational=True)
    parameters = {vehicle.parameter_symbols()[k]: v for k, v in vehicle.parameters().items()}
    constraints, multipliers, obstacle_values = _obstacle_terms(ocp, symbolic_obstacles)
    parameters.update(obstacle_values)
    p0 = sp.Integer(0) if abnormal else sp.Integer(-1)
    costates = [costate(s.name) for s in states]
    ham = p0 * lagrangian + sum((p * f for p, f in zip(costates, dynamics, strict=True)), sp.Integer(0))
    ham += sum((m * c for m, c in zip(multipliers, constraints, strict=True)), sp.Integer(0))
    adjoint = [sp.simplify(-sp.diff(ham, s)) for s in states]
    hessian = sp.hessian(ham, controls)
    laws = [_control_law(ham, u, ocp.bounds[u.name], hessian, i) for i, u in enumerate(controls)]
    free = [s for s in states if s.name not in ocp.final]
    return PMPSystem(
        name=ocp.name, abnormal=abnormal, p0=p0, states=states, costates=costates, controls=controls,
        dynamics=dynamics, lagrangian=lagrangian, constraints=constraints, multipliers=multipliers,
        hamiltonian=ham, adjoint=adjoint, laws=laws, hessian=hessian, parameters=parameters,
        free_final_states=free, free_final_time=bool(ocp.cost.free_final_time),
        notes=_notes(ocp), path=[*_output_families(ocp, states), *_road_families(ocp, states)],
    )


def _output_families(ocp: OCP, states: list[sp.Symbol]) -> list[PathFamily]:
    """Each bounded output lo <= g(x) <= hi, adjoined with one signed multiplier density."""
    out = []
    for name, g in ocp.vehicle.outputs().items():
        if name not in ocp.bounds:
            continue
        lo, hi = ocp.bounds[name]
        mu, bound = sym(f"mu_{name}"), sym(f"b_{name}")
        text = (f"{lo:g} <= {name} = {sp.sstr(g)} <= {hi:g}; b_{name} is the active bound, mu_{name} >= 0 at "
                f"the lower bound and <= 0 at the upper (mu_{name} (g - b_{name}) = 0)")  # fmt: skip
        adjoint = [sp.simplify(-mu * sp.diff(g, s)) for s in states]
        out.append(PathFamily(name, mu, g - bound, text, mu * (g - bound), adjoint))
    return out


def _road_families(ocp: OCP, states: list[sp.Symbol]) -> list[PathFamily]:
    """Each body's island and corridor rows at its points (X_i, Y_i) = pose + (a_i, b_i) in the body frame."""
    if ocp.road is None or not ocp.bodies:
        return []
    poses = ocp.vehicle.body_poses()
    i = sp.Idx("i")
    out = []
    for body in ocp.bodies:
        x, y, heading = poses[body]
        a, b = sp.IndexedBase(f"a_{body}")[i], sp.IndexedBase(f"b_{body}")[i]
        point = (x + a * sp.cos(heading) - b * sp.sin(heading), y + a * sp.sin(heading) + b * sp.cos(heading))
        count = sp.Symbol(f"n_{body}", integer=True, positive=True)
        for kind in ("island", "corridor"):
            name = road_family(body, kind)
            mu, c = sp.IndexedBase(f"mu_{name}")[i], sp.IndexedBase(f"c_{name}")[i]
            grad = (sp.IndexedBase(f"c_{name}_X")[i], sp.IndexedBase(f"c_{name}_Y")[i])
            adjoint = []
            for s in states:
                chain = sum((g * sp.diff(q, s) for g, q in zip(grad, point, strict=True)), sp.Integer(0))
                chain = sp.simplify(chain)
                adjoint.append(sp.Integer(0) if chain == 0 else -sp.Sum(mu * chain, (i, 1, count)))
            text = f"c_{name}(X_i, Y_i) >= 0, {ROAD_KINDS[kind]}"
            out.append(PathFamily(name, mu, c, text, sp.Sum(mu * c, (i, 1, count)), adjoint, point))
    return out


def _obstacle_terms(ocp: OCP, symbolic: bool) -> tuple[list[sp.Expr], list[sp.Symbol], dict]:
    """Constraint expressions c_j >= 0, their multipliers and the obstacle parameter values."""
    px, py = (sp.Symbol(n, real=True) for n in ocp.vehicle.position)
    count = len(ocp.obstacles)
    constraints, multipliers, values = [], [], {}
    for j, ob in enumerate(ocp.obstacles):
        multipliers.append(multiplier(j, count))
        if symbolic:
            xo, yo, radius = obstacle_symbols(j, count)
            values.update({xo: ob.center[0], yo: ob.center[1], radius: ob.keep_out})
            constraints.append(circle_constraint(px, py, xo, yo, radius))
        else:
            constraints.append(ob.constraint(px, py))
    return constraints, multipliers, values


def _control_law(ham: sp.Expr, u: sp.Symbol, bounds: tuple[float, float], hessian: sp.Matrix,
                 index: int) -> ControlLaw:
    """Classify the maximisation of H in u: affine (bang/singular) or strictly concave (projection)."""
    coupling = [hessian[index, j] for j in range(hessian.shape[1]) if j != index]
    if any(sp.simplify(c) != 0 for c in coupling):
        raise NotImplementedError(f"H couples {u} with other controls; only separable H is handled")
    psi = sp.diff(ham, u)
    curvature = sp.simplify(hessian[index, index])
    lo, hi = bounds
    if curvature == 0:
        return ControlLaw(u, lo, hi, "bang-singular", sp.simplify(psi), curvature)
    if curvature.free_symbols or not curvature.is_negative:
        raise NotImplementedError(f"d2H/d{u}2 = {curvature}: only affine or strictly concave H handled")
    stationary = sp.solve(sp.Eq(psi, 0), u)
    if len(stationary) != 1:
        raise NotImplementedError(f"dH/d{u} = 0 has {len(stationary)} roots")
    return ControlLaw(u, lo, hi, "projection", psi, curvature, sp.simplify(stationary[0]))


def _notes(ocp: OCP) -> list[str]:
    """Caveats of the derivation that a reader must know."""
    notes = []
    path = set(ocp.vehicle.path_outputs())
    state_bounds = [k for k in ocp.bounds if k in ocp.vehicle.states]
    if state_bounds:
        notes.append(
            f"state bounds on {', '.join(sorted(state_bounds))} are not adjoined: the system "
            "holds on arcs where they are inactive"
        )
    for name in sorted(path & set(ocp.bounds)):
        notes.append(
            f"the bound on {name} (a function of state and control) is not adjoined: the system holds on "
            "arcs where it is inactive; where it is active the certificate does not apply"
        )
    if ocp.obstacles:
        notes.append("mu >= 0 and mu*c = 0 (complementarity); p may jump at junctions with c = 0")
    if ocp.road is not None and ocp.bodies:
        bodies = ", ".join(ocp.bodies)
        notes.append(
            f"on the road the bodies ({bodies}) are kept in the route's corridor by constraints that are "
            "adjoined to H: sum_j mu_j c_j over the families <body>_island and <body>_corridor at each "
            "body's points i (its cover-disc centres on its axis, b_i = 0; the corners formulation uses "
            "its four corners and adds a <body>_keep_out family), so p' = -dH/dx gains "
            "-sum_j mu_j dc_j/dx; c_j is the transcription's smooth corridor geometry "
            "(model/direct/bodies.py), whose gradient (c_X, c_Y) at a point the certificate evaluates "
            "on the NLP"
        )
    if ocp.moving_obstacles:
        notes.append(
            f"the {len(ocp.moving_obstacles)} moving obstacle(s) (model/scene/moving.py) are not in this "
            "system: their keep-out rows c_j(x, t) >= 0 depend on time, so the solve adjoins them from the NLP "
            "(families moving or <body>_moving) and H is not constant along an optimum"
        )
    return notes


def render_pmp(ocp: OCP, fmt: str = "text", abnormal: bool = False) -> str:
    """The PMP system of ``ocp`` as plain text (``fmt="text"``) or LaTeX (``fmt="latex"``)."""
    system = derive(ocp, abnormal=abnormal)
    if fmt == "text":
        return system.to_text()
    if fmt == "latex":
        return system.to_latex()
    raise ValueError(f"fmt must be 'text' or 'latex', got {fmt!r}")
