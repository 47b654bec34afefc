"""SUMO's junction rule in the autopilot: no vehicle made to brake beyond its brake gap by the truck (issue 20)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.test_traffic import ring_car, straight_pilot

pytest.importorskip("sumolib")
pytest.importorskip("traci")


@pytest.fixture(scope="module")
def net(tmp_path_factory):
    from model.traffic.network import write_network
    from model.traffic.sumo import find_sumo

    pilot = straight_pilot()
    return write_network(pilot.scenario.ocp.road.roundabout, tmp_path_factory.mktemp("net"), find_sumo().netconvert)


def junction_pilot(net, exit_leg: int = 1, entry_rule: bool = True):
    """The straight plan into the ring, with SUMO's junction outlines of leg 0 (entry) and ``exit_leg``."""
    from model.traffic.autopilot import Autopilot
    from model.traffic.network import junction_shape

    plain = straight_pilot()
    outlines = (junction_shape(net, 0), junction_shape(net, exit_leg))
    return Autopilot(plain.scenario, plain.plan, front=6.5, junctions=outlines, entry_rule=entry_rule)


def test_the_junction_outline_and_the_internal_lanes_come_from_the_network(net):
    """r0's outline holds the ring at leg 0 (180 deg) and not at 90 deg; ring0 -> out1 starts where ring0 ends."""
    import shapely
    import sumolib

    from model.traffic.network import junction_shape, via_lane_shape

    outline = shapely.Polygon(junction_shape(net, 0))
    assert outline.contains(shapely.Point(-17.0, 0.0)) and not outline.contains(shapely.Point(0.0, 17.0))
    lane = via_lane_shape(net, "ring0", "out1")
    ring0 = sumolib.net.readNet(str(net)).getEdge("ring0").getLanes()[0].getShape()
    out1 = sumolib.net.readNet(str(net)).getEdge("out1").getLanes()[0].getShape()
    assert np.allclose(lane[0], ring0[-1], atol=1e-2) and np.allclose(lane[-1], out1[0], atol=1e-2)
    assert not np.allclose(via_lane_shape(net, "ring0", "ring1")[-1], lane[-1])


def test_the_entry_window_begins_where_the_front_enters_the_junction(net):
    """The straight plan's front (x + 6.5 at y = -2) enters r0's outline at SUMO's entry lane end."""
    from model.traffic.network import entry_end_radius

    pilot = junction_pilot(net)
    (enter, last), _ = pilot.windows
    ra = pilot.scenario.ocp.road.roundabout
    front = -50.0 + 8.0 * enter + 6.5
    assert math.hypot(front, -2.0) == pytest.approx(entry_end_radius(net, ra, 0), abs=0.1)
    assert enter < last < pilot.plan.duration


@pytest.mark.parametrize("degrees,conflict", [(130.0, True), (60.0, False)])
def test_entering_ahead_of_a_ring_car_within_its_brake_gap_is_refused(net, degrees, conflict):
    """At 7 m/s a ring car's brake gap is 7 * 1 + 49 / 9 = 12.4 m: about 5 m before the junction (centre at
    130 deg) it would brake hard for a truck entering now; about 25 m before it (60 deg) it would not."""
    pilot = junction_pilot(net)
    pilot.s, pilot.rate = pilot.windows[0][0] - 0.05, 1.0
    tau = pilot.instants(0.1)
    s = pilot.s + tau
    assert pilot.junction_conflict(tau, s, pilot.predicted([ring_car(degrees)], tau)) == conflict
    assert not pilot.junction_conflict(tau, np.full_like(tau, pilot.s), pilot.predicted([ring_car(130.0)], tau))
    off = junction_pilot(net, entry_rule=False)  # as `roundabout traffic` drives: the entry half is off
    off.s, off.rate = pilot.s, 1.0
    assert not off.junction_conflict(tau, s, off.predicted([ring_car(130.0)], tau))


@pytest.mark.parametrize("front_y,conflict", [(-29.4, True), (-62.0, False)])
def test_an_entering_car_within_its_brake_gap_blocks_the_exit_window(net, front_y, conflict):
    """Where SUMO may map the exiting truck onto the ring's lane, a car entering from that leg (x = 2,
    heading north at 8 m/s, brake gap 15.1 m) 6 m before the junction would brake hard; 38.6 m before not."""
    from model.scene.moving import MovingVehicle

    pilot = junction_pilot(net, exit_leg=1)
    pilot.s, pilot.rate = 0.5, 1.0
    pilot.windows = (pilot.windows[0], (0.5, 0.8))  # the truck is in the exit's mapped window for 0.3 plan s
    car = MovingVehicle(4.5, 1.8, start=(2.0, front_y - 2.25, math.pi / 2), speed=8.0)
    tau = pilot.instants(0.1)
    assert pilot.junction_conflict(tau, pilot.s + tau, pilot.predicted([car], tau)) == conflict
    later = np.full_like(tau, 0.9)  # standing after the window: no conflict whatever the car does
    assert not pilot.junction_conflict(tau, later, pilot.predicted([car], tau))


def test_without_the_network_there_is_no_junction_rule():
    pilot = straight_pilot()
    tau = pilot.instants(0.1)
    assert pilot.windows is None
    assert not pilot.junction_conflict(tau, pilot.give_way + tau, pilot.predicted([ring_car(130.0)], tau))
