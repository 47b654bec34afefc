"""The cooperative mode's announcement: the ring's conflict areas and the truck's occupancy windows."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from model.problem.scenario import load_scenario
from model.traffic.windows import conflict_areas, occupancy_windows

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ocp():
    return load_scenario(ROOT / "examples" / "traffic-roundabout.toml").ocp


def test_the_conflict_areas_cover_the_ring_roadway_once_each_around_its_leg(ocp):
    ra = ocp.road.roundabout
    areas = conflict_areas(ra)
    assert [a.leg for a in areas] == list(range(len(ra.legs)))
    annulus = math.pi * (ra.outer_radius**2 - ra.inner_radius**2)
    assert shapely.union_all([a.polygon for a in areas]).area == pytest.approx(annulus, rel=1e-3)
    assert sum(a.polygon.area for a in areas) == pytest.approx(annulus, rel=1e-3)  # no overlaps
    mid = (ra.outer_radius + ra.inner_radius) / 2
    for a, leg in zip(areas, ra.legs, strict=True):  # the leg's axis at mid-ring lies in its own area only
        point = shapely.Point(np.asarray(ra.center) + mid * leg.axis)
        assert [b.leg for b in areas if b.polygon.contains(point)] == [a.leg]


def test_a_truck_driving_in_along_its_leg_occupies_that_legs_area_from_its_front_reaching_the_curb(ocp):
    """Straight in along leg 0 (from 180 deg, heading +x) at 5 m/s: the window opens when the front bumper
    (6.5 m ahead of the rear axle) reaches the outer curb, x = -20 m, at t = (40 - 26.5) / 5 = 2.7 s."""
    step, speed = 0.1, 5.0

    def plan_at(s):
        s = np.atleast_1d(s)
        return {"x": -40.0 + speed * s, "y": 0 * s, "theta": 0 * s, "phi": 0 * s}

    windows = occupancy_windows(ocp, plan_at, duration=4.6, step=step)
    assert [w.leg for w in windows] == [0]
    assert 2.7 - 2 * step - 1e-9 <= windows[0].start <= 2.7 + 1e-9
    assert windows[0].end == pytest.approx(4.6)  # still in the ring roadway at the plan's end
    assert occupancy_windows(ocp, plan_at, duration=2.5, step=step) == []  # before the curb: no window


def test_the_windows_of_a_solved_straight_on_plan_follow_the_ring_in_its_direction(ocp):
    """The plan straight on from leg 0 (180 deg) to leg 2 (0 deg), right-hand traffic (counter-clockwise):
    its bodies enter leg 0's area first, then leg 1's (270 deg), then leg 2's, never leg 3's; the windows
    overlap where the truck spans two areas."""
    from model.traffic.autopilot import plan_of

    sol = ocp.solve(intervals=40)
    assert sol.ok
    plan = plan_of(sol, ocp.vehicle)
    windows = occupancy_windows(ocp, plan.at, plan.duration, step=0.1)
    assert [w.leg for w in windows] == [0, 1, 2]
    assert all(0.0 < w.start < w.end <= plan.duration for w in windows)
    assert windows[0].start < windows[1].start < windows[0].end  # the truck spans legs 0 and 1 for a while


def test_a_connected_vehicle_keeps_its_speed_unless_it_would_meet_the_truck_in_the_area():
    from model.traffic.cooperative import keep_clear_speed
    from model.traffic.windows import Window

    w = Window(leg=1, start=10.0, end=14.0)  # the truck in leg 1's area from 10 to 14 s
    kwargs = {"length": 15.0, "margin": 1.0, "max_speed": 13.9}
    assert keep_clear_speed(20.0, speed=10.0, now=5.0, window=w, **kwargs) is None  # out again at 8.5 s < 9 s
    assert keep_clear_speed(60.0, speed=5.0, now=5.0, window=w, **kwargs) is None  # arrives at 17 s > 15 s
    assert keep_clear_speed(-1.0, speed=10.0, now=9.5, window=w, **kwargs) is None  # already inside: drives on
    assert keep_clear_speed(30.0, speed=10.0, now=16.0, window=w, **kwargs) is None  # the window has closed
    v = keep_clear_speed(40.0, speed=10.0, now=5.0, window=w, **kwargs)  # would be in it from 9 to 10.5 s
    assert v == pytest.approx(40.0 / (15.0 - 5.0))  # reaches the area at 15 s, the window's end + margin
    assert 5.0 + 40.0 / v >= w.end + 1.0 - 1e-9


def test_connected_cars_keep_out_of_an_announced_area_in_sumo_and_drive_on_after(tmp_path, ocp):
    """SUMO's cars enter the ring at leg 1 (300 veh/h): with leg 1's area announced as the truck's from 25 to
    45 s, no car that was 30 m or more before the area at 25 s enters it before 45 s; afterwards they enter
    again and every speed command is released."""
    from model.problem.scenario import load_scenario
    from model.traffic.cooperative import Cooperator, area_entry, path_ahead
    from model.traffic.cosim import start_sumo, write_sumo_files
    from model.traffic.sumo import find_sumo
    from model.traffic.windows import Window

    scenario = load_scenario(ROOT / "examples" / "traffic-roundabout.toml")
    sumo = find_sumo()
    write_sumo_files(scenario, tmp_path, sumo, seed=0)

    def parked(s):  # a plan that never reaches the ring: its own windows are none; the test's window is set below
        s = np.atleast_1d(s)
        return {"x": -60.0 + 0 * s, "y": -2.0 + 0 * s, "theta": 0 * s, "phi": 0 * s}

    coop = Cooperator(scenario.ocp, parked, duration=60.0, step=0.1, margin=0.0)
    assert coop.windows == []
    coop.windows = [Window(leg=1, start=25.0, end=45.0)]  # plan time = clock time (s = now below)
    area = coop.areas[1]
    traci = start_sumo(sumo, tmp_path, "routes_without_truck.rou.xml")
    far, entered_late, entered_after = set(), set(), set()
    try:
        while (now := traci.simulation.getTime()) < 60.0:
            coop.step_traffic(traci, now, s=now)
            traci.simulationStep()
            for vid in traci.vehicle.getIDList():
                x, y = traci.vehicle.getPosition(vid)
                inside = area.contains(shapely.Point(x, y))
                path = path_ahead(traci, vid)
                if abs(now - 25.0) < 0.05 and path is not None and not inside:
                    entry = area_entry(path, area)
                    if entry is not None and entry[0] >= 30.0:
                        far.add(vid)
                if inside and vid in far and now < 45.0:
                    entered_late.add(vid)
                if inside and now > 45.0:
                    entered_after.add(vid)
        commanded = dict(coop.commanded)
    finally:
        traci.close()
    assert far and not entered_late
    assert far & entered_after  # released: the held cars go on
    assert not commanded  # after the window nothing is asked of anyone


def test_the_cooperative_driver_arrives_keeps_its_distance_and_reports_the_others_time_loss(tmp_path):
    """``roundabout traffic --driver cooperative``: the autopilot among connected cars held out of its windows."""
    import json

    from model.cli import main

    out = tmp_path / "coop"
    assert main(["traffic", str(ROOT / "examples" / "traffic-roundabout.toml"), "--out", str(out), "--driver",
                 "cooperative"]) == 0  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert summary["driver"] == "cooperative" and summary["arrived"] and summary["collisions"] == 0
    assert summary["min_distance"] >= 1.0  # the scenario's safety_distance, exact rectangles
    assert summary["others_time_loss"] >= 0.0 and "realtime_factor_cpu" in summary


def test_a_managed_run_is_replayed_from_dir_sumo_with_its_poses_and_speed_commands(tmp_path, contract_replay):
    """The contract's replay loop (conftest.py, apart from model.traffic) with commands.csv applied: traffic.csv.

    The reservation driver (first come, first served) on the example at 700 veh/h per leg sets speeds on the cars it
    refuses (at 300 veh/h it refuses none, and the cooperative driver asks only when the truck would wait)."""
    import csv

    from model.cli import main

    out, busy = tmp_path / "managed", tmp_path / "busy.toml"
    example = (ROOT / "examples" / "traffic-roundabout.toml").read_text()
    busy.write_text(example.replace("vehicles_per_hour = 300.0", "vehicles_per_hour = 700.0"))  # cars to refuse
    assert main(["traffic", str(busy), "--out", str(out), "--driver", "reservation"]) == 0
    commands: dict[float, dict[str, float]] = {}
    for r in csv.DictReader((out / "sumo" / "commands.csv").open()):
        commands.setdefault(round(float(r["t"]), 6), {})[r["id"]] = float(r["speed"])
    assert commands  # the cars were asked to keep clear at some steps (refused reservations)
    contract_replay(out, commands)
