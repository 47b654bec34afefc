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

Other formulations (``FORMULATIONS``, chosen by ``add_body_constraints(..., formulation=...)``,
passed down from ``build_model`` and ``solve_ocp(..., formulation=...)``;
docs/bodies-formulation.md compares them): "discs-tight", the same with more
discs (``TIGHT_COVER_SLACK``) and a sharper union (``TIGHT_SHARPNESS``), and "corners"
(``_add_corner_bodies``): the rectangle's corners in the union, the rectangle clear of the island,
the fillet discs and the route lanes' edge and centre lines outside the outer curb.
"""

from __future__ import annotations

import functools
import math
import operator
from dataclasses import dataclass

import numpy as np
import pyomo.environ as pyo

from derivations.pmp import road_family
from model.direct.expressions import sympy_to_pyomo
from model.direct.families import transcription_of
from model.problem.ocp import OCP
from model.scene.roundabout import apron_allowed, fillet_geometry, lane_side, leg_point
from model.vehicles import sym

SHARPNESS = 20.0  # k, 1/m: the union of five pieces gives away at most log(5) / k = 8.0 cm
SATURATION = 5.0  # M, m
COVER_SLACK = 0.1  # each body's cover discs reach at most 10 % of its half-width beyond its sides
TIGHT_SHARPNESS = 50.0  # k of "discs-tight": log(5) / k = 3.2 cm (k M = 250: exp and its square stay finite)
TIGHT_COVER_SLACK = 0.03  # "discs-tight": discs reach at most 3 % of the half-width beyond the sides
CORNER_SHARPNESS = 50.0  # k of "corners": a corner's union gives away log(5) / k = 3.2 cm, a keep-out log(4 or 6) / k
CORNER_BUFFER = 1e-3  # m: every "corners" row asks this much more, above Ipopt's constraint violation
FORMULATIONS = ("discs", "discs-tight", "corners")
DEFAULT_FORMULATION = "discs"  # what a caller that names none gets (docs/bodies-formulation.md)


def disc_count(length: float, width: float, slack: float = COVER_SLACK) -> int:
    """The fewest equal discs along the axis whose common radius is at most (1 + slack) width / 2."""
    half = width / 2
    reach = math.sqrt(((1 + slack) * half) ** 2 - half**2)  # half the axial span one disc covers
    return max(1, math.ceil(length / (2 * reach)))


def check_formulation(name: str) -> str:
    """``name`` if it is one of ``FORMULATIONS``; else ValueError naming them."""
    if name not in FORMULATIONS:
        raise ValueError(f"body formulation must be one of {FORMULATIONS}, got {name!r}")
    return name


def add_body_constraints(
    m: pyo.ConcreteModel, ocp: OCP, relax: bool = False, formulation: str = DEFAULT_FORMULATION
) -> None:
    """Add, for each body, the island and corridor constraints at every node.

    With ``relax`` each row gets a slack ``s >= 0`` (metres, on the disc's margin) and the model's
    objective becomes the sum of the slacks: the minimal-violation problem behind ``diagnosis``.
    ``formulation``: one of ``FORMULATIONS`` ("discs", the formulation of the module docstring).
    """
    if ocp.road is None or not ocp.bodies:
        return
    kind = check_formulation(formulation)
    m.body_formulation = kind  # a re-solve of the answer (on 2N for accuracy) uses the same
    if kind == "corners":
        _add_corner_bodies(m, ocp, relax)
    elif kind == "discs-tight":
        _add_disc_bodies(m, ocp, relax, TIGHT_COVER_SLACK, TIGHT_SHARPNESS)
    else:
        _add_disc_bodies(m, ocp, relax, COVER_SLACK, SHARPNESS)


def _pose_point(m: pyo.ConcreteModel, ocp: OCP, pose, ahead: float, left: float, value=None):
    """``t -> (x, y)``: the point ``ahead`` along and ``left`` across a body's axis, as Pyomo expressions
    (``value``: ``(state name, t) -> expression``, the states the pose is taken at; default their node values)."""
    v = ocp.vehicle
    params = {sym(k): val for k, val in v.parameters().items()}
    comps = [(sym(n), m.component(n)) for n in v.states]

    def point(t):
        states = {s: c[t] for s, c in comps} if value is None else {sym(n): value(n, t) for n in v.states}
        env = states | params
        x, y, h = (sympy_to_pyomo(e, env) for e in pose)
        if left == 0.0:  # the disc centres: the same expressions as before "left" existed
            return x + ahead * pyo.cos(h), y + ahead * pyo.sin(h)
        c, s = pyo.cos(h), pyo.sin(h)
        return x + ahead * c - left * s, y + ahead * s + left * c

    return point


def _add_disc_bodies(m: pyo.ConcreteModel, ocp: OCP, relax: bool, slack: float, k: float) -> None:
    """Each body's cover discs (``disc_count`` with ``slack``) kept in the corridor with sharpness ``k``."""
    poses = ocp.vehicle.body_poses()
    for name, body in ocp.bodies.items():
        offsets, radius = body.cover(disc_count(body.length, body.width, slack))
        apron = apron_allowed(ocp.road.roundabout, name)
        for j, offset in enumerate(offsets):
            centre = _pose_point(m, ocp, poses[name], float(offset), 0.0)
            _add_disc(m, ocp, f"body_{name}_{j}", centre, float(radius), apron, relax, k)
            _register_disc(m, name, f"body_{name}_{j}", relax)


def _add_disc(
    m: pyo.ConcreteModel, ocp: OCP, tag: str, position, r: float, apron: bool, relax: bool, k: float = SHARPNESS
):
    """A disc (a point if ``r`` = 0) outside the island and in the union of pieces; returns its centre."""
    rb, road = ocp.road.roundabout, ocp.road
    cx, cy = rb.center
    inner = rb.island_radius if apron else rb.inner_radius
    centre = _centre_variables(m, tag, position, rb)
    slack = _slacks(m, tag, relax)

    def island(_m, t):
        x, y = centre(t)
        return pyo.sqrt((x - cx) ** 2 + (y - cy) ** 2) + slack["island"](t) >= inner + r

    lanes = [lane_numbers(rb, leg, lane) for leg, lane in ((road.route.enter, "entry"), (road.exit_leg, "exit"))]

    def corridor(_m, t):
        x, y = centre(t)
        pieces = [rb.outer_radius - r - pyo.sqrt((x - cx) ** 2 + (y - cy) ** 2)]
        for numbers in lanes:
            pieces += [_lane_margin(numbers, x, y, r, k), _fillet_margin(numbers, x, y, r, k)]
        return _smooth_max(pieces, k) + slack["corridor"](t) >= math.log(len(pieces)) / k

    m.add_component(f"{tag}_island", pyo.Constraint(m.tau, rule=island))
    m.add_component(f"{tag}_corridor", pyo.Constraint(m.tau, rule=corridor))
    return centre


def _add_corner_bodies(m: pyo.ConcreteModel, ocp: OCP, relax: bool) -> None:
    """Formulation "corners": each body's four corners in the corridor, the rectangle clear of its holes.

    The corners are points (discs of radius ``CORNER_BUFFER``) outside the island and in the smooth
    union of the pieces (sharpness ``CORNER_SHARPNESS``). The rectangle misses the island's disc, the
    route's two fillet discs (``_keep_out_discs``) and the route lanes' lines outside the outer curb
    (``_keep_out_lines``); these rows too ask ``CORNER_BUFFER`` more: docs/bodies-formulation.md.
    """
    rb = ocp.road.roundabout
    poses = ocp.vehicle.body_poses()
    for name, body in ocp.bodies.items():
        apron = apron_allowed(rb, name)
        corners = []
        for j, (ox, oy) in enumerate(body.outline()):
            point = _pose_point(m, ocp, poses[name], float(ox), float(oy))
            tag = f"body_{name}_c{j}"  # a disc of radius CORNER_BUFFER: the corner with its buffer
            corners.append(_add_disc(m, ocp, tag, point, CORNER_BUFFER, apron, relax, CORNER_SHARPNESS))
            _register_disc(m, name, tag, relax)
        for tag, centre, radius in _keep_out_discs(ocp, apron):
            for box in (0, 1):
                _add_keep_out(m, f"body_{name}_{tag}_{box}", corners, body, centre, radius, box, relax)
                _register(m, name, "keep_out", m.component(f"body_{name}_{tag}_{box}_keep_out"), relax)
        for tag, ends, normal in _keep_out_lines(ocp):
            _add_line_keep_out(m, f"body_{name}_{tag}", corners, body, ends, normal, relax)
            _register(m, name, "keep_out", m.component(f"body_{name}_{tag}_keep_out"), relax)


def _register_disc(m: pyo.ConcreteModel, body: str, tag: str, soft: bool) -> None:
    for kind in ("island", "corridor"):
        _register(m, body, kind, m.component(f"{tag}_{kind}"), soft)


def _register(m: pyo.ConcreteModel, body: str, kind: str, component: pyo.Constraint, soft: bool) -> None:
    """Declare a row family member (``model.direct.families``): ``body_rows(m)`` lists it for the costates
    and the certificate; its slacks (``soft``) are declared where they are made."""
    transcription_of(m).declare(road_family(body, kind), kind, component, "slack" if soft else "hard")


def body_rows(m: pyo.ConcreteModel) -> list[tuple[str, pyo.Constraint]]:
    """(family, constraint) of every body row of the model, the family ``<body>_<kind>``
    (``derivations.pmp.ROAD_KINDS``: island, corridor, keep_out); empty off the road."""
    return transcription_of(m).rows_of_kind("island", "corridor", "keep_out")


def point_definitions(m: pyo.ConcreteModel) -> list[tuple[pyo.Var, pyo.Constraint]]:
    """(variable, defining row) of every auxiliary point coordinate (a disc centre's or a corner's
    x or y, ``var[t] == position(x[t])``): the body rows depend on the state through them."""
    return list(transcription_of(m).definitions)


def _keep_out_discs(ocp: OCP, apron: bool) -> list[tuple[str, tuple[float, float], float]]:
    """(tag, centre, radius) of the discs a rectangle must miss: the island (or apron edge) and the route's fillets."""
    rb, road = ocp.road.roundabout, ocp.road
    inner = rb.island_radius if apron else rb.inner_radius
    out = [("island", rb.center, inner)]
    for leg, lane in ((road.route.enter, "entry"), (road.exit_leg, "exit")):
        f = fillet_geometry(rb, leg, lane)
        out.append((f"fillet_{lane}", (float(f["center"][0]), float(f["center"][1])), float(f["radius"])))
    return out


def _keep_out_lines(ocp: OCP) -> list[tuple[str, tuple, tuple[float, float]]]:
    """(tag, (start, end), leg normal): the lane lines a rectangle must not cross outside the curb.

    Each route lane's outer edge from its fillet's tangent point to the leg's end and, where the
    route uses one lane of a leg (not for a U-turn), the leg's centre line from the outer curb
    (``V``, a reflex corner of the corridor) to the leg's end: edges with the corridor on one side.
    """
    rb, road = ocp.road.roundabout, ocp.road
    out = []
    for leg, lane in ((road.route.enter, "entry"), (road.exit_leg, "exit")):
        end = rb.outer_radius + rb.legs[leg].length
        lines = {"edge": (fillet_geometry(rb, leg, lane)["axial"], lane_side(rb, lane) * rb.legs[leg].lane_width)}
        if road.route.enter != road.exit_leg:
            lines["centre_line"] = (rb.outer_radius, 0.0)
        normal = (float(rb.legs[leg].normal[0]), float(rb.legs[leg].normal[1]))
        for name, (start, across) in lines.items():
            ends = tuple(tuple(float(c) for c in leg_point(rb, leg, along, across)) for along in (start, end))
            out.append((f"{name}_{lane}", ends, normal))
    return out


def _add_keep_out(m: pyo.ConcreteModel, tag: str, corners: list, body, point, radius: float, box: int, relax: bool):
    """The point outside one arm of the rectangle grown by ``radius`` (box 0: across, 1: along).

    With the corners outside the circle, the rectangle misses the disc (``point``, ``radius``) exactly
    when the point lies outside both arms of the cross ``rectangle + disc`` without its rounded
    corners. The condition is a smooth maximum of the four margins of the arm, ``>= log(4) / k``.
    """
    half_l, half_w = body.length / 2, body.width / 2
    reach = (half_l, half_w + radius) if box == 0 else (half_l + radius, half_w)
    slack = _slack(m, tag, relax)
    k = CORNER_SHARPNESS

    def rule(_m, t):
        along, across = _body_frame([c(t) for c in corners], body, point)
        margins = [along - reach[0], -along - reach[0], across - reach[1], -across - reach[1]]
        return _smooth_max(margins, k) + slack(t) >= math.log(len(margins)) / k + CORNER_BUFFER

    m.add_component(f"{tag}_keep_out", pyo.Constraint(m.tau, rule=rule))


def _add_line_keep_out(m: pyo.ConcreteModel, tag: str, corners: list, body, ends, normal, relax: bool) -> None:
    """The rectangle misses the segment ``ends``: a separating axis among the body's two and the segment's normal.

    Six margins (the segment beyond each of the rectangle's four sides, the four corners on either
    side of the segment's line), each a smooth minimum over its points; their smooth maximum
    ``>= log(6) / k``. Exact, up to the smoothing, for a rectangle and a segment (both convex).
    """
    half_l, half_w = body.length / 2, body.width / 2
    slack = _slack(m, tag, relax)
    k = CORNER_SHARPNESS

    def rule(_m, t):
        p = [c(t) for c in corners]
        (xv, yv), (xe, ye) = (_body_frame(p, body, end) for end in ends)
        sides = [(xv - half_l, xe - half_l), (-xv - half_l, -xe - half_l),
                 (yv - half_w, ye - half_w), (-yv - half_w, -ye - half_w)]  # fmt: skip
        across = [(q[0] - ends[0][0]) * normal[0] + (q[1] - ends[0][1]) * normal[1] for q in p]
        margins = [_smooth_min(list(pair), k) for pair in sides]
        margins += [_smooth_min(across, k), _smooth_min([-a for a in across], k)]
        return _smooth_max(margins, k) + slack(t) >= math.log(len(margins)) / k + CORNER_BUFFER

    m.add_component(f"{tag}_keep_out", pyo.Constraint(m.tau, rule=rule))


def _smooth_min(margins: list, k: float):
    """``-log(sum exp(-k g(m))) / k``, below the least saturated margin."""
    return -_smooth_max([-mi for mi in margins], k)


def _body_frame(p: list, body, point) -> tuple:
    """``point`` in the frame of the rectangle with corners ``p`` (rear right, front right, front left, rear left).

    Origin at the rectangle's centre, first axis along the body, second to its left.
    """
    mx, my = (p[0][0] + p[2][0]) / 2, (p[0][1] + p[2][1]) / 2
    ux, uy = (p[1][0] - p[0][0]) / body.length, (p[1][1] - p[0][1]) / body.length
    nx, ny = (p[3][0] - p[0][0]) / body.width, (p[3][1] - p[0][1]) / body.width
    dx, dy = point[0] - mx, point[1] - my
    return dx * ux + dy * uy, dx * nx + dy * ny


def _slack(m: pyo.ConcreteModel, tag: str, relax: bool):
    """One row's slack ``t -> s(t) >= 0`` (relaxed model) or zero."""
    if not relax:
        return lambda t: 0
    var = pyo.Var(m.tau, bounds=(0.0, None), initialize=0.0)
    m.add_component(f"{tag}_slack", var)
    transcription_of(m).add_slack(var)
    return lambda t: var[t]


def _slacks(m: pyo.ConcreteModel, tag: str, relax: bool) -> dict:
    """Per-row slack variables (relaxed model) or zero."""
    if not relax:
        return {"island": lambda t: 0, "corridor": lambda t: 0}
    out = {}
    for kind in ("island", "corridor"):
        var = pyo.Var(m.tau, bounds=(0.0, None), initialize=0.0)
        m.add_component(f"{tag}_{kind}_slack", var)
        transcription_of(m).add_slack(var)
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
        transcription_of(m).definitions.append((var, m.component(f"{tag}_{name}_def")))
        derived = getattr(m, "derived_values", [])
        derived.append((var, lambda t, k=k: position(t)[k]))
        m.derived_values = derived
    x, y = m.component(f"{tag}_x"), m.component(f"{tag}_y")
    return lambda t: (x[t], y[t])


@dataclass(frozen=True)
class LaneNumbers:
    """A route lane's geometry as Python floats, computed once per disc family rather than per node (a
    numpy scalar times a Pyomo expression goes through numpy's ufunc machinery, several times slower).

    ``axis``, ``normal``: the leg's unit vectors; ``side``: ``lane_side``; ``end``: the leg's end along its
    axis; ``fillet``: the fillet circle's centre and radius; ``rays``: (sign, dx, dy) of the fillet sector's
    two sides (unit directions from its centre, signed towards the corner).
    """

    center: tuple[float, float]
    axis: tuple[float, float]
    normal: tuple[float, float]
    side: float
    width: float
    end: float
    fillet: tuple[float, float, float]
    rays: tuple[tuple[float, float, float], ...]


def lane_numbers(rb, leg: int, lane: str) -> LaneNumbers:
    """``LaneNumbers`` of a leg's lane."""
    g, f = rb.legs[leg], fillet_geometry(rb, leg, lane)
    corner = np.asarray(f["corner"]) - f["center"]
    rays = []
    for tangent in (f["edge_point"], f["curb_point"]):  # the sector's two sides, rays from F
        d = np.asarray(tangent) - f["center"]
        d = d / np.hypot(*d)
        sign = 1.0 if d[0] * corner[1] - d[1] * corner[0] > 0 else -1.0  # the corner's side of the ray
        rays.append((sign, float(d[0]), float(d[1])))
    return LaneNumbers(
        center=(float(rb.center[0]), float(rb.center[1])),
        axis=(float(g.axis[0]), float(g.axis[1])),
        normal=(float(g.normal[0]), float(g.normal[1])),
        side=float(lane_side(rb, lane)),
        width=float(g.lane_width),
        end=float(rb.outer_radius + g.length),
        fillet=(float(f["center"][0]), float(f["center"][1]), float(f["radius"])),
        rays=tuple(rays),
    )


def _lane_margin(lane: LaneNumbers, x, y, r: float, k: float = SHARPNESS):
    """Smooth minimum of a disc's margins in the lane's strip: centre line, outer edge, and from the centre to its end.

    Without ``along >= r`` the strip would continue through the centre and past the opposite curb.
    """
    along, across = _lane_frame(lane, x, y)
    margins = [across - r, lane.width - across - r, along - r, lane.end - along - r]
    return -_smooth_max([-mi for mi in margins], k)


def _fillet_margin(lane: LaneNumbers, x, y, r: float, k: float = SHARPNESS):
    """Smooth minimum of a disc's margins in a lane's fillet corner (see the module docstring)."""
    fx, fy, radius = lane.fillet
    margins = [pyo.sqrt((x - fx) ** 2 + (y - fy) ** 2) - radius - r]
    margins += [sign * (dx * (y - fy) - dy * (x - fx)) for sign, dx, dy in lane.rays]
    margins.append(_lane_frame(lane, x, y)[1] - r)
    return -_smooth_max([-mi for mi in margins], k)


def _lane_frame(lane: LaneNumbers, x, y):
    """(along, across): the point's distance along the leg's axis and across it into the lane (0 on the centre line)."""
    dx, dy = x - lane.center[0], y - lane.center[1]
    return lane.axis[0] * dx + lane.axis[1] * dy, lane.side * (lane.normal[0] * dx + lane.normal[1] * dy)


def _saturate(margin):
    return SATURATION * margin / pyo.sqrt(SATURATION**2 + margin**2)


def _smooth_max(margins: list, k: float = SHARPNESS):
    """``log(sum exp(k g(m))) / k``: above the largest saturated margin, by at most ``log(len(margins)) / k``."""
    terms = [pyo.exp(k * _saturate(mi)) for mi in margins]
    return pyo.log(functools.reduce(operator.add, terms)) / k  # not sum(): see expressions.py
