"""Roundabout geometry (shared/roundabout-format.md) checked against numbers worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from model.errors import InputError
from model.scene.geometry import Arc, Segment, clearance, clearance_detail
from model.scene.roundabout import (
    Leg,
    Roundabout,
    Route,
    apron_allowed,
    check_lane_width,
    corridor,
    edges,
    exit_leg,
    exit_taken,
    fillet_geometry,
    goal_pose,
    heading_change,
    island_region,
    rectangle,
    ring_region,
    start_pose,
    sweep,
)

PI = math.pi
FOUR = (180.0, 270.0, 0.0, 90.0)  # the contract's first leg points west
THREE = (0.0, 100.0, 230.0)
FIVE = (154.0, 10.0, 298.0, 82.0, 226.0)  # 72 deg apart, listed out of order


def make(
    angles=FOUR,
    traffic="right",
    center=(0.0, 0.0),
    icd=40.0,
    ring=6.0,
    apron=1.5,
    w=4.0,
    r_in=15.0,
    r_out=20.0,
    length=60.0,
    **kw,
) -> Roundabout:
    legs = [Leg(a, w, r_in, r_out, length) for a in angles]
    return Roundabout(center, icd, ring, apron, traffic=traffic, legs=legs, **kw)


def unit(deg: float) -> np.ndarray:
    return np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])


def right_of(heading: np.ndarray) -> np.ndarray:
    """The unit vector to the right of a driver heading along ``heading``."""
    return np.array([heading[1], -heading[0]])


def lane_offset(traffic: str, lane: str, axis: np.ndarray) -> np.ndarray:
    """Unit vector from the leg axis towards the lane, straight from the contract's wording."""
    driving = -axis if lane == "entry" else axis  # coming in / going out
    side = right_of(driving)
    return side if traffic == "right" else -side


# --------------------------------------------------------------------------- fillets


@pytest.mark.parametrize("traffic", ["right", "left"])
@pytest.mark.parametrize("lane", ["entry", "exit"])
@pytest.mark.parametrize("leg", range(4))
def test_fillet_circle_touches_the_lane_edge_and_the_outer_curb(traffic, lane, leg):
    rb = make(traffic=traffic, center=(3.0, -7.0), w=3.5, r_in=12.0, r_out=25.0)
    f = fillet_geometry(rb, leg, lane)
    c, ro, r, w = np.array(rb.center), 20.0, (12.0 if lane == "entry" else 25.0), 3.5
    axis = unit(FOUR[leg])
    side = lane_offset(traffic, lane, axis)
    rel = f["center"] - c
    edge_offset = float(rel @ side)  # signed distance of the centre from the axis, towards the lane's outer edge
    assert abs(edge_offset - w) == pytest.approx(r, abs=1e-9)  # tangent to the edge line
    assert edge_offset > w  # from outside the lane
    assert math.hypot(*rel) == pytest.approx(ro + r, abs=1e-9)  # tangent to the outer curb from outside
    assert float(rel @ axis) > 0.0  # on the leg's side of the centre
    assert f["radius"] == r


def test_fillet_arc_is_an_edge_of_the_corridor_between_its_two_tangent_points():
    rb = make()
    route = Route(0, 1)
    (fillet,) = [e for e in edges(rb, route) if e.name == "leg 0 entry fillet"]
    assert fillet.kind == "circle_outside"
    (arc,) = fillet.pieces
    assert isinstance(arc, Arc) and not arc.inside
    # leg 0 points west; right-hand entry lane is its south half (y in [-4, 0]); centre at x = -sqrt(35^2 - 19^2)
    ax = -math.sqrt(35.0**2 - 19.0**2)
    assert fillet.center == pytest.approx((ax, -19.0), abs=1e-12)
    ends = {tuple(np.round(arc.point(a), 9)) for a in (arc.start, arc.end)}
    assert (round(ax, 9), -4.0) in ends  # on the edge line y = -4
    curb_end = [p for p in ends if p != (round(ax, 9), -4.0)][0]
    assert math.hypot(*curb_end) == pytest.approx(20.0, abs=1e-9)  # on the outer curb
    (edge,) = [e for e in edges(rb, route) if e.name == "leg 0 entry lane outer edge"]
    assert edge.kind == "halfplane" and edge.normal == pytest.approx((0.0, 1.0)) and edge.offset == pytest.approx(-4.0)
    (seg,) = edge.pieces
    assert {tuple(np.round(seg.start, 9)), tuple(np.round(seg.end, 9))} == {(round(ax, 9), -4.0), (-80.0, -4.0)}


def test_outer_curb_and_apron_arcs():
    rb = make()
    found = {e.name: e for e in edges(rb, Route(0, 1))}
    (apron,) = found["apron"].pieces
    assert (apron.radius, apron.inside, apron.end - apron.start) == (14.0, False, pytest.approx(2 * PI))
    curb = sorted(found["outer curb"].pieces, key=lambda a: a.end - a.start)
    assert len(curb) == 2 and all(a.inside for a in curb)
    # closed from leg 1's centre line (270 deg) counter-clockwise past 0 deg to leg 0's centre line (180 deg)
    assert (curb[1].start, curb[1].end) == (pytest.approx(1.5 * PI), pytest.approx(3 * PI))
    # and between the two fillets' tangent points
    t_entry = math.atan2(-19.0, -math.sqrt(35.0**2 - 19.0**2)) % (2 * PI)  # leg 0 entry fillet centre direction
    t_exit = math.atan2(-math.sqrt(40.0**2 - 24.0**2), -24.0) % (2 * PI)  # leg 1 exit fillet centre direction
    assert (curb[0].start, curb[0].end) == (pytest.approx(t_entry), pytest.approx(t_exit))


# --------------------------------------------------------------------------- exits, sweeps, poses


@pytest.mark.parametrize(
    "angles, traffic, enter, legs_in_order",
    [
        (FOUR, "right", 0, [1, 2, 3, 0]),  # from the west, counter-clockwise: south, east, north, back west
        (FOUR, "left", 0, [3, 2, 1, 0]),  # clockwise: north, east, south, back west
        (FOUR, "right", 2, [3, 0, 1, 2]),
        (THREE, "right", 1, [2, 0, 1]),
        (THREE, "left", 1, [0, 2, 1]),
        (FIVE, "right", 0, [4, 2, 1, 3, 0]),
        (FIVE, "left", 0, [3, 1, 2, 4, 0]),
    ],
)
def test_exit_counting(angles, traffic, enter, legs_in_order):
    rb = make(angles, traffic, w=3.0, r_in=10.0, r_out=10.0)
    assert [exit_leg(rb, Route(enter, n)) for n in range(1, len(angles) + 1)] == legs_in_order


@pytest.mark.parametrize(
    "traffic, changes",
    [("right", [-PI / 2, 0.0, PI / 2, PI]), ("left", [PI / 2, 0.0, -PI / 2, -PI])],
)
def test_heading_change_on_four_legs_is_the_contract_s_right_turn_straight_on_and_u_turn(traffic, changes):
    """Contract: a right turn at the first exit of a four-leg roundabout is -pi/2, straight on 0, a U-turn +pi."""
    rb = make(traffic=traffic)
    got = [heading_change(rb, Route(0, n)) for n in range(1, 5)]
    assert got == pytest.approx(changes, abs=1e-12)
    sweeps = [sweep(rb, Route(0, n)) for n in range(1, 5)]
    sign = 1 if traffic == "right" else -1
    assert sweeps == pytest.approx([sign * PI / 2, sign * PI, sign * 3 * PI / 2, sign * 2 * PI], abs=1e-12)


@pytest.mark.parametrize("angles", [THREE, FOUR, FIVE])
@pytest.mark.parametrize("traffic", ["right", "left"])
def test_goal_heading_points_out_of_the_exit_leg_after_turning_the_circulation_way(angles, traffic):
    rb = make(angles, traffic, w=3.0, r_in=10.0, r_out=10.0)
    for enter in range(len(angles)):
        theta0 = start_pose(rb, Route(enter, 1))[2]
        for n in range(1, len(angles) + 1):
            route = Route(enter, n)
            theta = goal_pose(rb, route)[2]
            out = math.radians(angles[exit_leg(rb, route)])
            assert math.remainder(theta - out, 2 * PI) == pytest.approx(0.0, abs=1e-12)
            turn = theta - theta0  # right-hand traffic turns right into the ring: net change in (-pi, pi]
            assert (-PI < turn <= PI + 1e-12) if traffic == "right" else (-PI - 1e-12 <= turn < PI)
            if n == len(angles):
                assert turn == pytest.approx(PI if traffic == "right" else -PI)


def test_start_and_goal_poses_on_known_geometry():
    rb = make(center=(10.0, -5.0))  # Ro = 20, lanes 4 m
    route = Route(0, 1, start_distance=30.0, goal_distance=25.0)
    # from the west (leg 0 at 180 deg), driving east on the south half: y = -5 - 2
    assert start_pose(rb, route) == pytest.approx((10.0 - 50.0, -7.0, 0.0), abs=1e-12)
    # out by the south leg (270 deg), driving south on its west half: x = 10 - 2, y = -5 - 45; right turn
    assert goal_pose(rb, route) == pytest.approx((8.0, -50.0, -PI / 2), abs=1e-12)
    left = make(traffic="left", center=(10.0, -5.0))
    assert start_pose(left, route) == pytest.approx((-40.0, -3.0, 0.0), abs=1e-12)
    # left-hand: first exit is the north leg (90 deg), driven north on its west half: a left turn
    assert goal_pose(left, route) == pytest.approx((8.0, 40.0, PI / 2), abs=1e-12)


def test_start_heading_is_in_minus_pi_to_pi():
    rb = make()
    thetas = [start_pose(rb, Route(i, 1))[2] for i in range(4)]  # legs at 180, 270, 0, 90 deg
    assert thetas == pytest.approx([0.0, PI / 2, PI, -PI / 2], abs=1e-12)


# --------------------------------------------------------------------------- exit taken


def drive(rb: Roundabout, route: Route, extra_loops: int = 0) -> np.ndarray:
    """A polyline: start, round the middle of the ring the circulation way, out to the goal."""
    angles = [leg.angle_deg for leg in rb.legs]
    a0, a1 = angles[route.enter], angles[exit_leg(rb, route)]
    turn = ((a1 - a0) % 360.0 or 360.0) if rb.traffic == "right" else -((a0 - a1) % 360.0 or 360.0)
    turn = math.radians(turn) + (1 if rb.traffic == "right" else -1) * 2 * PI * extra_loops
    phi = math.radians(a0) + np.linspace(0.0, turn, 400)
    ring = np.array(rb.center) + 17.0 * np.column_stack([np.cos(phi), np.sin(phi)])
    return np.vstack([start_pose(rb, route)[:2], ring, goal_pose(rb, route)[:2]])


@pytest.mark.parametrize("angles", [THREE, FOUR, FIVE])
@pytest.mark.parametrize("traffic", ["right", "left"])
def test_exit_taken_counts_like_the_route(angles, traffic):
    rb = make(angles, traffic, w=3.0, r_in=10.0, r_out=10.0)
    k = len(angles)
    for enter in range(k):
        for n in range(1, k + 1):
            route = Route(enter, n)
            assert exit_taken(rb, enter, drive(rb, route)) == n
    assert exit_taken(rb, 0, drive(rb, Route(0, 1), extra_loops=1)) == 1 + k


def test_exit_taken_is_none_outside_every_exit_lane():
    rb = make()
    path = drive(rb, Route(0, 2))
    path[-1] = start_pose(rb, Route(2, 1))[:2]  # ends in leg 2's entry lane
    assert exit_taken(rb, 0, path) is None


# --------------------------------------------------------------------------- regions


def test_corridor_membership():
    rb = make()  # Ro 20, Ri 14, island 12.5
    region = corridor(rb, Route(0, 1))
    inside = [(-50.0, -2.0), (-17.0, 0.0), (17.0, 0.0), (0.0, 17.0), (-2.0, -50.0), (-21.0, -5.0)]
    outside = [
        (-50.0, 2.0),
        (0.0, 0.0),
        (-13.0, 0.0),
        (2.0, -50.0),
        (50.0, -2.0),
        (0.0, 50.0),
        (-85.0, -2.0),
        (-2.0, -85.0),
        (-22.0, -15.0),
    ]
    assert region.contains(np.array(inside)).all()
    assert not region.contains(np.array(outside)).any()
    assert corridor(rb, Route(0, 1), apron=True).contains(np.array([(-13.0, 0.0)]))[0]
    assert not corridor(rb, Route(0, 1), apron=True).contains(np.array([(-12.0, 0.0)]))[0]


def test_fillet_region_point_just_outside_the_arc_is_not_in_the_corridor():
    rb = make()
    f = fillet_geometry(rb, 0, "entry")
    region = corridor(rb, Route(0, 1))
    mid = math.atan2(*(-f["center"])[::-1])  # direction from the fillet centre to the roundabout centre
    towards = np.array([math.cos(mid + 0.3), math.sin(mid + 0.3)])  # between the two tangent points
    just_in = f["center"] + (f["radius"] + 1e-6) * towards
    just_out = f["center"] + (f["radius"] - 1e-6) * towards
    assert region.contains(just_in[None])[0] and not region.contains(just_out[None])[0]


@pytest.mark.parametrize(
    "angles, traffic, route", [(FOUR, "right", Route(0, 1)), (FIVE, "left", Route(3, 2)), (THREE, "right", Route(1, 3))]
)
def test_polygon_agrees_with_the_exact_test_away_from_the_boundary(angles, traffic, route):
    rb = make(angles, traffic, w=3.0, r_in=10.0, r_out=10.0)
    region = corridor(rb, route)
    pts = np.random.default_rng(0).uniform(-85, 85, size=(4000, 2))
    far = region.boundary_distance(pts) > 1e-3
    poly = shapely.contains_xy(region.polygon, *pts[far].T)
    assert (poly == region.contains(pts[far])).all()


def exact_length(region) -> float:
    return sum(
        math.dist(p.start, p.end) if isinstance(p, Segment) else p.radius * (p.end - p.start) for _, p in region.pieces
    )


@pytest.mark.parametrize(
    "rb, route",
    [
        (make(), Route(0, 2)),
        # opposite legs: collinear centre lines
        (make((98.5, 278.5), "left", icd=65.5, ring=5.0, apron=0.0, w=3.5, r_in=27.2, r_out=13.7), Route(0, 1)),
        # one leg, a U-turn: both lanes, both fillets (an overlay of polygons left slits here)
        (make((95.3,), "left", icd=59.0, ring=5.9, apron=0.0, w=3.1, r_in=7.24, r_out=29.76, length=70.5), Route(0, 1)),
    ],
)
def test_polygon_is_traced_along_the_exact_boundary(rb, route):
    region = corridor(rb, route)
    poly = region.polygon
    assert poly.geom_type == "Polygon" and len(poly.interiors) == 1  # the island (here: the apron edge)
    assert poly.length == pytest.approx(exact_length(region), abs=1e-3)
    v = np.asarray(poly.exterior.coords)
    assert region.boundary_distance(v).max() < 1e-9  # every vertex on the exact boundary


def test_ring_polygon_within_its_tolerance():
    rb = make()
    ring = ring_region(rb)
    assert ring.polygon.area == pytest.approx(PI * (20.0**2 - 14.0**2), abs=2 * PI * 20.0 * 1e-4)
    assert island_region(rb).polygon.area == pytest.approx(PI * 12.5**2, abs=2 * PI * 12.5 * 1e-4)


@pytest.mark.parametrize("apron", [False, True])
def test_edge_names(apron):
    rb = make()
    names = {e.name for e in edges(rb, Route(0, 1), apron=apron)}
    inner = "island" if apron else "apron"
    assert names == {
        "outer curb",
        inner,
        "leg 0 entry lane outer edge",
        "leg 0 centre line",
        "leg 0 end",
        "leg 0 entry fillet",
        "leg 1 exit lane outer edge",
        "leg 1 centre line",
        "leg 1 end",
        "leg 1 exit fillet",
    }
    uturn = {e.name for e in edges(rb, Route(2, 4), apron=apron)}
    assert uturn == {
        "outer curb",
        inner,
        "leg 2 entry lane outer edge",
        "leg 2 exit lane outer edge",
        "leg 2 end",
        "leg 2 entry fillet",
        "leg 2 exit fillet",
    }


def test_edge_pieces_lie_on_their_primitive_with_the_region_on_the_allowed_side():
    rb = make(FIVE, "left", w=3.0, r_in=10.0, r_out=10.0)
    region = corridor(rb, Route(1, 3))
    for edge in region.edges:
        for piece in edge.pieces:
            if isinstance(piece, Segment):
                a, b = np.array(piece.start), np.array(piece.end)
                pts = a + np.linspace(0.05, 0.95, 5)[:, None] * (b - a)
            else:
                pts = np.array([piece.point(t) for t in np.linspace(piece.start, piece.end, 7)[1:-1]])
            x, y = pts.T
            assert edge.margin(x, y) == pytest.approx(0.0, abs=1e-9)
            inward = (
                np.array(edge.normal)[None]
                if edge.kind == "halfplane"
                else (pts - edge.center) * (-1 if edge.kind == "circle_inside" else 1)
            )
            inward = inward / np.hypot(*inward.T)[:, None]
            assert region.contains(pts + 1e-4 * inward).all()
            assert not region.contains(pts - 1e-4 * inward).any()


# --------------------------------------------------------------------------- clearance


def tangential_body(rb: Roundabout, polar_deg: float, outer_corner_radius: float, length=8.0, width=2.5, rear=1.5):
    """A body driving counter-clockwise round the centre, its outer corners at ``outer_corner_radius``."""
    m = math.sqrt(outer_corner_radius**2 - (length / 2) ** 2) - width / 2  # radius of the body's centre
    mid = np.array(rb.center) + m * unit(polar_deg)
    heading = math.radians(polar_deg) + PI / 2
    x, y = mid - (length / 2 - rear) * np.array([math.cos(heading), math.sin(heading)])
    return rectangle(x, y, heading, length, width, rear), m


def test_body_touching_the_outer_curb_has_clearance_zero():
    rb = make()
    region = corridor(rb, Route(0, 1))
    body, _ = tangential_body(rb, 45.0, 20.0)  # north-east, between legs 2 and 3: the curb is closed there
    assert clearance(region, body) == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("gap", [0.3, 0.05, 1e-4])
def test_clearance_inside_is_the_gap_to_the_nearest_curb(gap):
    rb = make()
    region = corridor(rb, Route(0, 1))
    body, m = tangential_body(rb, 45.0, 20.0 - gap)
    assert m - 1.25 - 14.0 > gap  # the apron edge is farther
    assert clearance(region, body) == pytest.approx(gap, abs=1e-9)


@pytest.mark.parametrize("depth", [0.2, 1e-3])
def test_clearance_over_the_curb_is_minus_the_depth(depth):
    rb = make()
    region = corridor(rb, Route(0, 1))
    body, _ = tangential_body(rb, 45.0, 20.0 + depth)
    assert clearance(region, body) == pytest.approx(-depth, abs=1e-9)


def test_clearance_onto_the_apron_is_minus_the_depth_of_the_nearest_side():
    rb = make()
    region = corridor(rb, Route(0, 1))
    body, m = tangential_body(rb, 45.0, 16.5)
    inner_side = m - 1.25  # the inner side's midpoint is the body point nearest the centre
    assert inner_side < 14.0
    assert clearance(region, body) == pytest.approx(-(14.0 - inner_side), abs=1e-9)
    assert clearance(corridor(rb, Route(0, 1), apron=True), body) == pytest.approx(inner_side - 12.5, abs=1e-9)


def test_clearance_onto_the_apron_is_exact_between_the_edge_samples():
    rb = make()
    region = corridor(rb, Route(0, 1))
    body, m = tangential_body(rb, 45.0, 16.5, length=7.0, rear=0.0)
    heading = math.radians(135.0)
    shifted = shapely.affinity.translate(body, 1.2345 * math.cos(heading), 1.2345 * math.sin(heading))
    inner_side = m - 1.25  # the centre's foot on the inner side is still inside that side, off the 1 cm grid
    assert clearance(region, shifted) == pytest.approx(-(14.0 - inner_side), abs=1e-12)


def test_body_wholly_outside_has_negative_clearance():
    rb = make()
    region = corridor(rb, Route(0, 1))
    on_island = rectangle(-1.0, 0.5, 0.0, 4.0, 2.0, 1.0)  # covers the centre, 14 m from the ring roadway
    assert clearance(region, on_island) == pytest.approx(-14.0, abs=1e-12)
    other_leg = rectangle(50.0, 2.0, PI, 8.0, 2.5, 1.5)  # in leg 2's entry lane, 3.25 m beyond leg 2's centre line
    assert clearance(region, other_leg) < 0.0
    covering = Polygon([(-14.1, -14.1), (14.1, -14.1), (14.1, 14.1), (-14.1, 14.1)])  # corners in the ring
    assert clearance(region, covering) == pytest.approx(-14.0, abs=1e-12)  # the apron circle lies inside it


def test_clearance_to_the_leg_end_behind_a_long_body():
    rb = make()
    region = corridor(rb, Route(0, 1))
    body = rectangle(-78.4, -2.0, 0.0, 8.0, 2.5, 1.5)  # rear bumper 0.1 m short of the leg's end at x = -80
    assert clearance(region, body) == pytest.approx(0.1, abs=1e-12)


def test_clearance_at_the_start_pose_is_the_gap_to_the_lane_edges():
    rb = make()
    region = corridor(rb, Route(0, 1))
    body = rectangle(*start_pose(rb, Route(0, 1)), 8.0, 2.5, 1.5)
    assert clearance(region, body) == pytest.approx((4.0 - 2.5) / 2, abs=1e-12)
    plain = clearance(region.polygon, body)  # a shapely geometry is measured on its polygon
    assert plain == pytest.approx(0.75, abs=1e-3)


def test_clearance_detail_names_the_edge():
    rb = make()
    region = corridor(rb, Route(0, 1))
    over, _ = tangential_body(rb, 45.0, 20.2)
    onto, _ = tangential_body(rb, 45.0, 16.5)
    near_end = rectangle(-78.4, -2.0, 0.0, 8.0, 2.5, 1.5)
    assert clearance_detail(region, over)[:2] == (pytest.approx(-0.2), "outer curb")
    assert clearance_detail(region, onto)[1] == "apron"
    value, name, point = clearance_detail(region, near_end)
    assert (value, name) == (pytest.approx(0.1), "leg 0 end") and point[0] == pytest.approx(-79.9)


def test_rectangle_reference_point_is_the_rear_axle():
    body = rectangle(1.0, 2.0, 0.0, 8.0, 2.5, 1.5)
    assert body.equals(Polygon([(-0.5, 0.75), (7.5, 0.75), (7.5, 3.25), (-0.5, 3.25)]))
    turned = rectangle(0.0, 0.0, PI / 2, 8.0, 2.0, 1.0)
    assert turned.bounds == pytest.approx((-1.0, -1.0, 1.0, 7.0), abs=1e-12)


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "changes, key",
    [
        (dict(ring=20.0), "roundabout.circulatory_width"),
        (dict(ring=25.0), "roundabout.circulatory_width"),
        (dict(ring=0.0), "roundabout.circulatory_width"),
        (dict(icd=-40.0), "roundabout.inscribed_diameter"),
        (dict(apron=-0.5), "roundabout.apron_width"),
        (dict(apron=14.0), "roundabout.apron_width"),
        (dict(traffic="center"), "roundabout.traffic"),
        (dict(apron_use="bus"), "roundabout.apron_use"),
        (dict(angles=()), "roundabout.legs"),
        (dict(center=(0.0,)), "roundabout.center"),
        (dict(w=0.0), "roundabout.legs[0].lane_width"),
        (dict(w=20.0), "roundabout.legs[0].lane_width"),
        (dict(r_in=-1.0), "roundabout.legs[0].entry_radius"),
        (dict(r_out=float("nan")), "roundabout.legs[0].exit_radius"),
        (dict(length=0.0), "roundabout.legs[0].length"),
        (dict(length=10.0), "roundabout.legs[0].exit_radius"),  # the 20 m exit fillet reaches 12 m out
        (dict(angles=(180.0, 200.0, 0.0)), "roundabout.legs[1].angle"),
        (dict(angles=(0.0, 360.0)), "roundabout.legs[1].angle"),
        (dict(angles=(0.0, 60.0), r_in=30.0, r_out=30.0), "roundabout.legs[0].entry_radius"),
    ],
)
def test_bad_roundabouts_name_their_key(changes, key):
    with pytest.raises(InputError) as err:
        make(**changes)
    assert err.value.key == key


def test_bad_leg_angle_names_its_key():
    legs = [Leg(0.0, 4.0, 15.0, 20.0), Leg(float("inf"), 4.0, 15.0, 20.0)]
    with pytest.raises(InputError) as err:
        Roundabout((0.0, 0.0), 40.0, 6.0, legs=legs)
    assert err.value.key == "roundabout.legs[1].angle"


def test_legs_close_but_apart_outside_the_curb_are_fine():
    # 40 deg apart, 3 m lanes: strips 6 m wide meet at 3 / sin(20 deg) = 8.8 m < Ro; small fillets
    make(angles=(0.0, 40.0), w=3.0, r_in=2.0, r_out=2.0)


@pytest.mark.parametrize(
    "route, key",
    [
        (Route(0, 0), "route.exit"),
        (Route(0, 5), "route.exit"),
        (Route(4, 1), "route.enter"),
        (Route(-1, 1), "route.enter"),
        (Route(0, 1, start_distance=61.0), "route.start_distance"),
        (Route(0, 1, goal_distance=-1.0), "route.goal_distance"),
    ],
)
def test_bad_routes_name_their_key(route, key):
    rb = make()
    with pytest.raises(InputError) as err:
        start_pose(rb, route)
        goal_pose(rb, route)
    assert err.value.key == key


def test_lane_width_against_the_body():
    legs = [Leg(a, w, 15.0, 20.0) for a, w in zip(FOUR, (4.0, 4.0, 2.5, 4.0), strict=True)]
    rb = Roundabout((0.0, 0.0), 40.0, 6.0, legs=legs)
    check_lane_width(rb, 2.4)
    with pytest.raises(InputError) as err:
        check_lane_width(rb, 2.5)
    assert err.value.key == "roundabout.legs[2].lane_width"


def test_apron_use():
    assert [apron_allowed(make(apron_use=u), "trailer") for u in ("trailer", "all", "none")] == [True, True, False]
    assert [apron_allowed(make(apron_use=u), "vehicle") for u in ("trailer", "all", "none")] == [False, True, False]
