"""The truck in traffic does what its recorded controls say (docs/traffic-format.md, issue 45).

Independent checks: each row of ``trajectory.csv`` (the states at t, the controls that act until
the next row), re-integrated over the step under its held controls with the vehicle's own dynamics
(scipy's ``solve_ivp``, not the project's integrator), reaches the next row to 1 mm; the first
row is at t = warmup. And SUMO's driver baseline drives a vType with the scenario's limits.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from model.cli import main
from model.problem.scenario import load_scenario
from model.vehicles import Truck
from model.vehicles.base import Roles, Vehicle, sym

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "traffic-roundabout.toml"
pytest.importorskip("traci")

WARMUP = 10.0


def short_scenario(folder: Path) -> Path:
    """The traffic example with a 10 s warmup and a 30 s time limit."""
    text = EXAMPLE.read_text().replace("warmup = 20.0", f"warmup = {WARMUP}").replace("time_limit = 60.0",
                                                                                       "time_limit = 30.0")
    path = folder / "short.toml"
    path.write_text(text)
    return path


def limited_scenario(folder: Path) -> Path:
    """``short_scenario`` at longitudinal limits (docs/dynamics-format.md): a in [-2.5, 1.3], v <= 8, at 5 m/s."""
    text = short_scenario(folder).read_text()
    text = text.replace("[bounds]\nu1 = [0.0, 8.0]\n", "[vehicle.longitudinal]\nacceleration = [-2.5, 1.3]\n\n"
                        "[bounds]\nv = [0.0, 8.0]\n").replace("[traffic]", "[initial]\nv = 5.0\n\n[traffic]")
    assert "[vehicle.longitudinal]" in text
    path = folder / "limited.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def limited_short(tmp_path_factory):
    folder = tmp_path_factory.mktemp("limited")
    scenario = limited_scenario(folder)
    code = main(["traffic", str(scenario), "--out", str(folder / "out"), "--driver", "autopilot"])
    return code, scenario, folder / "out"


@pytest.fixture(scope="module")
def autopilot_short(tmp_path_factory):
    folder = tmp_path_factory.mktemp("motion")
    scenario = short_scenario(folder)
    code = main(["traffic", str(scenario), "--out", str(folder / "out"), "--driver", "autopilot"])
    return code, scenario, folder / "out"


def re_integration_misses(scenario_path: Path, out: Path) -> np.ndarray:
    """Per step: the largest state difference between the next row and its row integrated under its controls."""
    vehicle = load_scenario(scenario_path).ocp.vehicle
    f = vehicle.rhs_function()
    rows = list(csv.DictReader((out / "trajectory.csv").open()))
    assert len(rows) > 10
    misses = []
    for a, b in zip(rows, rows[1:], strict=False):
        x0 = np.array([float(a[s]) for s in vehicle.states])
        u = np.array([float(a[c]) for c in vehicle.controls])
        sol = solve_ivp(lambda _, x, u=u: f(x, u), (float(a["t"]), float(b["t"])), x0, rtol=1e-10, atol=1e-12)
        assert sol.success
        x1 = np.array([float(b[s]) for s in vehicle.states])
        misses.append(float(np.max(np.abs(sol.y[:, -1] - x1))))
    return np.array(misses)


def test_each_row_under_its_held_controls_reaches_the_next_row(autopilot_short):
    code, scenario, out = autopilot_short
    misses = re_integration_misses(scenario, out)
    assert misses.max() <= 1e-3  # m (positions) and rad (angles)
    rows = list(csv.DictReader((out / "trajectory.csv").open()))
    assert float(rows[0]["t"]) == pytest.approx(WARMUP, abs=1e-9)
    assert np.allclose(np.diff([float(r["t"]) for r in rows]), 0.1)
    bounds = load_scenario(scenario).ocp.bounds
    for name in ("u1", "u2", "phi"):
        values = np.array([float(r[name]) for r in rows])
        assert bounds[name][0] - 1e-9 <= values.min() and values.max() <= bounds[name][1] + 1e-9, name


def test_the_held_control_motion_is_safe_and_replayable(autopilot_short, contract_replay):
    code, _, out = autopilot_short
    summary = json.loads((out / "summary.json").read_text())
    assert summary["arrived"] and code == 0
    assert summary["collisions"] == 0 and summary["min_distance"] >= 1.0  # safety_distance, exact rectangles
    assert summary["min_clearance"] >= 0.0  # every body in its corridor, on the integrated motion
    assert summary["tracking_error_max"] < 0.05  # m: where the plan wanted the truck, where it drove
    assert summary["sumo_vtype"]["source"] == "SUMO's defaults of the vClass"
    assert summary["longitudinal_limits"] is None
    contract_replay(out)


def wavy_reference(vehicle, speed: float = 6.0, seconds: float = 12.0):
    """A plan of ``vehicle`` (states x, y, theta, phi first) under a steering rate 0.3 sin(t), densely integrated."""
    from model.traffic.tracking import Reference

    f = vehicle.rhs_function()
    t = np.linspace(0.0, seconds, 1201)
    u2 = 0.3 * np.sin(t)
    x0 = np.zeros(len(vehicle.states))
    if "v" in vehicle.states:
        x0[vehicle.states.index("v")] = speed

    def rhs(time, x):
        return f(x, np.array([speed, 0.3 * math.sin(time)]) if "u1" in vehicle.controls else np.array([0.0, 0.3
                 * math.sin(time)]))  # fmt: skip

    sol = solve_ivp(rhs, (0.0, seconds), x0, t_eval=t, rtol=1e-10, atol=1e-12)
    cols = {s: sol.y[i] for i, s in enumerate(vehicle.states)}
    cols |= {c: (np.full_like(t, speed) if c == "u1" else u2 if c == "u2" else np.zeros_like(t))
             for c in vehicle.controls}  # fmt: skip
    return Reference(t, cols, vehicle.position)


def track(vehicle, bounds: dict, rates: np.ndarray, step: float = 0.1):
    """The tracker along ``wavy_reference`` with the progress rates ``rates``: the largest miss of the plan (m)."""
    from model.traffic.tracking import Tracker

    ref = wavy_reference(vehicle)
    tracker = Tracker(SimpleNamespace(vehicle=vehicle, bounds=bounds), ref)
    s, worst, controls, speeds = 0.0, 0.0, [], []
    for rate in rates:
        s = min(s + rate * step, float(ref.t[-1]))
        u = tracker.controls(s, rate, step)
        tracker.advance(u, step)
        aim, got = ref.at(s), tracker.state()
        worst = max(worst, math.hypot(got["x"] - aim["x"], got["y"] - aim["y"]))
        controls.append(u)
        if "v" in vehicle.states:  # the speed a state: the autopilot goes on from where the truck is
            s = tracker.locate()
            speeds.append((got["v"], rate * aim["v"]))
    return worst, np.array(controls), np.array(speeds)


RATES = np.concatenate([np.ones(20), np.linspace(1.0, 0.0, 20), np.zeros(5), np.linspace(0.0, 1.0, 20), np.ones(40)])


def test_the_tracker_holds_the_plan_at_any_pace():
    vehicle = Truck(wheelbase=5.0)
    bounds = {"u1": (0.0, 8.0), "u2": (-0.5, 0.5), "phi": (-0.6, 0.6)}
    worst, controls, _ = track(vehicle, bounds, RATES)
    assert worst < 0.01
    assert controls[:, 0].min() >= 0.0 and controls[:, 0].max() <= 8.0
    assert np.abs(controls[:, 1]).max() <= 0.5
    assert np.abs(controls[40:45, 0]).max() < 1e-3  # standing while the rate is 0


class Accelerating(Vehicle):  # the truck with v' = a (docs/dynamics-format.md's extended model)
    model = "accelerating-truck"
    states = ("x", "y", "theta", "phi", "v")
    controls = ("a", "u2")
    roles = Roles(speed="v", acceleration="a") if hasattr(Roles(), "acceleration") else Roles()

    def parameters(self) -> dict[str, float]:
        return {"d": 5.0}

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta, phi, v = self.state_symbols()
        a, u2 = self.control_symbols()
        return {"x": v * sp.cos(theta), "y": v * sp.sin(theta), "theta": v * sp.tan(phi) / sym("d"), "phi": u2,
                "v": a}  # fmt: skip

    @property
    def lateral_acceleration(self) -> sp.Expr:
        return sym("v") ** 2 * sp.tan(sym("phi")) / sym("d")


@pytest.mark.skipif(not hasattr(Roles(), "acceleration"), reason="Roles.acceleration not in this tree yet")
def test_the_speed_asked_for_keeps_the_lateral_acceleration_bound_along_the_path_ahead():
    """At 6 m/s the wavy plan's steering (up to 0.6 rad) would corner at 4.9 m/s^2: the bound 1.5 holds instead."""
    bounds = {"a": (-3.0, 2.0), "v": (0.0, 8.0), "u2": (-0.5, 0.5), "phi": (-0.6, 0.6),
              "lateral_acceleration": (-1.5, 1.5)}  # fmt: skip
    vehicle = Accelerating()
    from model.traffic.tracking import Tracker

    tracker = Tracker(SimpleNamespace(vehicle=vehicle, bounds=bounds), wavy_reference(vehicle))
    s, lateral = 0.0, []
    for _ in range(80):
        u = tracker.controls(s + 0.1, 1.0, 0.1)
        tracker.advance(u, 0.1)
        x = tracker.state()
        lateral.append(x["v"] ** 2 * math.tan(x["phi"]) / 5.0)
        s = tracker.locate()
    assert max(np.abs(lateral)) <= 1.5
    assert s > 2.0  # it drove on


@pytest.mark.skipif(not hasattr(Roles(), "acceleration"), reason="Roles.acceleration not in this tree yet")
def test_with_the_speed_a_state_the_tracker_commands_the_acceleration_within_its_bounds():
    bounds = {"a": (-3.0, 2.0), "v": (0.0, 8.0), "u2": (-0.5, 0.5), "phi": (-0.6, 0.6)}
    slow = np.concatenate([np.ones(20), np.linspace(1.0, 0.5, 20), np.full(20, 0.5), np.linspace(0.5, 1.0, 20)])
    worst, controls, speeds = track(Accelerating(), bounds, slow)
    assert controls[:, 0].min() >= -3.0 and controls[:, 0].max() <= 2.0
    assert np.abs(speeds[:, 0] - speeds[:, 1]).max() < 1e-6  # the speed asked for, reached within the bounds
    assert worst < 0.05  # m: where the truck is after a step, against where it was asked to be
    worst, controls, speeds = track(Accelerating(), bounds, RATES)  # 6 m/s to rest in 2 s: 3 m/s^2 asked
    assert controls[:, 0].min() >= -3.0 and controls[:, 0].max() <= 2.0 and speeds[:, 0].min() >= 0.0
    assert np.abs(speeds[:, 0] - speeds[:, 1]).max() > 0.1  # the bound binds: the truck lags the ask


@pytest.mark.skipif(not hasattr(Roles(), "acceleration"), reason="Roles.acceleration not in this tree yet")
def test_the_truck_vtype_takes_the_scenarios_longitudinal_limits():
    from model.traffic.network import truck_limits, truck_vtype

    ocp = SimpleNamespace(vehicle=SimpleNamespace(roles=Roles(speed="v", acceleration="a")),
                          bounds={"a": (-2.0, 1.0), "v": (0.0, 8.33)})  # fmt: skip
    limits = truck_limits(SimpleNamespace(ocp=ocp))
    assert limits == {"accel": 1.0, "decel": 2.0, "maxSpeed": 8.33}
    assert 'accel="1" decel="2" maxSpeed="8.33"' in truck_vtype("truck", 8.0, 2.5, limits)
    plain = SimpleNamespace(ocp=SimpleNamespace(vehicle=Truck(wheelbase=5.0), bounds={"u1": (0.0, 8.0)}))
    assert truck_limits(plain) is None


def test_sumos_driver_drives_the_vtype_it_is_given(tmp_path, monkeypatch):
    """SUMO's driver baseline with limits on its vType: SUMO runs them (read back over TraCI) and keeps them."""
    from model.traffic import cosim
    from model.traffic.sumo import find_sumo

    limits = {"accel": 0.8, "decel": 2.0, "maxSpeed": 7.0}
    monkeypatch.setattr(cosim, "truck_limits", lambda scenario: limits)
    scenario = load_scenario(short_scenario(tmp_path))
    sumo, folder = find_sumo(), tmp_path / "sumo"
    cosim.write_sumo_files(scenario, folder, sumo, 0)
    assert 'accel="0.8" decel="2" maxSpeed="7"' in (folder / "routes.rou.xml").read_text()
    driven = cosim.drive(scenario, sumo, folder)
    assert {k: driven.vtype[k] for k in limits} == pytest.approx(limits)
    assert (driven.vtype["length"], driven.vtype["width"]) == pytest.approx((8.0, 2.5))
    times = sorted(driven.truck)
    speeds = np.array([driven.truck[t][3] for t in times])
    assert speeds.max() <= 7.0 + 1e-9 and speeds.max() > 5.0
    assert np.diff(speeds).max() / 0.1 <= 0.8 + 1e-6


def test_at_longitudinal_limits_the_rows_follow_from_the_acceleration_within_the_bounds(limited_short):
    code, scenario, out = limited_short
    assert re_integration_misses(scenario, out).max() <= 1e-3
    rows = list(csv.DictReader((out / "trajectory.csv").open()))
    assert list(rows[0]) == ["t", "x", "y", "theta", "phi", "v", "a", "u2"]
    assert float(rows[0]["t"]) == pytest.approx(WARMUP, abs=1e-9) and float(rows[0]["v"]) == pytest.approx(5.0)
    v, a = (np.array([float(r[k]) for r in rows]) for k in ("v", "a"))
    assert v.min() >= -1e-9 and v.max() <= 8.0 + 1e-9
    assert a.min() >= -2.5 - 1e-9 and a.max() <= 1.3 + 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["arrived"] and summary["collisions"] == 0 and summary["min_distance"] >= 1.0 and code == 0
    assert summary["min_clearance"] >= 0.0
    assert summary["longitudinal_limits"] == {"acceleration": [-2.5, 1.3], "speed": [0.0, 8.0]}
    vtype = summary["sumo_vtype"]
    assert (vtype["accel"], vtype["decel"], vtype["maxSpeed"], vtype["source"]) == (1.3, 2.5, 8.0,
                                                                                   "the scenario's limits")
