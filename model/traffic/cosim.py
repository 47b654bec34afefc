"""The co-simulation loop of ``roundabout traffic`` (docs/traffic-format.md), with the ``sumo`` driver.

A run has three SUMO passes, each a fresh ``traci.start`` of ``DIR/sumo/run.sumocfg``'s settings:

1. *drive*: SUMO's own driver model drives the vehicle ``truck`` (the truck's overall length and
   widest body) on the route's edges; its front-bumper pose is read after every step from
   t = warmup until the truck's rear axle passes the goal (or the time limit). The model's states
   are reconstructed from these poses (``reconstruct``).
2. *replay*: the contract's replay loop moves ``truck`` with ``moveToXY`` to the recorded poses
   and writes ``traffic.csv``; the metrics (exact rectangles, braking, time loss) come from this
   pass, so anyone replaying ``DIR/sumo`` with ``trajectory.csv`` sees exactly the traffic scored.
3. *without truck*: the same seed, no truck, to the same end time: ``others_time_loss_without_truck``.

The free-flow time is pass 1 on a routes file without flows.
"""

from __future__ import annotations

import contextlib
import io
import math
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from model.nlp.imports import settled_heap
from model.problem.scenario import Scenario
from model.traffic.autopilot import LEADER_DECEL, LINE_SLACK, YAW_WINDOW, Autopilot, predict
from model.traffic.cooperative import apply_commands
from model.traffic.network import (
    config_xml,
    entry_end_radius,
    junction_shape,
    route_edges,
    routes_xml,
    truck_geometry,
    truck_limits,
    via_lane_shape,
    write_network,
)
from model.traffic.reservation import traffic_manager
from model.traffic.sumo import Sumo
from model.traffic.tracking import Tracker, reference_of

BRAKING_RADIUS = 50.0  # m: other vehicles this close to a truck body count for max_braking_caused
STILL_SPEED = 0.1  # m/s: below this the truck stands still (entry_wait)
ARRIVE_GAP = 0.1  # m: the truck has arrived when its reference point is this near its plan path's end
TIME_DIGITS = 6
CONNECT_WAIT = 0.02  # s between tries to connect to a starting SUMO
CONNECT_TRIES = 3000  # a minute in all, traci's own default (60 tries, 1 s apart)


@dataclass
class Pass:
    """What one SUMO pass recorded: the truck's front poses and speeds, the others' rows, their time loss."""

    truck: dict[float, tuple[float, float, float, float]] = field(default_factory=dict)  # t -> X, Y, A, speed
    rows: list[tuple] = field(default_factory=list)
    time_loss: dict[str, float] = field(default_factory=dict)
    braking: dict[float, dict[str, float]] = field(default_factory=dict)  # t -> id -> deceleration
    arrived: bool = False
    end: float = 0.0
    states: dict[float, dict[str, float]] = field(default_factory=dict)  # autopilot: t -> states and controls
    decisions: list[str] = field(default_factory=list)
    decision_seconds: list[float] = field(default_factory=list)
    decision_cpu_seconds: list[float] = field(default_factory=list)
    commands: dict[float, dict[str, float]] = field(default_factory=dict)  # cooperative: t -> id -> setSpeed value
    vtype: dict[str, object] = field(default_factory=dict)  # the truck's vType as SUMO used it (``vtype_of``)
    tracking: list[float] = field(default_factory=list)  # autopilot: per step, the reference point's miss of the plan's
    management: dict[str, int] = field(default_factory=dict)  # cooperative: waiting steps by its request's reason


def write_sumo_files(scenario: Scenario, folder: Path, sumo: Sumo, seed: int) -> None:
    """Net, routes with and without the truck and without others, and the run's config in ``folder``."""
    road, traffic = scenario.ocp.road, scenario.traffic
    write_network(road.roundabout, folder, sumo.netconvert)
    truck = truck_geometry(scenario) | {"enter": road.route.enter, "exit": road.route.exit}
    truck["limits"] = truck_limits(scenario)
    speed = scenario.ocp.vehicle.roles.speed
    if speed in scenario.ocp.vehicle.states:  # SUMO's driver appears at [initial] v, as the autopilot does
        truck["depart_speed"] = float(scenario.ocp.initial.get(speed, 0.0))
    leg = road.roundabout.legs[road.route.enter]
    truck["depart_pos"] = max(truck["length"], leg.length - road.route.start_distance + truck["front"])
    files = {
        "routes.rou.xml": routes_xml(road.roundabout, traffic, truck),
        "routes_without_truck.rou.xml": routes_xml(road.roundabout, traffic, None),
        "routes_free_flow.rou.xml": routes_xml(road.roundabout, traffic, truck, with_others=False),
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    (folder / "run.sumocfg").write_text(config_xml(traffic, seed))


def start_sumo(sumo: Sumo, folder: Path, routes: str = "routes.rou.xml") -> object:
    """SUMO started on ``folder/run.sumocfg`` (with ``routes`` instead of its route file), quietly; its traci module."""
    traci = sumo.traci
    cmd = [sumo.sumo, "-c", str(folder / "run.sumocfg")]
    if routes != "routes.rou.xml":
        cmd += ["--route-files", str(folder / routes)]
    # traci.start waits 1 s between its tries to connect while SUMO loads, a second or more per start and four
    # starts a run (the drive, its replay, the runs without the truck and free flow); polling every
    # CONNECT_WAIT seconds finds SUMO as soon as it listens
    port = traci.main.getFreeSocketPort()
    proc = subprocess.Popen([*cmd, "--remote-port", str(port)], stdout=subprocess.DEVNULL)
    with contextlib.redirect_stdout(io.StringIO()):  # traci prints " Retrying in ... seconds" while SUMO starts
        traci.main.connect(port, CONNECT_TRIES, "localhost", proc, CONNECT_WAIT, label="default")
    traci.switch("default")
    return traci


def passed_goal(scenario: Scenario, front: tuple[float, float, float]) -> bool:
    """Whether the truck's rear axle, ``front`` being its front-bumper (X, Y, SUMO angle), is past the goal."""
    road = scenario.ocp.road
    geo = truck_geometry(scenario)
    theta = math.radians(90.0 - front[2])
    x, y = front[0] - geo["front"] * math.cos(theta), front[1] - geo["front"] * math.sin(theta)
    gx, gy, gtheta = road.goal()
    return (x - gx) * math.cos(gtheta) + (y - gy) * math.sin(gtheta) >= 0.0


def drive(scenario: Scenario, sumo: Sumo, folder: Path, routes: str = "routes.rou.xml") -> Pass:
    """Pass 1: SUMO drives the truck; its front poses from t = warmup to the goal or the time limit."""
    traffic = scenario.traffic
    traci = start_sumo(sumo, folder, routes)
    out, t_end = Pass(), traffic.warmup + traffic.time_limit
    try:
        while traci.simulation.getTime() < t_end - 1e-9:
            traci.simulationStep()
            t = round(traci.simulation.getTime(), TIME_DIGITS)
            ids = traci.vehicle.getIDList()
            if "truck" not in ids:
                if out.truck:  # it left the network: arrived at its route's end
                    out.arrived = True
                    break
                continue
            if t < traffic.warmup - 1e-9:
                continue
            out.vtype = out.vtype or vtype_of(traci)
            (x, y), a = traci.vehicle.getPosition("truck"), traci.vehicle.getAngle("truck")
            out.truck[t] = (x, y, a, traci.vehicle.getSpeed("truck"))
            if passed_goal(scenario, (x, y, a)):
                out.arrived = True
                break
    finally:
        traci.close()
    out.end = max(out.truck) if out.truck else t_end
    return out


def replay(sumo: Sumo, folder: Path, poses: dict[float, tuple], t_last: float, step: float,
           routes: str = "routes.rou.xml", commands: dict[float, dict[str, float]] | None = None) -> Pass:  # fmt: skip
    """The contract's replay loop: ``truck`` moved to ``poses`` (t -> X, Y, A), every other vehicle recorded;
    ``commands`` (t -> id -> speed, a cooperative run's ``commands.csv``) set with setSpeed at the same point."""
    traci = start_sumo(sumo, folder, routes)
    out = Pass(end=t_last)
    try:
        while traci.simulation.getTime() < t_last - 1e-9:
            t_next = round(traci.simulation.getTime() + step, TIME_DIGITS)
            if t_next in poses and "truck" in traci.vehicle.getIDList():
                x, y, a = poses[t_next][:3]
                traci.vehicle.moveToXY("truck", "", -1, x, y, a, keepRoute=2)
            apply_commands(traci, (commands or {}).get(t_next, {}))
            traci.simulationStep()
            _record(traci, round(traci.simulation.getTime(), TIME_DIGITS), out)
    finally:
        traci.close()
    return out


def autopilot_drive(scenario: Scenario, sumo: Sumo, folder: Path, plan, routes: str = "routes.rou.xml",
                    junction_rule: bool = False, entry_rule: bool = False,
                    follow_rule: bool = True, cooperate: bool | str = False) -> Pass:  # fmt: skip
    """The autopilot's pass: each step, predict the others, choose the progress, move ``truck`` there.

    The loop is the contract's replay loop with the poses made online, so replaying ``DIR/sumo``
    with ``trajectory.csv`` gives this pass's ``traffic.csv``. ``Pass.states`` holds the rows.
    ``junction_rule``: give the driver SUMO's exit junction rule (``Autopilot.junction_conflict``);
    off by default (``roundabout traffic``): measured worse, benchmarks/traffic.md. ``entry_rule``: its
    entry half (``Autopilot(entry_rule=True)``), alone or with the exit half; off by default.
    ``follow_rule``: refuse an entry that makes a circulating follower brake above ``FOLLOWER_DECEL``
    (``Autopilot.follower_braking``, the merge point the end of SUMO's internal entry lane); on by default.
    ``cooperate``: a managed driver, the other vehicles connected: True or "cooperative" (the priority
    request of ``model.traffic.cooperative.PriorityRequest``), "reservation" (first come, first served,
    ``model.traffic.reservation``); from the truck's appearance on, each step the management sets the speeds
    of the vehicles it holds out of the truck's windows (``Pass.commands``); the autopilot's own checks stay
    as they are.
    """

    traffic, v, road = scenario.traffic, scenario.ocp.vehicle, scenario.ocp.road
    geo = truck_geometry(scenario)
    line = entry_end_radius(folder / "net.net.xml", road.roundabout, road.route.enter) + LINE_SLACK
    net = folder / "net.net.xml"
    junctions = (junction_shape(net, road.route.enter), junction_shape(net, road.exit_leg))
    edges = route_edges(road.roundabout, road.route.enter, road.route.exit)
    lanes = None
    if len(edges) > 2:  # the ring's internal lanes at the exit: the truck's, and the one continuing round
        lanes = (via_lane_shape(net, edges[-2], edges[-1]), via_lane_shape(net, edges[-2], f"ring{road.exit_leg}"))
    if not junction_rule:
        lanes = None  # no exit half: the mapped window is empty
    if not (junction_rule or entry_rule):
        junctions = None
    merge = tuple(via_lane_shape(net, edges[0], edges[1])[-1])  # where the entry's internal lane joins the ring
    pilot = Autopilot(scenario, plan, geo["front"], line_radius=line, junctions=junctions, exit_lanes=lanes,
                      entry_rule=entry_rule, follow_rule=follow_rule, merge_point=merge,
                      leader_decel=(truck_limits(scenario) or {"decel": LEADER_DECEL})["decel"])  # fmt: skip
    kind = "cooperative" if cooperate is True else cooperate
    manager = traffic_manager(kind, scenario, plan, geo["front"]) if kind else None
    tracker = Tracker(scenario.ocp, reference_of(scenario.ocp, plan.t, plan.columns))
    # the plan's solve leaves large object graphs: collect them now and keep the survivors out of the
    # collector's scans while driving, so that no decision pays for a full collection (measured: 1.7 CPU s)
    with settled_heap():
        traci = start_sumo(sumo, folder, routes)
        out, t_end = Pass(), traffic.warmup + traffic.time_limit
        seen: dict[str, list[tuple[float, float]]] = {}  # id -> (t, heading) over the last YAW_WINDOW seconds
        last: list[tuple] = []
        ra, exiting = road.roundabout, frozenset()
        held = np.zeros(len(v.controls))
        try:
            while traci.simulation.getTime() < t_end - 1e-9:
                t_next = round(traci.simulation.getTime() + traffic.step, TIME_DIGITS)
                now = round(traci.simulation.getTime(), TIME_DIGITS)
                if now >= traffic.warmup - 1e-9 and "truck" in traci.vehicle.getIDList():
                    out.vtype = out.vtype or vtype_of(traci)
                    others = [predict(r, *_earlier(seen.get(r[1], []), r[0])) for r in last]
                    name, _ = pilot.decide(others, traffic.step, exiting)
                    out.decisions.append(name)
                    if manager is not None and (sent := manager.step(traci, traci.simulation.getTime(), pilot, others)):
                        out.commands[t_next] = sent
                    held = _track(pilot, tracker, out, now, geo["front"])
                    x, y, a = front_pose(v, tracker.state(), geo["front"])
                    traci.vehicle.moveToXY("truck", "", -1, x, y, a, keepRoute=2)
                traci.simulationStep()
                t = round(traci.simulation.getTime(), TIME_DIGITS)
                n = len(out.rows)
                _record(traci, t, out)
                last = out.rows[n:]
                exiting = _exiting(traci, last, ra, follow_rule and t >= traffic.warmup - 1e-9)
                seen = _headings(seen, last, t)
                if out.states and arrived(pilot, tracker):
                    out.arrived = True
                    break
            if out.states:  # the state after the last step: the last row (its controls those held into it)
                _row(out, tracker, held, round(traci.simulation.getTime(), TIME_DIGITS), geo["front"])
        finally:
            traci.close()
    out.end = max(out.truck) if out.truck else t_end
    out.management = dict(getattr(manager, "reasons", {}))
    out.decision_seconds = pilot.decision_seconds
    out.decision_cpu_seconds = pilot.decision_cpu_seconds
    return out


def vtype_of(traci) -> dict[str, object]:
    """The truck's vType (``ego``) as SUMO runs it: vClass, accel, decel, emergencyDecel, maxSpeed, length, width."""
    vt = traci.vehicletype
    return {"vClass": vt.getVehicleClass("ego"), "accel": vt.getAccel("ego"), "decel": vt.getDecel("ego"),
            "emergencyDecel": vt.getEmergencyDecel("ego"), "maxSpeed": vt.getMaxSpeed("ego"),
            "length": vt.getLength("ego"), "width": vt.getWidth("ego")}  # fmt: skip


def front_pose(vehicle, state: dict[str, float], front: float) -> tuple[float, float, float]:
    """SUMO's pose of the truck at ``state``: its front bumper's centre (X, Y) and heading A in SUMO's degrees."""
    r = vehicle.roles
    th = state[r.heading]
    return state[r.x] + front * math.cos(th), state[r.y] + front * math.sin(th), 90.0 - math.degrees(th)


def _track(pilot: Autopilot, tracker: Tracker, out: Pass, now: float, front: float) -> np.ndarray:
    """The row at ``now`` (the truck's states, the controls held until the next row) and the step integrated.

    The controls bring the truck to the plan time the autopilot chose (``pilot.s``); their
    computation and the integration count into the decision's time. With the speed a state (the
    truck cannot jump to the pace asked for) the autopilot's plan time is then where the truck is.
    """
    t0, c0, step = time.perf_counter(), time.process_time(), pilot.scenario.traffic.step
    held = tracker.controls(pilot.s, pilot.rate, step)
    _row(out, tracker, held, now, front)
    tracker.advance(held, step)
    v = tracker.ocp.vehicle
    r, aim = v.roles, tracker.reference.at(pilot.s)
    here = tracker.state()
    out.tracking.append(math.hypot(here[r.x] - aim[r.x], here[r.y] - aim[r.y]))
    if r.speed in v.states:  # the speed a state: the truck's progress is where it is, the autopilot goes on from there
        pilot.s = min(tracker.locate(), pilot.plan.duration)
    pilot.decision_seconds[-1] += time.perf_counter() - t0
    pilot.decision_cpu_seconds[-1] += time.process_time() - c0
    return held


def _row(out: Pass, tracker: Tracker, held: np.ndarray, t: float, front: float) -> None:
    """``trajectory.csv``'s row at ``t``: the truck's states and ``held``; its SUMO pose and speed."""
    v = tracker.ocp.vehicle
    state = tracker.state()
    out.states[t] = state | dict(zip(v.controls, held.tolist(), strict=True))
    out.truck[t] = (*front_pose(v, state, front), tracker.speed(held))


def arrived(pilot: Autopilot, tracker: Tracker) -> bool:
    """Whether the autopilot has asked for its plan's end and the truck is within ``ARRIVE_GAP`` of the path's end."""
    ref = tracker.reference
    if max(pilot.s, tracker.aim) < pilot.plan.duration - 1e-12:
        return False
    s = tracker.state()
    r = tracker.ocp.vehicle.roles
    where = ref.project(s[r.x], s[r.y], ref.t[-1])
    return ref.arc[-1] - ref.arc_at(where) <= ARRIVE_GAP


def _headings(seen: dict[str, list[tuple[float, float]]], rows: list[tuple], t: float) -> dict:
    """Each vehicle of ``rows`` (the step's) -> its (t, heading) over the last ``YAW_WINDOW`` seconds, ``t``'s added."""
    return {r[1]: [*(h for h in seen.get(r[1], []) if h[0] >= t - YAW_WINDOW - 1e-9), (t, r[5])] for r in rows}


def _exiting(traci, rows: list[tuple], roundabout, query: bool = True) -> frozenset[str]:
    """Keys (``traffic <id>``) of the vehicles near the ring showing the exit side's turn signal.

    SUMO switches a vehicle's blinker on ahead of a turning link: its exit from the ring is a right
    turn in counter-clockwise circulation (``VEH_SIGNAL_BLINKER_RIGHT``, bit 0), a left turn in
    clockwise (bit 1). Only vehicles whose centre is within the outer curb + 5 m are asked (one
    TraCI call each); none without ``query``.
    """
    if not query:
        return frozenset()
    bit = 1 if roundabout.circulation > 0 else 2
    cx, cy = roundabout.center
    reach = roundabout.outer_radius + 5.0
    return frozenset(f"traffic {r[1]}" for r in rows
                     if math.hypot(r[3] - cx, r[4] - cy) <= reach and traci.vehicle.getSignals(r[1]) & bit)  # fmt: skip


def _earlier(history: list[tuple[float, float]], t: float) -> tuple[float | None, float]:
    """The oldest (heading, seconds before ``t``) of a vehicle's recent headings other than the one at ``t``."""
    for when, heading in history:
        if when < t - 1e-9:
            return heading, t - when
    return None, 1.0


def states_of(scenario: Scenario, driven: Pass) -> dict[str, np.ndarray]:
    """The autopilot pass's rows as trajectory columns (t, states, controls)."""
    v = scenario.ocp.vehicle
    times = sorted(driven.states)
    cols = {"t": np.array(times)}
    for n in [*v.states, *v.controls]:
        cols[n] = np.array([driven.states[t][n] for t in times])
    return cols


def _record(traci, t: float, out: Pass) -> None:
    """Every vehicle but ``truck`` after a step: rectangle centre, heading (rad, ccw from +x), speed, size."""
    v = traci.vehicle
    decel = {}
    for vid in v.getIDList():
        if vid == "truck":
            continue
        (x, y), a, length = v.getPosition(vid), v.getAngle(vid), v.getLength(vid)
        heading = math.radians(90.0 - a)
        cx, cy = x - 0.5 * length * math.cos(heading), y - 0.5 * length * math.sin(heading)
        heading = math.atan2(math.sin(heading), math.cos(heading))
        out.rows.append((t, vid, v.getTypeID(vid), cx, cy, heading, v.getSpeed(vid), length, v.getWidth(vid)))
        out.time_loss[vid] = v.getTimeLoss(vid)
        decel[vid] = -v.getAcceleration(vid)
    out.braking[t] = decel


def reconstruct(scenario: Scenario, drive_pass: Pass) -> dict[str, np.ndarray]:
    """The model's states and controls from SUMO's front-bumper poses, as honestly as the poses allow.

    Position and heading of the first body: exact (rear axle = front bumper - front offset along
    the heading). Speed (the control, or the state v): SUMO's speed; with the speed a state its
    acceleration (and jerk) by finite differences. Steering angle: from the heading rate and the speed
    by the model's own kinematics at phi (phi = atan(d * dtheta/dt / v) for the car-like truck),
    by finite differences; its rate by finite differences. Each trailer's heading: the model's own
    dynamics integrated along the reconstructed tractor (the trailer SUMO's path would drag).
    """
    v = scenario.ocp.vehicle
    r = v.roles
    times = np.array(sorted(drive_pass.truck))
    poses = np.array([drive_pass.truck[t] for t in times])
    geo = truck_geometry(scenario)
    theta = np.unwrap(np.radians(90.0 - poses[:, 2]))
    cols = {
        "t": times,
        r.x: poses[:, 0] - geo["front"] * np.cos(theta),
        r.y: poses[:, 1] - geo["front"] * np.sin(theta),
    }
    cols[r.heading] = theta
    speed = poses[:, 3]
    cols[r.speed] = speed
    rate = np.gradient(theta, times) if len(times) > 1 else np.zeros(1)
    for name, of in ((r.acceleration, r.speed), (r.jerk, r.acceleration)):  # the speed a state: its rates
        if name is not None and r.speed in v.states:
            cols[name] = np.gradient(cols[of], times) if len(times) > 1 else np.zeros(1)
    if r.steering is not None:
        cols[r.steering] = _steering(v, rate, speed)
        cols[r.steering_rate] = np.gradient(cols[r.steering], times) if len(times) > 1 else np.zeros(1)
    elif r.turn_rate is not None:
        cols[r.turn_rate] = rate
    for c in v.controls:
        cols.setdefault(c, np.zeros(len(times)))
    _trailers(v, cols)
    return cols


def _steering(vehicle, rate: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """The steering angle whose heading rate at ``speed`` is ``rate``, solved on the model's own dynamics."""
    r = vehicle.roles
    f = vehicle.rhs_function()
    i_h, i_s = vehicle.states.index(r.heading), vehicle.states.index(r.steering)
    in_states = r.speed in vehicle.states  # with longitudinal dynamics the speed is the state v
    i_u = (vehicle.states if in_states else vehicle.controls).index(r.speed)
    grid = np.linspace(-1.2, 1.2, 2401)
    out = np.zeros(len(rate))
    for k, (w, u) in enumerate(zip(rate, speed, strict=True)):
        if u < 0.05:
            out[k] = out[k - 1] if k else 0.0
            continue
        x, c = np.zeros(len(vehicle.states)), np.zeros(len(vehicle.controls))
        (x if in_states else c)[i_u] = u
        rates = []
        for phi in grid:
            x[i_s] = phi
            rates.append(f(x, c)[i_h])
        out[k] = grid[int(np.argmin(np.abs(np.array(rates) - w)))]
    return out


def _trailers(vehicle, cols: dict[str, np.ndarray]) -> None:
    """Integrate each trailer heading along the reconstructed motion (midpoint rule), starting aligned."""
    trailers = vehicle.roles.trailers
    if not trailers:
        return
    f = vehicle.rhs_function()
    n = len(cols["t"])
    for s in trailers:
        cols[s] = np.zeros(n)
        cols[s][0] = cols[vehicle.roles.heading][0]
    idx = [vehicle.states.index(s) for s in trailers]

    def at(k: int) -> tuple[np.ndarray, np.ndarray]:
        return np.array([cols[s][k] for s in vehicle.states]), np.array([cols[c][k] for c in vehicle.controls])

    for k in range(n - 1):
        h = cols["t"][k + 1] - cols["t"][k]
        x, u = at(k)
        half = x.copy()
        half[idx] += 0.5 * h * f(x, u)[idx]
        x1, u1 = at(k + 1)
        mid = 0.5 * (x + x1)
        mid[idx] = half[idx]
        step = f(mid, 0.5 * (u + u1))[idx]
        for j, s in zip(idx, trailers, strict=True):
            cols[s][k + 1] = x[j] + h * step[trailers.index(s)]


__all__ = [
    "ARRIVE_GAP", "BRAKING_RADIUS", "Pass", "arrived", "autopilot_drive", "drive", "front_pose", "passed_goal",
    "reconstruct", "replay", "start_sumo", "states_of", "vtype_of", "write_sumo_files",
]  # fmt: skip
