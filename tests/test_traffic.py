"""roundabout traffic (docs/traffic-format.md): the keys, the SUMO network, a run of each driver and its replay."""

from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString

from model.cli import main
from model.errors import InputError
from model.problem.scenario import parse_scenario
from model.scene.roundabout import fillet_region, lane_region, ring_region

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "traffic-roundabout.toml"
sumolib = pytest.importorskip("sumolib")
pytest.importorskip("traci")


def document() -> dict:
    return tomllib.loads(EXAMPLE.read_text())


BAD = [
    (lambda d: d["traffic"]["flows"][0].update(leg=4), "traffic.flows[0].leg"),
    (lambda d: d["traffic"]["flows"][0].update(vehicles_per_hour=-1.0), "traffic.flows[0].vehicles_per_hour"),
    (lambda d: d["traffic"]["flows"][0].update(vehicles_per_hour=float("inf")), "traffic.flows[0].vehicles_per_hour"),
    (lambda d: d["traffic"]["flows"][1].update(exits=[0.5, 0.6, 0.0, 0.0]), "traffic.flows[1].exits"),
    (lambda d: d["traffic"]["flows"][1].update(exits=[1.2, -0.2, 0.0, 0.0]), "traffic.flows[1].exits"),
    (lambda d: d["traffic"]["flows"][0].update(exits=[0.5, 0.5]), "traffic.flows[0].exits"),
    (lambda d: d["traffic"]["flows"][0].update(type="tram"), "traffic.flows[0].type"),
    (lambda d: d["traffic"].update(step=0.0), "traffic.step"),
    (lambda d: d["traffic"].update(step=0.3), "traffic.step"),
    (lambda d: d["traffic"].update(colour=1), "traffic.colour"),
    (lambda d: d.pop("roundabout"), "roundabout"),
]


@pytest.mark.parametrize("edit,key", BAD, ids=[k for _, k in BAD])
def test_invalid_traffic_keys_name_the_key(edit, key):
    data = document()
    edit(data)
    with pytest.raises(InputError) as err:
        parse_scenario(data)
    assert err.value.key == key


def test_traffic_without_roundabout_or_route_is_refused():
    data = document()
    data.pop("roundabout"), data.pop("route")
    data["initial"] = {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}
    with pytest.raises(InputError) as err:
        parse_scenario(data)
    assert err.value.key == "traffic"


def test_the_example_parses():
    t = parse_scenario(document()).traffic
    assert (t.warmup, t.step, len(t.flows)) == (20.0, 0.1, 2)
    assert t.flows[0].exits == (0.25, 0.5, 0.25, 0.0)


def test_bad_input_exits_2_and_writes_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("step = 0.1", "step = 0.3"))
    assert main(["traffic", str(bad), "--out", str(tmp_path / "out"), "--driver", "sumo"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "traffic.step" in err[0]
    assert not (tmp_path / "out").exists()


def paved_area(roundabout):
    parts = [ring_region(roundabout).polygon]
    for i in range(len(roundabout.legs)):
        for lane in ("entry", "exit"):
            parts += [lane_region(roundabout, i, lane).polygon, fillet_region(roundabout, i, lane).polygon]
    return shapely.union_all(parts)


@pytest.mark.parametrize("traffic_side", ["right", "left"])
def test_every_lane_lies_in_the_paved_area(tmp_path, traffic_side):
    from model.traffic.network import write_network
    from model.traffic.sumo import find_sumo

    data = document()
    data["roundabout"]["traffic"] = traffic_side
    ra = parse_scenario(data).ocp.road.roundabout
    net = sumolib.net.readNet(str(write_network(ra, tmp_path, find_sumo().netconvert)), withInternal=True)
    paved = paved_area(ra)
    lanes = [lane for e in net.getEdges(withInternal=True) for lane in e.getLanes()]
    assert len(lanes) >= 3 * len(ra.legs)
    for lane in lanes:
        poly = LineString(lane.getShape()).buffer(lane.getWidth() / 2, cap_style="flat")
        outside = poly.difference(paved)
        worst = max((paved.distance(shapely.Point(p)) for p in shapely.get_coordinates(outside)), default=0.0)
        assert worst <= 0.5, (lane.getID(), worst)
    ring = [e for e in net.getEdges() if e.getID().startswith("ring")]
    # circulation: counter-clockwise under right-hand traffic, clockwise under left-hand
    a, b = np.array(ring[0].getShape()[0]), np.array(ring[0].getShape()[1])
    d = b - a
    assert np.sign(a[0] * d[1] - a[1] * d[0]) == (1 if traffic_side == "right" else -1)
    assert net.getRoundabouts(), "the ring is declared a roundabout"


def test_routes_follow_the_nth_exit():
    from model.traffic.network import route_edges

    ra = parse_scenario(document()).ocp.road.roundabout
    assert route_edges(ra, 0, 1) == ["in0", "ring0", "out1"]  # legs at 180, 270, 0, 90 degrees: ccw
    assert route_edges(ra, 0, 4) == ["in0", "ring0", "ring1", "ring2", "ring3", "out0"]


@pytest.fixture(scope="module")
def sumo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("traffic") / "run"
    code = main(["traffic", str(EXAMPLE), "--out", str(out), "--driver", "sumo"])
    return code, out


@pytest.fixture(scope="module")
def autopilot_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("traffic") / "autopilot"
    code = main(["traffic", str(EXAMPLE), "--out", str(out), "--driver", "autopilot"])
    return code, out


@pytest.fixture(params=["sumo", "autopilot"])
def any_run(request):
    return request.getfixturevalue(f"{request.param}_run")


def test_a_sumo_driver_run_writes_the_contract(sumo_run):
    code, out = sumo_run
    summary = json.loads((out / "summary.json").read_text())
    keys = ("driver arrived travel_time free_flow_time delay entry_wait collisions min_distance min_clearance "
            "max_braking_caused others_time_loss others_time_loss_without_truck energy solve_seconds_max "
            "realtime_factor sumo_version seed").split()  # fmt: skip
    assert set(keys) <= set(summary)
    assert summary["driver"] == "sumo" and summary["sumo_version"] == "1.28.0"
    assert code == (0 if summary["ok"] else 1)
    assert summary["arrived"] and summary["travel_time"] > 5.0
    assert summary["other_vehicles"] > 0
    rows = list(csv.DictReader((out / "traffic.csv").open()))
    assert rows and set(rows[0]) == {"t", "id", "type", "x", "y", "heading", "speed", "length", "width"}
    traj = list(csv.DictReader((out / "trajectory.csv").open()))
    assert float(traj[0]["t"]) == pytest.approx(20.0)
    assert list(traj[0]) == ["t", "x", "y", "theta", "phi", "u1", "u2"]
    for name in ("net.net.xml", "routes.rou.xml", "run.sumocfg"):
        assert (out / "sumo" / name).exists()
    assert 'id="truck"' in (out / "sumo" / "routes.rou.xml").read_text()
    assert 'depart="19.90"' in (out / "sumo" / "routes.rou.xml").read_text()


def test_the_replay_loop_reproduces_traffic_csv(any_run, contract_replay):
    """The contract's loop, written independently of model.traffic (conftest.py), on DIR/sumo and trajectory.csv:
    a run of SUMO's driver and one of the autopilot."""
    contract_replay(any_run[1])


def test_sumo_not_installed_exits_2_naming_the_package(tmp_path, capsys, monkeypatch):
    import importlib

    real = importlib.import_module

    def without_sumo(name, *args):
        if name == "sumo":
            raise ImportError(name)
        return real(name, *args)

    monkeypatch.setattr(importlib, "import_module", without_sumo)
    assert main(["traffic", str(EXAMPLE), "--out", str(tmp_path / "out"), "--driver", "sumo"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "eclipse-sumo" in err[0] and "pip install" in err[0]
    assert not (tmp_path / "out").exists()


def test_runs_write_runs_csv_and_the_means(tmp_path):
    data = (
        EXAMPLE.read_text().replace("time_limit = 60.0", "time_limit = 30.0").replace("warmup = 20.0", "warmup = 10.0")
    )
    scenario = tmp_path / "short.toml"
    scenario.write_text(data)
    out = tmp_path / "out"
    code = main(["traffic", str(scenario), "--out", str(out), "--driver", "sumo", "--runs", "2"])
    summary = json.loads((out / "summary.json").read_text())
    runs = list(csv.DictReader((out / "runs.csv").open()))
    assert [int(r["seed"]) for r in runs] == [0, 1]
    assert summary["runs"] == 2 and code == (0 if summary["ok"] else 1)
    assert summary["min_distance"] == pytest.approx(min(float(r["min_distance"]) for r in runs))
    loss = [float(r["others_time_loss"]) for r in runs]
    assert summary["others_time_loss"] == pytest.approx(np.mean(loss))
    assert (out / "run-1" / "sumo" / "run.sumocfg").read_text().count('<seed value="1"/>') == 1


def test_encounter_counts_an_overlap_and_measures_the_exact_distance():
    """A car 3 m beside the truck's side, then overlapping its front corner: distance and collision, exactly."""
    from model.traffic.cosim import Pass
    from model.traffic.run import encounter, other_corners

    scenario = parse_scenario(document())
    cols = {"t": np.array([20.0, 20.1]), "x": np.zeros(2), "y": np.zeros(2), "theta": np.zeros(2), "phi": np.zeros(2)}
    # truck body: x in [-1.5, 6.5], y in [-1.25, 1.25]; car 4 x 2 centred at (2, 1.25 + 3 + 1): gap 3 m
    beside = (20.0, "car", "passenger", 2.0, 5.25, 0.0, 5.0, 4.0, 2.0)
    corner = (20.1, "car", "passenger", 7.0, 1.5, math.pi / 2, 5.0, 4.0, 2.0)
    scored = Pass(rows=[beside, corner], braking={20.0: {"car": 6.0}, 20.1: {"car": 1.0}})
    got = encounter(scenario, cols, scored)
    assert got["collisions"] == 1
    assert got["min_distance"] < 0.0
    assert got["max_braking_caused"] == 6.0
    only_beside = encounter(scenario, cols, Pass(rows=[beside], braking={}))
    assert only_beside["min_distance"] == pytest.approx(3.0)
    assert shapely.Polygon(other_corners(corner)).area == pytest.approx(8.0)


def test_the_autopilot_gives_way_keeps_its_distance_and_arrives(autopilot_run):
    code, out = autopilot_run
    summary = json.loads((out / "summary.json").read_text())
    assert summary["driver"] == "autopilot" and summary["plan_valid"]
    assert summary["arrived"] and summary["collisions"] == 0 and code == 0
    assert summary["min_distance"] >= 1.0  # safety_distance of the example, exact rectangles
    assert summary["min_clearance"] >= 0.0  # the plan's path: every body in its corridor
    assert summary["travel_time"] >= summary["free_flow_time"] - 1e-9
    assert summary["free_flow_time"] == pytest.approx(summary["plan_final_time"], abs=0.25)
    assert 0 < summary["realtime_factor"] == pytest.approx(summary["solve_seconds_max"] / 0.1)
    # its size is measured in the benchmarks, not here (0.35-0.47 on 2 shared cores, 10.5 once under load)
    traj = list(csv.DictReader((out / "trajectory.csv").open()))
    speeds = np.array([float(r["u1"]) for r in traj])
    assert speeds.min() >= 0.0 and speeds.max() <= 8.0 + 1e-9  # the plan's speeds, scaled by the rate in [0, 1]


def test_the_autopilot_stands_before_the_line_when_a_car_circulates(tmp_path):
    """A car on the ring just upstream of the entry: the truck, at the line, must not enter (stand or stop)."""
    from model.problem.scenario import load_scenario
    from model.traffic.autopilot import Autopilot, Plan, predict

    scenario = load_scenario(EXAMPLE)
    ra = scenario.ocp.road.roundabout
    # a straight plan along the entry lane into the ring: x from -50 to -10 at y = -2, heading +x
    t = np.linspace(0.0, 5.0, 51)
    cols = {"x": -50.0 + 8.0 * t, "y": np.full_like(t, -2.0), "theta": np.zeros_like(t), "phi": np.zeros_like(t),
            "u1": np.full_like(t, 8.0), "u2": np.zeros_like(t)}  # fmt: skip
    pilot = Autopilot(scenario, Plan(t, cols), front=6.5)
    assert math.hypot(-50.0 + 8.0 * pilot.give_way + 6.5, -2.0) == pytest.approx(ra.outer_radius + 1.0, abs=0.05)
    pilot.s = pilot.give_way - 0.05
    pilot.rate = 0.2
    r = 17.0  # ring centre line; a car at 7 m/s counter-clockwise, 30 degrees before the entry (180 deg)
    a = math.radians(150.0)
    car = (0.0, "car", "passenger", r * math.cos(a), r * math.sin(a), a + math.pi / 2, 7.0, 4.5, 1.8)
    previous = a + math.pi / 2 - 7.0 / r * 0.1
    name, _ = pilot.decide([predict(car, previous, 0.1)], 0.1)
    assert name in ("approach", "stop at the line", "stand")  # each stops before the line
    assert pilot.s <= pilot.give_way
    free = Autopilot(scenario, Plan(t, cols), front=6.5)
    free.s, free.rate = pilot.give_way - 0.05, 0.2
    assert free.decide([], 0.1)[0] == "rate 1"


def straight_pilot():
    """The example's scenario with a straight plan along the entry lane into the ring (x -50 -> -10 at y = -2)."""
    from model.problem.scenario import load_scenario
    from model.traffic.autopilot import Autopilot, Plan

    scenario = load_scenario(EXAMPLE)
    t = np.linspace(0.0, 5.0, 51)
    cols = {"x": -50.0 + 8.0 * t, "y": np.full_like(t, -2.0), "theta": np.zeros_like(t), "phi": np.zeros_like(t),
            "u1": np.full_like(t, 8.0), "u2": np.zeros_like(t)}  # fmt: skip
    return Autopilot(scenario, Plan(t, cols), front=6.5)


def ring_car(degrees: float, speed: float = 7.0):
    """A car on the ring's centre line (r = 17) at ``degrees``, driving counter-clockwise, predicted."""
    from model.traffic.autopilot import predict

    r, a = 17.0, math.radians(degrees)
    row = (0.0, "car", "passenger", r * math.cos(a), r * math.sin(a), a + math.pi / 2, speed, 4.5, 1.8)
    return predict(row, a + math.pi / 2 - speed / r * 0.5, 0.5)


def test_a_circulating_car_is_predicted_along_the_ring_whatever_its_measured_yaw_rate():
    """A car on the ring's centre line measured with no yaw rate (SUMO's chords; traced: truck right 200
    seed 0, 0.04 rad/s at 7.1 m/s) is turned about the ring's centre: radius and heading to the tangent
    kept. Showing the exit side's signal 60 degrees before leg 3 it goes round to EXIT_TURN_ANGLE before
    that leg's axis, then out onto its exit lane (x = 2, heading north)."""
    from model.traffic.autopilot import EXIT_TURN_ANGLE, predict

    pilot = straight_pilot()
    tau = pilot.instants(0.1)
    a = math.radians(90.0)
    row = (0.0, "car", "passenger", 17.0 * math.cos(a), 17.0 * math.sin(a), a + math.pi / 2, 7.0, 4.5, 1.8)
    car = predict(row, a + math.pi / 2, 0.5)  # yaw rate 0
    assert pilot.circulates(car)
    x, y, h = pilot.expect(car, tau).pose(tau)
    angle = np.unwrap(np.arctan2(y, x))
    assert np.allclose(np.hypot(x, y), 17.0) and np.allclose(h - angle, math.pi / 2)
    assert angle[-1] - a == pytest.approx(7.0 * tau[-1] / 17.0)
    a = math.radians(30.0)
    row = (0.0, "car", "passenger", 17.0 * math.cos(a), 17.0 * math.sin(a), a + math.pi / 2, 7.0, 4.5, 1.8)
    x, y, h = pilot.expect(predict(row, a + math.pi / 2, 0.5), tau, exiting=True).pose(tau)
    round_ring = tau <= 17.0 * (math.radians(60.0) - EXIT_TURN_ANGLE) / 7.0
    assert np.allclose(np.hypot(x, y)[round_ring], 17.0) and not np.allclose(np.hypot(x, y), 17.0)
    assert x[-1] == pytest.approx(2.0, abs=0.3) and h[-1] == pytest.approx(math.pi / 2, abs=0.1) and y[-1] > 25.0


def test_a_car_leaving_the_ring_goes_straight_along_its_leg_and_no_prediction_circles():
    """Leaving by leg 2 (east) still curving at -1 rad/s (traced: semitrailer straight 200 seed 3, its
    circle came back over the truck's path 5 s ahead): straight on along the leg's axis. Any other
    constant yaw rate turns at most MAX_TURN, then goes straight."""
    from model.scene.moving import MovingVehicle
    from model.traffic.autopilot import MAX_TURN

    pilot = straight_pilot()
    tau = pilot.instants(0.1)
    leaving = MovingVehicle(4.5, 1.8, start=(22.0, -3.0, 0.4), speed=8.7, yaw_rate=-1.0)
    x, y, h = pilot.expect(leaving, tau).pose(tau)
    assert np.allclose(h, 0.0) and np.allclose(y, -3.0) and x[-1] == pytest.approx(22.0 + 8.7 * tau[-1])
    turning = MovingVehicle(4.5, 1.8, start=(0.0, -17.0, 1.0), speed=7.0, yaw_rate=1.0)  # 57 deg off the tangent
    assert not pilot.circulates(turning)
    x, y, h = pilot.expect(turning, tau).pose(tau)
    assert h.max() - 1.0 == pytest.approx(MAX_TURN) and np.all(np.diff(h) >= -1e-12)
    step = np.hypot(np.diff(x), np.diff(y)) / np.diff(tau)
    assert np.allclose(step, 7.0, rtol=0.02)  # its speed kept along the capped path


def test_a_car_turning_out_goes_onto_the_exit_lane_and_a_committed_entering_car_joins_the_ring():
    """Turning out by leg 0 (west) 20 degrees before its axis, 23 degrees outward of the tangent, with a
    small measured yaw rate (traced: truck right 700 seed 1, predicted straight over the entry lane beside
    the exit, where the truck stood): it ends on the exit lane's middle (y = +2), clear of the entry lane
    (y < 0). An entering car too fast to yield (leg 3, 9 m before the curb at 9.4 m/s; traced: truck
    straight 700 seed 1, predicted across the whole ring) drives to the ring lane's middle and round it."""
    from model.scene.moving import MovingVehicle
    from model.traffic.network import ring_radius

    pilot = straight_pilot()
    tau = pilot.instants(0.1)
    a = math.radians(160.0)
    out = MovingVehicle(4.5, 1.8, start=(17.0 * math.cos(a), 17.0 * math.sin(a), -2.2), speed=7.2, yaw_rate=-0.12)
    x, y, h = pilot.expect(out, tau).pose(tau)
    assert np.all(y >= 1.0) and y[-1] == pytest.approx(2.0, abs=0.3) and x[-1] < -40.0
    assert math.remainder(h[-1] - math.pi, 2 * math.pi) == pytest.approx(0.0, abs=0.1)
    committed = MovingVehicle(4.5, 1.8, start=(-2.0, 31.5, -math.pi / 2), speed=9.4)
    x, y, h = pilot.expect(committed, tau).pose(tau)
    r = np.hypot(x, y)
    radius = ring_radius(pilot.scenario.ocp.road.roundabout)
    assert r.min() == pytest.approx(radius, abs=1e-6) and np.allclose(r[r <= radius + 1e-6], radius)
    t_in = (31.5 - math.sqrt(radius**2 - 4.0)) / 9.4  # when it reaches the lane's middle
    turned = np.unwrap(np.arctan2(y, x))[-1] - math.atan2(math.sqrt(radius**2 - 4.0), -2.0)
    assert turned == pytest.approx(9.4 * (tau[-1] - t_in) / radius)  # counter-clockwise round the ring


def test_instants_after_the_truck_arrives_are_not_checked():
    """0.1 s before the plan's end a car comes from behind faster than the truck: parked at its goal in
    the prediction the truck would be hit 0.5 s ahead, but the run ends on arrival (traced: truck
    straight 450 seed 1, a 'stand' at 8 m/s in the exit for that, 1.1 s of delay): full pace."""
    from model.scene.moving import MovingVehicle
    from model.traffic.autopilot import PREDICTION_MARGIN

    pilot = straight_pilot()
    pilot.s, pilot.rate = pilot.plan.duration - 0.1, 1.0
    car = MovingVehicle(4.5, 1.8, start=(-17.55, -2.0, 0.0), speed=10.0)  # its front 3 m behind the truck's rear
    tau = pilot.instants(0.1)
    _, _, s = next(pilot.profiles(tau))
    gaps = pilot.clearances(s, pilot.predicted([car], tau))
    assert gaps[1] > 2.0 and gaps.min() < 0.0  # clear at the arrival, hit while parked after it
    assert pilot.net_gap(tau, s, gaps) == pytest.approx(gaps[1] - PREDICTION_MARGIN * tau[1])
    assert pilot.decide([car], 0.1)[0] == "rate 1" and pilot.s == pilot.plan.duration


@pytest.mark.parametrize("degrees,enters", [(140.0, False), (60.0, True)])
def test_the_truck_at_its_line_waits_for_a_car_in_its_window_and_enters_a_big_gap(degrees, enters):
    """Standing at the line: a car 40 degrees upstream crosses the truck's planned occupancy (wait);
    120 degrees upstream it comes after the truck's bodies have passed and, following the truck
    starting from standstill, brakes less than FOLLOWER_DECEL (enter at the plan's pace; 90 degrees
    upstream it would have to brake 9 m/s^2: the next test)."""
    pilot = straight_pilot()
    pilot.s, pilot.rate = pilot.give_way - 0.01, 0.0
    name, gap = pilot.decide([ring_car(degrees)], 0.1)
    assert (name == "rate 1") == enters
    if enters:
        assert gap >= 1.0 and pilot.rate > 0.0
    else:
        assert name in ("approach", "stop at the line", "stand") and pilot.s <= pilot.give_way  # it stays out


@pytest.mark.parametrize("rule", [True, False])
def test_an_entry_gap_clear_of_the_distance_that_makes_a_follower_brake_hard_is_refused(rule):
    """Standing at the line, a car on the ring 90 degrees upstream at 7 m/s: the gap keeps the safety
    distance (the truck's bodies pass first, least predicted distance > 3 m), but the car, following
    the truck that starts from standstill as SUMO's Krauss driver would, must brake 9 m/s^2 (its
    emergency braking; traced in truck right 450 seed 4, 9.0 m/s^2): the follower rule refuses the
    entry, the truck stays out. Without the rule it enters at the plan's pace."""
    from model.traffic.autopilot import FOLLOWER_DECEL, PREDICTION_MARGIN

    pilot = straight_pilot()
    pilot.follow_rule = rule
    pilot.s, pilot.rate = pilot.give_way - 0.01, 0.0
    car = ring_car(90.0)
    tau = pilot.instants(0.1)
    name, rates, s = next(pilot.profiles(tau))
    theirs = pilot.predicted([car], tau)
    assert name == "rate 1"
    assert np.min(pilot.clearances(s, theirs)[1:] - PREDICTION_MARGIN * tau[1:]) > 3.0  # clear of the distance
    rule_free = straight_pilot()
    assert rule_free.follower_braking(tau, rates, s, theirs) > FOLLOWER_DECEL  # the follower brakes hard
    name, _ = pilot.decide([car], 0.1)
    assert (name == "rate 1") != rule
    if rule:
        assert name in ("approach", "stop at the line", "stand") and pilot.s <= pilot.give_way


def test_a_car_signalling_its_exit_before_the_merge_point_is_no_follower():
    """SUMO's car shows its exit-side blinker ahead of its exit: 90 degrees upstream and signalling,
    it leaves before the merge point, so the gap of the previous test is taken; 30 degrees upstream
    (within EXIT_SIGNAL_MIN) the signal may mean the exit after the entry: it still follows."""
    from model.traffic.autopilot import EXIT_SIGNAL_MIN, FOLLOWER_DECEL

    pilot = straight_pilot()
    pilot.s, pilot.rate = pilot.give_way - 0.01, 0.0
    car = ring_car(90.0)
    assert pilot.decide([car], 0.1, frozenset({car.key}))[0] == "rate 1"
    near = straight_pilot()
    near.s, near.rate = near.give_way - 0.01, 0.0
    tau = near.instants(0.1)
    _, rates, s = next(near.profiles(tau))
    close = near.predicted([ring_car(150.0)], tau)  # its front 6.7 m (22 degrees) before the merge point
    assert near._ring_to_merge(close, 0.1)[0][0] < EXIT_SIGNAL_MIN
    assert near.follower_braking(tau, rates, s, close, np.array([True])) > FOLLOWER_DECEL


def test_the_follower_safe_speed_is_sumos_stop_speed():
    """SUMO's Euler stop speed: it stops within the gap after the 1 s headway braking at 4.5 m/s^2 a
    step, close to the continuous -b tau + sqrt(b^2 tau^2 + 2 b g); the follower of a truck braking at
    LEADER_DECEL adds its braking distance (traced 200 veh/h: gap 3.5 m at 6.7 m/s behind the truck
    at 8.45 m/s, SUMO's car braked 2.7, Krauss' original formula said 6.9)."""
    from model.traffic.autopilot import LEADER_DECEL, _safe_stop_speed

    for gap in (0.5, 3.0, 10.0, 40.0):
        v = _safe_stop_speed(gap, 4.5, 1.0, 0.1)
        assert v == pytest.approx(-4.5 + math.sqrt(4.5**2 + 9.0 * gap), abs=0.2)
        n = int(v / 0.45) + 1
        assert v * 1.0 + sum(max(v - 0.45 * k, 0.0) * 0.1 for k in range(1, n + 1)) <= gap + 0.5
    assert _safe_stop_speed(0.0, 4.5, 1.0, 0.1) == 0.0
    assert _safe_stop_speed(3.5 + 8.45**2 / (2 * LEADER_DECEL), 4.5, 1.0, 0.1) > 6.7  # no braking for the truck


def test_a_car_turning_out_or_past_the_merge_point_is_no_follower():
    """The follower rule counts only vehicles circulating toward the merge point: a car on the ring
    heading 60 degrees off the tangent (turning out) and one just past the merge point ask nothing."""
    from model.scene.moving import MovingVehicle

    pilot = straight_pilot()
    pilot.s, pilot.rate = pilot.give_way - 0.01, 0.0
    tau = pilot.instants(0.1)
    name, rates, s = next(pilot.profiles(tau))
    a = math.radians(90.0)
    out = MovingVehicle(4.5, 1.8, start=(17.0 * math.cos(a), 17.0 * math.sin(a), a + math.pi / 2 + math.radians(60.0)),
                        speed=7.0)  # fmt: skip
    assert pilot.follower_braking(tau, rates, s, pilot.predicted([out], tau)) == 0.0
    past = ring_car(200.0)  # 20 degrees past the entry's axis: the truck follows it, not it the truck
    assert pilot.follower_braking(tau, rates, s, pilot.predicted([past], tau)) == 0.0
    assert pilot.follower_braking(tau, rates, s, pilot.predicted([ring_car(90.0)], tau)) > 4.0


def test_the_approach_keeps_the_plan_pace_while_a_stop_at_the_line_stays_possible():
    """Far from the line with a conflict ahead: full pace ("approach"); too close to stop: it brakes."""
    pilot = straight_pilot()
    car = ring_car(120.0)  # arrives at the entry about when the truck would, at full pace
    pilot.s, pilot.rate = 0.5, 1.0
    tau = pilot.instants(0.1)
    name, _, s = next(pilot.profiles(tau))
    assert name == "rate 1" and pilot.least_distance(s, pilot.predicted([car], tau)) < 1.0  # a conflict ahead
    assert pilot.decide([car], 0.1)[0] == "approach" and pilot.rate == 1.0
    late = straight_pilot()
    late.s, late.rate = late.give_way - 0.3, 1.0  # 2.4 m before the line at 8 m/s: a stop at 4 m/s^2 needs 8 m
    name, _ = late.decide([ring_car(150.0)], 0.1)
    assert name == "stop at the line" and late.rate < 1.0 and late.s <= late.give_way


def test_a_truck_too_near_the_line_to_stop_by_it_gently_may_enter_a_little_slower():
    """2.5 m before the line at 8 m/s (a stop at RATE_SLOPE needs 8 m) behind a car at 4 m/s: the plan's
    pace closes on it within the horizon, a slower one does not. The truck enters at that pace instead of
    the stop at the line it took before (traced: truck right 700 seed 4, a one-step conflict 4.75 s ahead
    stopped the truck at the line from 8 m/s). Not below COMMITTED_RATE_MIN; farther out only at 1."""
    from model.scene.moving import MovingVehicle
    from model.traffic.autopilot import COMMITTED_RATE_MIN

    pilot = straight_pilot()
    pilot.s, pilot.rate = pilot.give_way - 2.5 / 8.0, 1.0
    car = MovingVehicle(4.5, 1.8, trajectory=((0.0, -12.0, -2.0, 0.0), (5.0, 8.0, -2.0, 0.0)))
    name, _ = pilot.decide([car], 0.1)
    assert name.startswith("rate ") and COMMITTED_RATE_MIN <= float(name[5:]) < 1.0 and pilot.rate < 1.0
    far = straight_pilot()
    far.s, far.rate = far.give_way - 12.0 / 8.0, 1.0  # 12 m before the line: a gentle stop is still possible
    names = [n for n, _, s in far.profiles(far.instants(0.1)) if s[-1] > far.give_way]
    assert names[0] == "rate 1" and not any(n.startswith("rate") for n in names[1:])


@pytest.mark.parametrize("gap,keeps_pace", [(1.005, False), (1.6, True), (1.3, True)])
def test_a_predicted_gap_within_the_prediction_margin_is_not_accepted(gap, keeps_pace):
    """A car just ahead at the truck's speed (8 m/s) on the test's straight plan into the ring.

    Given as its path (a straight line, which ``expect`` keeps as it is: a committed entering car given
    by its pose would be predicted round the ring lane, off the straight plan), it keeps ``gap`` at every
    instant. 1.005 m is within the predictions'
    error (PREDICTION_MARGIN per second ahead; traced in truck left 700 seed 0: predicted 1.0049 m one
    step ahead, 0.9962 m measured): the truck must not hold its pace. 1.6 m: it does. 1.3 m: it does
    too, the margin stopping growing at MARGIN_HORIZON (1 s: 1.1 m; growing over the whole horizon it
    asked 1.33 m where the plan ends 3.3 s ahead, and in truck left 450 seed 1 stopped the truck at
    its exit behind a car: 3.8 s of delay, 0.0 with the cap).
    """
    from model.scene.moving import MovingVehicle
    from model.traffic.autopilot import PREDICTION_MARGIN

    pilot = straight_pilot()
    car = MovingVehicle(4.5, 1.8, trajectory=((0.0, -27.25, -2.0, 0.0), (5.0, 12.75, -2.0, 0.0)))  # front x = -25
    pilot.s, pilot.rate = (-29.5 - gap - 6.5 + 50.0) / 8.0, 1.0  # the truck's front ``gap`` behind the car's rear
    tau = pilot.instants(0.1)
    gaps = pilot.clearances(next(pilot.profiles(tau))[2], pilot.predicted([car], tau))
    assert gaps.min() == pytest.approx(gap, abs=1e-6) and gaps.min() >= 1.0  # safe without the margin
    name, _ = pilot.decide([car], 0.1)
    assert (name == "rate 1") == keeps_pace
    assert (pilot.rate == 1.0) == keeps_pace
    assert PREDICTION_MARGIN * 0.1 > 1.005 - 1.0


def test_an_entering_car_that_can_stop_is_expected_to_yield_one_that_cannot_goes_on():
    """On leg 1's entry lane (x = 2, heading north): 20 m before the curb at 10 m/s it stops at the curb;
    3 m before it at 10 m/s (16.7 m/s^2 needed) it keeps its speed."""
    from model.scene.moving import MovingVehicle

    pilot = straight_pilot()
    tau = pilot.instants(0.1)
    far = MovingVehicle(4.5, 1.8, start=(2.0, -42.25, math.pi / 2), speed=10.0)  # front at r = 40
    stops = pilot.expect(far, tau)
    x, y, _ = stops.pose(tau)
    # it brakes along its heading for the distance from its front to the curb (radially), then stands
    assert y[-1] - y[0] == pytest.approx(math.hypot(2.0, 40.0) - 20.0, abs=1e-6)
    assert math.hypot(x[-1], y[-1] + 2.25) == pytest.approx(20.0, abs=0.06) and np.all(np.diff(y) >= -1e-12)
    assert y[-1] == pytest.approx(y[-2])
    close = MovingVehicle(4.5, 1.8, start=(2.0, -25.25, math.pi / 2), speed=10.0)
    x, y, _ = pilot.expect(close, tau).pose(tau)  # committed: on at its speed into the ring lane, then round it
    ahead = y <= -math.sqrt(17.0**2 - 4.0) + 1e-9
    assert np.allclose(x[ahead], 2.0) and np.allclose(np.diff(y[ahead]) / np.diff(tau[ahead]), 10.0)
    assert np.allclose(np.hypot(x, y)[~ahead], 17.0) and (~ahead).any()
    leaving = MovingVehicle(4.5, 1.8, start=(-2.0, -42.25, -math.pi / 2), speed=10.0)  # along its leg: straight on
    assert np.allclose(np.array(pilot.expect(leaving, tau).pose(tau)), np.array(leaving.pose(tau)))


def test_the_give_way_line_lies_before_the_junction_sumo_makes(tmp_path):
    """The line is where SUMO's entry lane ends (its internal junction lane begins there), not the curb."""
    from model.traffic.autopilot import LINE_SLACK, Autopilot
    from model.traffic.network import entry_end_radius, write_network
    from model.traffic.sumo import find_sumo

    pilot = straight_pilot()
    ra = pilot.scenario.ocp.road.roundabout
    net = write_network(ra, tmp_path, find_sumo().netconvert)
    r = entry_end_radius(net, ra, 0)
    assert ra.outer_radius + 1.0 < r < ra.outer_radius + ra.legs[0].length
    internal = [lane for lane in sumolib.net.readNet(str(net), withInternal=True).getEdge("in0").getLanes()[0]
                .getOutgoing()]  # fmt: skip
    start = internal[0].getViaLaneID()
    x, y = sumolib.net.readNet(str(net), withInternal=True).getLane(start).getShape()[0]
    assert math.hypot(x, y) == pytest.approx(r, abs=1e-3)
    lined = Autopilot(pilot.scenario, pilot.plan, front=6.5, line_radius=r + LINE_SLACK)
    front = -50.0 + 8.0 * lined.give_way + 6.5  # the straight plan's front bumper at the line (y = -2)
    assert math.hypot(front, -2.0) == pytest.approx(r + LINE_SLACK, abs=0.05)
    assert lined.give_way < pilot.give_way


def test_export_sumo_writes_a_config_that_sumo_runs(tmp_path):
    import subprocess

    from model.traffic.sumo import find_sumo

    out = tmp_path / "export"
    assert main(["export-sumo", str(EXAMPLE), "--out", str(out)]) == 0
    for name in ("net.net.xml", "routes.rou.xml", "run.sumocfg"):
        assert (out / name).exists()
    done = subprocess.run([find_sumo().sumo, "-c", str(out / "run.sumocfg"), "--end", "30"], capture_output=True)
    assert done.returncode == 0, done.stderr
    net = sumolib.net.readNet(str(out / "net.net.xml"))
    x0, y0, _, _ = net.getBoundary()
    assert x0 < -50.0 and y0 < -50.0  # the scenario's coordinates, not shifted to the origin


def test_left_hand_traffic_a_sumo_run_arrives_by_its_exit(tmp_path):
    scenario = tmp_path / "left.toml"
    text = EXAMPLE.read_text().replace('traffic = "right"', 'traffic = "left"')
    text = text.replace("warmup = 20.0", "warmup = 10.0").replace("time_limit = 60.0", "time_limit = 30.0")
    scenario.write_text(text)
    out = tmp_path / "out"
    main(["traffic", str(scenario), "--out", str(out), "--driver", "sumo"])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["arrived"] and summary["exit_taken"] == 2
    traj = list(csv.DictReader((out / "trajectory.csv").open()))
    assert float(traj[0]["y"]) == pytest.approx(2.0)  # left-hand: the entry lane of the leg at 180 deg is at y > 0


def test_the_truck_moved_along_its_plan_stays_on_its_route_lanes(tmp_path):
    """Replayed by the contract's loop (keepRoute=2), the right-turn plan is never put on a lane off its route.

    With the ring lane as wide as the ring roadway (6 m against the exit's 4 m) SUMO put the truck,
    cutting the exit corner near the outer curb, on the ring's internal lane beside the exit's for
    0.4 s (``:r1_2_0``, route rewritten to ring0 ring1): a "circulating" truck for the car entering
    from the exit leg, which braked at 9 m/s^2 (benchmarks/traffic.md).
    """
    import xml.etree.ElementTree as ET

    from model.traffic.autopilot import plan_of
    from model.traffic.cosim import autopilot_drive, start_sumo, write_sumo_files
    from model.traffic.run import solve_plan
    from model.traffic.sumo import find_sumo

    data = document()
    data["route"]["exit"] = 1
    scenario = parse_scenario(data)
    sumo = find_sumo()
    write_sumo_files(scenario, tmp_path, sumo, 0)
    sol, _ = solve_plan(scenario)
    assert sol.ok
    free = "routes_free_flow.rou.xml"
    poses = autopilot_drive(scenario, sumo, tmp_path, plan_of(sol, scenario.ocp.vehicle), routes=free).truck
    root = ET.parse(tmp_path / "net.net.xml").getroot()
    traci = start_sumo(sumo, tmp_path, free)
    lanes, allowed = [], None
    try:
        while traci.simulation.getTime() < max(poses) - 1e-9:
            t_next = round(traci.simulation.getTime() + scenario.traffic.step, 6)
            if t_next in poses and "truck" in traci.vehicle.getIDList():
                if allowed is None:
                    route = traci.vehicle.getRoute("truck")
                    pairs = zip(route[:-1], route[1:], strict=True)
                    vias = {root.find(f"connection[@from='{a}'][@to='{b}']").get("via") for a, b in pairs}
                    allowed = {f"{e}_0" for e in route} | vias
                x, y, a = poses[t_next][:3]
                traci.vehicle.moveToXY("truck", "", -1, x, y, a, keepRoute=2)
            traci.simulationStep()
            if allowed is not None and "truck" in traci.vehicle.getIDList():
                lanes.append(traci.vehicle.getLaneID("truck"))
    finally:
        traci.close()
    assert ":r1_1_0" in lanes and "out1_0" in lanes, "the truck left by its exit's internal lane"
    assert set(lanes) <= allowed, sorted(set(lanes) - allowed)


def _replayed_lanes(scenario, folder: Path, poses: dict) -> tuple[list[str], set[str]]:
    """The truck's lane after each ``moveToXY(keepRoute=2)`` of ``poses`` (truck alone), and its route's lanes."""
    import xml.etree.ElementTree as ET

    from model.traffic.cosim import start_sumo
    from model.traffic.sumo import find_sumo

    root = ET.parse(folder / "net.net.xml").getroot()
    traci = start_sumo(find_sumo(), folder, "routes_free_flow.rou.xml")
    lanes, allowed = [], set()
    try:
        while traci.simulation.getTime() < max(poses) - 1e-9:
            t_next = round(traci.simulation.getTime() + scenario.traffic.step, 6)
            if t_next in poses and "truck" in traci.vehicle.getIDList():
                if not allowed:
                    route = traci.vehicle.getRoute("truck")
                    pairs = zip(route[:-1], route[1:], strict=True)
                    vias = {root.find(f"connection[@from='{a}'][@to='{b}']").get("via") for a, b in pairs}
                    allowed = {f"{e}_0" for e in route} | vias
                traci.vehicle.moveToXY("truck", "", -1, *poses[t_next], keepRoute=2)
            traci.simulationStep()
            if allowed and "truck" in traci.vehicle.getIDList():
                lanes.append(traci.vehicle.getLaneID("truck"))
    finally:
        traci.close()
    return lanes, allowed


def test_the_semitrailer_at_its_entry_merge_stays_on_its_route_lanes(tmp_path, monkeypatch):
    """The recorded poses of semitrailer right 450 veh/h seed 4 (the bench's cell) stay on the route's lanes.

    With netconvert's default internal-link detail (5) SUMO mapped the semitrailer's front, at the
    merge of its entry's internal lane ``:r0_2_0`` with the ring's ``:r0_1_0``, onto the ring's
    (t = 28.7 s; a ring car braked at 9 m/s^2, benchmarks/traffic.md round 3); with
    ``INTERNAL_LINK_DETAIL`` (20) it is not. Fixture: benchmarks/traffic/record_poses.py.
    """
    from benchmarks.bench_traffic import document as cell
    from model.traffic import network
    from model.traffic.cosim import write_sumo_files
    from model.traffic.sumo import find_sumo

    fixture = ROOT / "tests" / "data" / "traffic" / "semitrailer-right-450-seed4.csv"
    rows = np.loadtxt(fixture, delimiter=",", skiprows=1)
    poses = {round(float(r[0]), 6): tuple(map(float, r[1:])) for r in rows}
    scenario = parse_scenario(cell("semitrailer", "right", 450.0))
    write_sumo_files(scenario, tmp_path / "now", find_sumo(), 4)
    lanes, allowed = _replayed_lanes(scenario, tmp_path / "now", poses)
    assert ":r0_2_0" in lanes and "out1_0" in lanes, "the truck entered by its entry's internal lane and left"
    assert set(lanes) <= allowed, sorted(set(lanes) - allowed)
    monkeypatch.setattr(network, "INTERNAL_LINK_DETAIL", 5)  # netconvert's default: the step off the route
    write_sumo_files(scenario, tmp_path / "default", find_sumo(), 4)
    lanes, allowed = _replayed_lanes(scenario, tmp_path / "default", poses)
    assert not set(lanes) <= allowed, "the fixture no longer shows the mapping off the route"
