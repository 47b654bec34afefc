"""Bodies on a road in the NLP: every body's cover discs kept in the route's corridor.

Formulation ("union of pieces"): each rectangular body is covered by ``n`` equal discs along
its axis (``Body.cover``: they contain the rectangle exactly). For every disc, at every node:

- outside the island: ``|p - c| >= R_in + r``, ``R_in`` the inner edge of the ring
  roadway (Ri), or of the apron where the body may use it;
- inside the union of five pieces: the disc ``|p - c| <= Ro - r`` (the ring roadway inside the
  outer curb), the entry lane strip and the exit lane strip (between the leg's centre line and
  the lane's outer edge, up to the leg's end), and each of those lanes' fillet corners: the
  sector at the fillet centre F between its tangent points on the lane edge and on the outer curb,
  outside the circle of radius ``r_f + r`` around F (there the disc's clearance to the curb is
  its clearance to the fillet arc), on the lane's side of the centre line.

The union and the intersections are smooth: a piece's margin is the smooth minimum
``-log(sum exp(-k g(m_i))) / k`` of its half-plane margins, the union the smooth maximum
``log(sum exp(k g(m_j))) / k >= log(3) / k``. Both are conservative (the smooth minimum is
below the minimum, the smooth maximum minus ``log(3) / k`` below the maximum), so a feasible
point of the NLP keeps every disc in the corridor. ``g(m) = M m / sqrt(M^2 + m^2)`` saturates a
margin at +-M metres (same sign, same zero) so that the exponentials stay finite.
Where the centre line meets the outer curb (the corner between a leg's two lanes) the union is
conservative by up to a disc radius. The exact rectangles are checked against the exact
corridor by the validation.
"""

from __future__ import annotations

import functools
import math
import operator

import numpy as np
import pyomo.environ as pyo

from model.direct.expressions import sympy_to_pyomo
from model.problem.ocp import OCP
from model.scene.roundabout import apron_allowed, fillet_geometry, lane_side
from model.vehicles import sym

SHARPNESS = 20.0  # k, 1/m: the union gives away at most log(3) / k = 5.5 cm
SATURATION = 5.0  # M, m
COVER_SLACK = 0.1  # each body's cover discs reach at most 10 % of its half-width beyond its sides


def disc_count(length: float, width: float, slack: float = COVER_SLACK) -> int:
    """The fewest equal discs along the axis whose common radius is at most (1 + slack) width / 2."""
    half = width / 2
    reach = math.sqrt(((1 + slack) * half) ** 2 - half**2)  # half the axial span one disc covers
    return max(1, math.ceil(length / (2 * reach)))


def add_body_constraints(m: pyo.ConcreteModel, ocp: OCP, relax: bool = False) -> None:
    """Add, for each body and cover disc, the island and corridor constraints at every node.

    With ``relax`` each row gets a slack ``s >= 0`` (metres, on the disc's margin) and the model's
    objective becomes the sum of the slacks: the minimal-violation problem behind ``diagnosis``.
    """
    if ocp.road is None or not ocp.bodies:
        return
    v = ocp.vehicle
    params = {sym(k): val for k, val in v.parameters().items()}
    comps = [(sym(n), m.component(n)) for n in v.states]
    poses = v.body_poses()
    for name, body in ocp.bodies.items():
        offsets, radius = body.cover(disc_count(body.length, body.width))
        pose = poses[name]
        for j, offset in enumerate(offsets):

            def centre(t, pose=pose, offset=float(offset)):
                env = {s: c[t] for s, c in comps} | params
                x, y, h = (sympy_to_pyomo(e, env) for e in pose)
                return x + offset * pyo.cos(h), y + offset * pyo.sin(h)

            _add_disc(m, ocp, f"body_{name}_{j}", centre, float(radius), apron_allowed(ocp.road.roundabout, name),
                      relax)  # fmt: skip


def _add_disc(m: pyo.ConcreteModel, ocp: OCP, tag: str, position, r: float, apron: bool, relax: bool) -> None:
    rb, road = ocp.road.roundabout, ocp.road
    cx, cy = rb.center
    inner = rb.island_radius if apron else rb.inner_radius
    centre = _centre_variables(m, tag, position, rb)
    slack = _slacks(m, tag, relax)

    def island(_m, t):
        x, y = centre(t)
        return pyo.sqrt((x - cx) ** 2 + (y - cy) ** 2) + slack["island"](t) >= inner + r

    def corridor(_m, t):
        x, y = centre(t)
        pieces = [rb.outer_radius - r - pyo.sqrt((x - cx) ** 2 + (y - cy) ** 2)]
        for leg, lane in ((road.route.enter, "entry"), (road.exit_leg, "exit")):
            pieces += [_lane_margin(rb, leg, lane, x, y, r), _fillet_margin(rb, leg, lane, x, y, r)]
        return _smooth_max(pieces) + slack["corridor"](t) >= math.log(len(pieces)) / SHARPNESS

    m.add_component(f"{tag}_island", pyo.Constraint(m.tau, rule=island))
    m.add_component(f"{tag}_corridor", pyo.Constraint(m.tau, rule=corridor))


def _slacks(m: pyo.ConcreteModel, tag: str, relax: bool) -> dict:
    """Per-row slack variables (relaxed model) or zero."""
    if not relax:
        return {"island": lambda t: 0, "corridor": lambda t: 0}
    out = {}
    for kind in ("island", "corridor"):
        var = pyo.Var(m.tau, bounds=(0.0, None), initialize=0.0)
        m.add_component(f"{tag}_{kind}_slack", var)
        m.slacks = [*getattr(m, "slacks", []), var]
        out[kind] = lambda t, var=var: var[t]
    return out


def _centre_variables(m: pyo.ConcreteModel, tag: str, position, rb):
    """The disc centre as two NLP variables tied to the state (x_c = x + o cos h, ...).

    Bounded (by the roundabout's extent), so the NLP presolve keeps them: the corridor rows
    then depend on two variables each, and their derivatives stay small.
    """
    reach = rb.outer_radius + max(g.length for g in rb.legs) + 100.0
    for k, name in enumerate(("x", "y")):
        lo, hi = rb.center[k] - reach, rb.center[k] + reach
        var = pyo.Var(m.tau, bounds=(lo, hi), initialize=rb.center[k])
        m.add_component(f"{tag}_{name}", var)
        rule = lambda _m, t, k=k, var=var: var[t] == position(t)[k]  # noqa: E731
        m.add_component(f"{tag}_{name}_def", pyo.Constraint(m.tau, rule=rule))
        derived = getattr(m, "derived_values", [])
        derived.append((var, lambda t, k=k: position(t)[k]))
        m.derived_values = derived
    x, y = m.component(f"{tag}_x"), m.component(f"{tag}_y")
    return lambda t: (x[t], y[t])


def _lane_margin(rb, leg: int, lane: str, x, y, r: float):
    """Smooth minimum of a disc's margins in the lane's strip: centre line, outer edge, and from the centre to its end.

    Without ``along >= r`` the strip would continue through the centre and past the opposite curb.
    """
    g = rb.legs[leg]
    along, across = _lane_frame(rb, leg, lane, x, y)
    margins = [across - r, g.lane_width - across - r, along - r, rb.outer_radius + g.length - along - r]
    return -_smooth_max([-mi for mi in margins])


def _fillet_margin(rb, leg: int, lane: str, x, y, r: float):
    """Smooth minimum of a disc's margins in a lane's fillet corner (see the module docstring)."""
    f = fillet_geometry(rb, leg, lane)
    fx, fy = f["center"]
    corner = np.asarray(f["corner"]) - f["center"]
    margins = [pyo.sqrt((x - fx) ** 2 + (y - fy) ** 2) - f["radius"] - r]
    for tangent in (f["edge_point"], f["curb_point"]):  # the sector's two sides, rays from F
        d = np.asarray(tangent) - f["center"]
        d = d / np.hypot(*d)
        sign = 1.0 if d[0] * corner[1] - d[1] * corner[0] > 0 else -1.0  # the corner's side of the ray
        margins.append(sign * (d[0] * (y - fy) - d[1] * (x - fx)))
    margins.append(_lane_frame(rb, leg, lane, x, y)[1] - r)
    return -_smooth_max([-mi for mi in margins])


def _lane_frame(rb, leg: int, lane: str, x, y):
    """(along, across): the point's distance along the leg's axis and across it into the lane (0 on the centre line)."""
    g = rb.legs[leg]
    dx, dy = x - rb.center[0], y - rb.center[1]
    return g.axis[0] * dx + g.axis[1] * dy, lane_side(rb, lane) * (g.normal[0] * dx + g.normal[1] * dy)


def _saturate(margin):
    return SATURATION * margin / pyo.sqrt(SATURATION**2 + margin**2)


def _smooth_max(margins: list):
    terms = [pyo.exp(SHARPNESS * _saturate(mi)) for mi in margins]
    return pyo.log(functools.reduce(operator.add, terms)) / SHARPNESS  # not sum(): see expressions.py
