"""The scenario's roundabout as a SUMO network, its flows as routes, and the run's configuration.

The network is plain XML (nodes, edges, connections) converted by ``netconvert`` in the
scenario's own metric coordinates (``--offset.disable-normalization``: no shift):

- one ring node per leg on the ring roadway's centre line (radius ``(Ro + Ri) / 2``) on the leg's
  axis, and one node at the leg's far end (``Ro + length``);
- ring edges ``ring{i}`` from leg i's node to the next leg's node in the circulation direction,
  one lane on the ring roadway's centre line, shaped as its arc, as wide as the legs' lanes (at most
  the roadway; ``ring_lane_width``: the ring's internal lane beside an exit's is then no wider than
  the exit's, so that ``moveToXY(..., keepRoute=2)`` maps a truck leaving by the exit onto the exit's);
- per leg an entry edge ``in{i}`` and an exit edge ``out{i}``, one lane each, as wide as the
  leg's lanes, along the middle of the entry and the exit lane (the sides the traffic side gives);
- connections entry -> ring, ring -> ring, ring -> exit only (no U-turn in place), and the ring
  declared a ``<roundabout>`` so that entering vehicles yield to circulating ones.

A vehicle entering from leg i that takes the n-th exit drives ``in{i}``, n ring edges and
``out{j}`` (j the n-th leg after i in the circulation direction; n = k is the U-turn).
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from model.problem.scenario import Scenario
from model.problem.traffic import TrafficSettings
from model.scene.roundabout import Roundabout, exit_order, lane_side, leg_point

RING_SPEED = 25.0 / 3.6  # m/s, speed limit of the ring
LEG_SPEED = 50.0 / 3.6  # m/s, speed limit of the legs
ARC_STEP = math.radians(5.0)  # angle between the points of a ring edge's shape
NET_FILES = ("nodes.nod.xml", "edges.edg.xml", "connections.con.xml")
# Points on each internal junction lane's shape (netconvert's default 5). With 5 the entry's and the
# ring's internal lanes at a merge are polylines coarse enough that a truck's front near their common
# end is equally near both, and moveToXY(keepRoute=2) maps it onto the ring's (measured: semitrailer
# right 450 veh/h seed 4, t = 28.7 s); with 20 the recorded poses stay on the route's lanes.
INTERNAL_LINK_DETAIL = 20


def ring_radius(roundabout: Roundabout) -> float:
    """Radius of the ring lane's centre line, the middle of the ring roadway."""
    return (roundabout.outer_radius + roundabout.inner_radius) / 2.0


def ring_order(roundabout: Roundabout) -> list[int]:
    """Leg indices in the circulation direction, starting at leg 0."""
    order = exit_order(roundabout, 0)
    return [order[-1], *order[:-1]]


def next_leg(roundabout: Roundabout, leg: int) -> int:
    """The leg met next after ``leg`` in the circulation direction."""
    return exit_order(roundabout, leg)[0]


def _ring_point(roundabout: Roundabout, angle: float) -> tuple[float, float]:
    c, r = roundabout.center, ring_radius(roundabout)
    return c[0] + r * math.cos(angle), c[1] + r * math.sin(angle)


def ring_lane_width(roundabout: Roundabout) -> float:
    """Width of the ring's SUMO lane: the legs' widest lane, at most the ring roadway.

    SUMO's internal lanes take the width of the lane they lead to, so an exit's internal lane is as
    wide as the exit lane and the ring's one beside it as wide as the ring lane. ``moveToXY(...,
    keepRoute=2)`` picks between them by their distances *and* widths: with a ring lane as wide as
    the roadway (6 m against the exit's 4 m on the example) a truck cutting the exit corner near the
    outer curb lies inside the ring lane's width and outside the exit's, and SUMO put it on the ring's
    lane for 0.2-0.7 s (measured: every exit of the benchmark's runs), a "circulating" truck for the
    car entering from that leg. With equal widths the nearer lane wins.
    """
    return min(roundabout.circulatory_width, max(g.lane_width for g in roundabout.legs))


def ring_shape(roundabout: Roundabout, leg: int) -> list[tuple[float, float]]:
    """The arc of the ring centre line from leg ``leg``'s node to the next leg's, in the circulation direction."""
    a0, a1 = roundabout.legs[leg].angle, roundabout.legs[next_leg(roundabout, leg)].angle
    turn = (roundabout.circulation * (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    n = max(2, math.ceil(turn / ARC_STEP))
    return [_ring_point(roundabout, a0 + roundabout.circulation * turn * s) for s in np.linspace(0.0, 1.0, n + 1)]


def lane_line(roundabout: Roundabout, leg: int, lane: str) -> list[tuple[float, float]]:
    """The middle of leg ``leg``'s entry or exit lane, from the far end to the outer curb (entry) or back (exit)."""
    g = roundabout.legs[leg]
    across = lane_side(roundabout, lane) * g.lane_width / 2.0
    near = math.sqrt(roundabout.outer_radius**2 - (g.lane_width / 2.0) ** 2)
    far = roundabout.outer_radius + g.length
    points = [tuple(map(float, leg_point(roundabout, leg, a, across))) for a in (far, near)]
    return points if lane == "entry" else points[::-1]


def _shape(points) -> str:
    return " ".join(f"{x:.4f},{y:.4f}" for x, y in points)


def nodes_xml(roundabout: Roundabout) -> str:
    """The plain-XML nodes: ``r{i}`` on the ring, ``e{i}`` at each leg's far end."""
    rows = []
    for i, g in enumerate(roundabout.legs):
        x, y = _ring_point(roundabout, g.angle)
        rows.append(f'    <node id="r{i}" x="{x:.4f}" y="{y:.4f}" type="priority"/>')
        fx, fy = leg_point(roundabout, i, roundabout.outer_radius + g.length, 0.0)
        rows.append(f'    <node id="e{i}" x="{fx:.4f}" y="{fy:.4f}" type="dead_end"/>')
    return "<nodes>\n" + "\n".join(rows) + "\n</nodes>\n"


def edges_xml(roundabout: Roundabout) -> str:
    """The plain-XML edges (ring, entries, exits) and the ``<roundabout>`` declaration."""
    width = ring_lane_width(roundabout)
    rows = []
    for i, g in enumerate(roundabout.legs):
        j = next_leg(roundabout, i)
        rows.append(
            f'    <edge id="ring{i}" from="r{i}" to="r{j}" numLanes="1" speed="{RING_SPEED:.4f}" '
            f'width="{width:.4f}" spreadType="center" shape="{_shape(ring_shape(roundabout, i))}"/>'
        )
        for lane, frm, to in (("entry", f"e{i}", f"r{i}"), ("exit", f"r{i}", f"e{i}")):
            rows.append(
                f'    <edge id="{"in" if lane == "entry" else "out"}{i}" from="{frm}" to="{to}" numLanes="1" '
                f'speed="{LEG_SPEED:.4f}" width="{g.lane_width:.4f}" spreadType="center" '
                f'shape="{_shape(lane_line(roundabout, i, lane))}"/>'
            )
    ring = ring_order(roundabout)
    rows.append(
        f'    <roundabout nodes="{" ".join(f"r{i}" for i in ring)}" edges="{" ".join(f"ring{i}" for i in ring)}"/>'
    )
    return "<edges>\n" + "\n".join(rows) + "\n</edges>\n"


def connections_xml(roundabout: Roundabout) -> str:
    """Entry -> ring, ring -> ring and ring -> exit at every ring node; nothing else."""
    rows = []
    for i in range(len(roundabout.legs)):
        before = [j for j in range(len(roundabout.legs)) if next_leg(roundabout, j) == i][0]
        rows.append(f'    <connection from="in{i}" to="ring{i}"/>')
        rows.append(f'    <connection from="ring{before}" to="ring{i}"/>')
        rows.append(f'    <connection from="ring{before}" to="out{i}"/>')
    return "<connections>\n" + "\n".join(rows) + "\n</connections>\n"


def route_edges(roundabout: Roundabout, enter: int, exit_number: int) -> list[str]:
    """SUMO edges of the path from leg ``enter`` to its ``exit_number``-th exit."""
    edges, leg = [f"in{enter}"], enter
    for _ in range(exit_number):
        edges.append(f"ring{leg}")
        leg = next_leg(roundabout, leg)
    return [*edges, f"out{leg}"]


def write_network(roundabout: Roundabout, folder: Path, netconvert: str) -> Path:
    """Write the plain XML into ``folder`` and convert it to ``folder/net.net.xml``.

    The internal junction lanes get ``INTERNAL_LINK_DETAIL`` points (``--junctions.internal-link-detail``)
    so that ``moveToXY(keepRoute=2)`` keeps a truck at a merge on its own entry's internal lane.

    Raises
    ------
    RuntimeError
        If netconvert fails (its message included).
    """
    folder.mkdir(parents=True, exist_ok=True)
    texts = (nodes_xml(roundabout), edges_xml(roundabout), connections_xml(roundabout))
    for name, text in zip(NET_FILES, texts, strict=True):
        (folder / name).write_text(text)
    net = folder / "net.net.xml"
    cmd = [
        netconvert, "--node-files", str(folder / NET_FILES[0]), "--edge-files", str(folder / NET_FILES[1]),
        "--connection-files", str(folder / NET_FILES[2]), "--output-file", str(net),
        "--offset.disable-normalization", "true", "--no-turnarounds", "true", "--junctions.corner-detail", "8",
        "--junctions.internal-link-detail", str(INTERNAL_LINK_DETAIL), "--no-warnings", "true", "--seed", "0",
    ]  # fmt: skip
    if roundabout.traffic == "left":
        cmd += ["--lefthand", "true"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"netconvert failed: {done.stderr.strip()}")
    return net


def entry_end_radius(net: Path, roundabout: Roundabout, leg: int) -> float:
    """Distance from the centre at which leg ``leg``'s entry lane ends in the converted network ``net``.

    netconvert cuts the entry lane back to the junction's shape: beyond this point a vehicle is on
    the junction's internal lane, where SUMO's circulating vehicles treat it as having entered.
    """
    import xml.etree.ElementTree as ET

    lane = ET.parse(net).getroot().find(f"edge[@id='in{leg}']/lane")
    x, y = map(float, lane.get("shape").split()[-1].split(","))
    return math.hypot(x - roundabout.center[0], y - roundabout.center[1])


def junction_shape(net: Path, leg: int) -> np.ndarray:
    """The outline (n, 2) of leg ``leg``'s ring junction ``r<leg>`` in the converted network ``net``.

    Inside it a vehicle is on one of the junction's internal lanes: where SUMO's junction model
    (right of way, merging) sees it.
    """
    import xml.etree.ElementTree as ET

    node = ET.parse(net).getroot().find(f"junction[@id='r{leg}']")
    return np.array([tuple(map(float, p.split(","))) for p in node.get("shape").split()])


def via_lane_shape(net: Path, from_edge: str, to_edge: str) -> np.ndarray:
    """The centre line (n, 2) of the internal lane that connects ``from_edge`` to ``to_edge`` in ``net``."""
    import xml.etree.ElementTree as ET

    root = ET.parse(net).getroot()
    via = root.find(f"connection[@from='{from_edge}'][@to='{to_edge}']").get("via")
    lane = root.find(f"edge/lane[@id='{via}']")
    return np.array([tuple(map(float, p.split(","))) for p in lane.get("shape").split()])


def truck_vtype(vclass: str, length: float, width: float, limits: dict[str, float] | None = None) -> str:
    """The ``<vType>`` of the truck (id ``ego``): its class, overall length and widest body.

    ``limits`` (``truck_limits``): its ``accel``, ``decel`` (m/s^2) and ``maxSpeed`` (m/s) too; without
    them SUMO's defaults of the vClass hold.
    """
    extra = "".join(f' {k}="{limits[k]:.6g}"' for k in ("accel", "decel", "maxSpeed")) if limits else ""
    return f'    <vType id="ego" vClass="{vclass}" length="{length:.4f}" width="{width:.4f}" minGap="2.0"{extra}/>'


def truck_limits(scenario: Scenario) -> dict[str, float] | None:
    """SUMO's ``accel``, ``decel`` and ``maxSpeed`` of the truck from the scenario's longitudinal limits.

    With ``[vehicle.longitudinal]`` (the vehicle's ``roles.acceleration`` set): accel = the upper bound
    of the acceleration, decel = minus its lower bound, maxSpeed = the speed's upper bound
    (docs/dynamics-format.md, "like with like"); None without them (SUMO's vClass defaults).
    """
    ocp = scenario.ocp
    r = ocp.vehicle.roles
    if r.acceleration is None or r.acceleration not in ocp.bounds or r.speed not in ocp.bounds:
        return None
    lo, hi = ocp.bounds[r.acceleration]
    return {"accel": float(hi), "decel": float(-lo), "maxSpeed": float(ocp.bounds[r.speed][1])}


def routes_xml(roundabout: Roundabout, traffic: TrafficSettings, truck: dict | None, with_others: bool = True) -> str:
    """The routes file: one ``<flow>`` per leg and exit (exponential headways), and the vehicle ``truck``.

    A flow of rate q whose exits have shares s_n becomes one flow per exit of rate q s_n: thinning
    a Poisson stream gives independent Poisson streams, so the leg's departures are a Poisson
    stream of rate q whose vehicles take the exits with the shares (SUMO draws with its seed).

    Parameters
    ----------
    truck : dict or None
        ``vclass``, ``length``, ``width``, ``enter``, ``exit`` of the truck (and ``limits``, ``truck_vtype``;
        ``depart_speed``, m/s, default 0), or None for no truck.
    with_others : bool
        False writes no flows (the free-flow run).
    """
    end = traffic.warmup + traffic.time_limit
    rows = [f'    <vType id="{kind}" vClass="{kind}"/>' for kind in sorted({f.type for f in traffic.flows})]
    if truck is not None:
        rows.append(truck_vtype(truck["vclass"], truck["length"], truck["width"], truck.get("limits")))
    body = []
    for k, flow in enumerate(traffic.flows if with_others else ()):
        for n, share in enumerate(flow.exits, start=1):
            rate = flow.vehicles_per_hour * share / 3600.0
            if rate <= 0:
                continue
            edges = " ".join(route_edges(roundabout, flow.leg, n))
            body.append((0.0, f'    <flow id="f{k}_{n}" type="{flow.type}" begin="0.00" end="{end:.2f}" '
                              f'period="exp({rate:.9g})" departLane="best" departSpeed="max">\n'
                              f'        <route edges="{edges}"/>\n    </flow>'))  # fmt: skip
    if truck is not None:
        edges = " ".join(route_edges(roundabout, truck["enter"], truck["exit"]))
        body.append((traffic.depart, f'    <vehicle id="truck" type="ego" depart="{traffic.depart:.2f}" '
                                     f'departSpeed="{truck.get("depart_speed", 0.0):g}" '
                                     f'departPos="{truck["depart_pos"]:.4f}">\n'
                                     f'        <route edges="{edges}"/>\n    </vehicle>'))  # fmt: skip
    rows += [text for _, text in sorted(body, key=lambda b: b[0])]
    return "<routes>\n" + "\n".join(rows) + "\n</routes>\n"


def config_xml(traffic: TrafficSettings, seed: int, routes: str = "routes.rou.xml") -> str:
    """``run.sumocfg``: net, routes, SUMO's seed and step length, no teleports, collisions only warned."""
    values = {
        "net-file": "net.net.xml", "route-files": routes, "seed": str(seed), "step-length": f"{traffic.step:g}",
        "end": f"{traffic.warmup + traffic.time_limit:g}", "time-to-teleport": "-1", "collision.action": "warn",
        "no-step-log": "true", "no-warnings": "true", "default.speeddev": "0.1",
    }  # fmt: skip
    rows = [f"    <{k} value={quoteattr(v)}/>" for k, v in values.items()]
    return "<configuration>\n" + "\n".join(rows) + "\n</configuration>\n"


def truck_geometry(scenario: Scenario) -> dict:
    """The SUMO vehicle ``truck``: vClass, overall length of the straight vehicle, widest body, front offset.

    ``front`` is the distance from the reference point (rear axle) to the first body's front bumper.
    """
    ocp = scenario.ocp
    v = ocp.vehicle
    poses = v.body_poses()
    straight = {s: np.zeros(1) for s in v.states}
    ends = []
    for name, body in ocp.bodies.items():
        x, y, _ = v.state_function(list(poses[name]))(straight)
        ends += [float(x[0]) - body.rear_overhang, float(x[0]) + body.length - body.rear_overhang]
    first = ocp.bodies["vehicle"]
    return {
        "vclass": "trailer" if v.roles.trailers else "truck",
        "length": max(ends) - min(ends),
        "width": max(b.width for b in ocp.bodies.values()),
        "front": first.length - first.rear_overhang,
    }



__all__ = [
    "NET_FILES", "config_xml", "connections_xml", "edges_xml", "junction_shape", "lane_line", "next_leg", "nodes_xml",
    "ring_lane_width", "ring_order", "ring_radius", "ring_shape", "route_edges", "routes_xml", "truck_geometry",
    "truck_limits", "truck_vtype",
    "via_lane_shape", "write_network",
]  # fmt: skip
