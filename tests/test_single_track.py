"""The single-track plant (docs/closed-loop-format.md, "A plant that is not the planning model").

CommonRoad's ``vehicle_dynamics_st`` (commonroad-vehicle-models 3.0.2) is the reference the plant's
equations match; the plant follows the kinematic truck at low speed and small steering and departs
from it as the speed grows; ``roundabout simulate`` with ``[plant] model = "single-track"`` reports
the mismatch; bad ``[plant]`` keys exit 2 with one line.
"""

from __future__ import annotations

import copy
import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from model.cli import main
from model.errors import InputError
from model.problem.closed_loop import Disturbance
from model.problem.scenario import load_scenario
from model.simulation.plant import Plant
from model.simulation.single_track import (
    DEFAULT_LR_SHARE,
    GRAVITY,
    SingleTrackParameters,
    SingleTrackPlant,
    path_distance,
    single_track_parameters,
    single_track_rhs,
)
from model.simulation.tractor_semitrailer import ArticulatedParameters, TractorSemitrailerPlant, articulated_rhs
from model.vehicles import TractorTrailer, Tricycle, Truck
from tests.conftest import ROOT

vehiclemodels = pytest.importorskip("vehiclemodels")
from vehiclemodels.parameters_vehicle2 import parameters_vehicle2  # noqa: E402
from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st  # noqa: E402

TRUCK = ROOT / "examples" / "closed-loop-truck.toml"


def commonroad_pair(p: SingleTrackParameters | None = None):
    """CommonRoad's parameters (BMW 320i, vehicle 2) and ours at the same numbers; with ``p``, ours
    copied into CommonRoad's (which has one cornering stiffness for both axles, so cf = cr)."""
    cr = copy.deepcopy(parameters_vehicle2())
    if p is not None:
        assert p.cf == p.cr
        cr.m, cr.I_z, cr.a, cr.b, cr.h_s = p.mass, p.yaw_inertia, p.lf, p.lr, p.h_cg
        cr.tire.p_dy1, cr.tire.p_ky1 = p.mu, -p.cf
    ours = SingleTrackParameters(
        mass=cr.m, yaw_inertia=cr.I_z, lf=cr.a, lr=cr.b, cf=-cr.tire.p_ky1, cr=-cr.tire.p_ky1, h_cg=cr.h_s,
        mu=cr.tire.p_dy1,
    )  # fmt: skip
    return cr, ours


def truck_defaults_equal_axles() -> SingleTrackParameters:
    p = single_track_parameters(Truck(wheelbase=5.0), Disturbance(), {})
    return SingleTrackParameters(**{**p.__dict__, "cr": p.cf})


@pytest.mark.parametrize("which", ["bmw", "truck"])
@pytest.mark.parametrize("branch", ["dynamic", "low-speed"])
def test_rhs_matches_commonroad_vehicle_dynamics_st(which, branch):
    """Identical parameters and states, inputs within CommonRoad's limits (so its input constraints
    are idle): the derivatives agree to 1e-9 (relative to max(1, |f|)) in both of its branches."""
    cr, ours = commonroad_pair(None if which == "bmw" else truck_defaults_equal_axles())
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(500):
        v = rng.uniform(0.1, 30.0) if branch == "dynamic" else rng.uniform(-0.0999, 0.0999)
        x = [*rng.uniform(-50, 50, 2), rng.uniform(-0.9, 0.9), v, rng.uniform(-4, 4), rng.uniform(-1, 1),
             rng.uniform(-0.3, 0.3)]  # fmt: skip
        u = [rng.uniform(-0.39, 0.39), rng.uniform(-2.5, 2.5)]  # BMW: |steering velocity| <= 0.4, a <= 2.8 at 30 m/s
        ref = np.array(vehicle_dynamics_st(x, u, cr), dtype=float)
        got = np.array(single_track_rhs(x, u[0], u[1], ours))
        worst = max(worst, float(np.max(np.abs(got - ref) / np.maximum(1.0, np.abs(ref)))))
    assert worst <= 1e-9


def test_reverse_uses_the_kinematic_branch_where_commonroad_diverges():
    """CommonRoad keeps the dynamic equations for v <= -0.1 m/s, where they diverge; the plant does not."""
    cr, ours = commonroad_pair(truck_defaults_equal_axles())
    x = [0.0, 0.0, 0.3, -1.0, 0.0, -0.06, 0.11]
    ref = np.array(vehicle_dynamics_st(x, [0.0, 0.0], cr))
    got = np.array(single_track_rhs(x, 0.0, 0.0, ours))
    assert abs(ref[6]) > 100 * abs(got[6])  # CommonRoad's slip rate: hundreds of rad/s
    plant = SingleTrackPlant(Truck(wheelbase=5.0), Disturbance(), 0.1, {})
    z = plant.start(np.array([0.0, 0.0, 0.0, 0.3]), speed=-1.0)
    for _ in range(20):
        z = plant.step(z, np.array([-1.0, 0.0]))
    kin = Plant(Truck(wheelbase=5.0), Disturbance(), 0.1)
    x = np.array([0.0, 0.0, 0.0, 0.3])
    for _ in range(20):
        x = kin.step(x, np.array([-1.0, 0.0]))
    assert np.all(np.isfinite(z)) and np.hypot(*(plant.state(z)[:2] - x[:2])) < 1e-6


def test_understeer_of_the_front_and_rear_cornering_coefficients():
    """Steady cornering at 10 m/s, delta = 0.02 rad: the yaw rate is v delta / (L + K v^2) with the
    linear single-track model's understeer gradient K = (1/cf - 1/cr) / g (front and rear in their places)."""
    p = single_track_parameters(Truck(wheelbase=5.0), Disturbance(), {})
    assert p.cf < p.cr  # the defaults understeer
    plant = SingleTrackPlant(Truck(wheelbase=5.0), Disturbance(), 1.0, {})
    v, delta = 10.0, 0.02
    z = plant.start(np.array([0.0, 0.0, 0.0, delta]), speed=v)
    for _ in range(30):
        z = plant.step(z, np.array([v, 0.0]))
    understeer = (1 / p.cf - 1 / p.cr) / GRAVITY
    assert z[3] * math.cos(z[6]) == pytest.approx(v, rel=1e-9)  # the speed law holds the rear speed
    assert z[5] == pytest.approx(z[3] * delta / (p.wheelbase + understeer * z[3] ** 2), rel=1e-8)
    assert z[5] < 0.97 * v * math.tan(delta) / p.wheelbase  # 4 % below the kinematic truck's: understeer


def drive(vehicle, speed: float, steer: float, distance: float = 40.0, h: float = 0.1):
    """The kinematic plant and the single-track plant under the same controls: steer to ``steer`` in 2 s,
    hold it, steer back half way along ``distance`` m; both start at ``speed``. Returns both position tracks
    and the largest |beta|."""
    kin, st = Plant(vehicle, Disturbance(), h), SingleTrackPlant(vehicle, Disturbance(), h, {})
    x = np.zeros(4)
    z = st.start(x, speed=speed)
    end = distance / speed
    kin_xy, st_xy, beta = [x[:2]], [st.state(z)[:2]], 0.0
    for k in range(int(round(end / h))):
        t = k * h
        rate = steer / 2.0 if t < 2.0 else (-steer / 2.0 if end / 2 <= t < end / 2 + 2.0 else 0.0)
        u = np.array([speed, rate])
        x, z = kin.step(x, u), st.step(z, u)
        kin_xy.append(x[:2])
        st_xy.append(st.state(z)[:2])
        beta = max(beta, abs(z[6]))
    return np.array(kin_xy), np.array(st_xy), beta


@pytest.mark.parametrize("model", [Truck, Tricycle])
def test_low_speed_small_steering_follows_the_kinematic_model(model):
    """40 m at 1 m/s steering to 0.05 rad and back (wheelbase 5 m, the default truck numbers): the two
    plants stay within 3 cm of each other at equal times (measured 1.2 cm for the truck); at 8 m/s the
    same manoeuvre parts them by over 0.3 m (measured 0.45 m): the tyres' slip is what the plant adds."""
    slow_kin, slow_st, slow_beta = drive(model(wheelbase=5.0), 1.0, 0.05)
    fast_kin, fast_st, _ = drive(model(wheelbase=5.0), 8.0, 0.05)
    slow = float(np.max(np.hypot(*(slow_st - slow_kin).T)))
    fast = float(np.max(np.hypot(*(fast_st - fast_kin).T)))
    assert slow < 0.03
    assert fast > 0.3 and fast > 10 * slow
    assert slow_beta == pytest.approx(math.atan(math.tan(0.05) * DEFAULT_LR_SHARE), rel=0.05)  # kinematic CoG slip
    assert float(np.max(path_distance(slow_st, slow_kin))) <= slow


def test_state_round_trip_and_rear_axle_reference():
    """start then state gives back the kinematic state; the centre of gravity lies lr ahead of the rear axle."""
    plant = SingleTrackPlant(Truck(wheelbase=5.0), Disturbance(), 0.1, {"lr": 2.0})
    x = np.array([3.0, -1.0, 0.7, -0.2])
    z = plant.start(x, speed=4.0)
    assert np.allclose(plant.state(z), x, atol=1e-12)
    assert np.allclose(z[:2], [3.0 + 2.0 * math.cos(0.7), -1.0 + 2.0 * math.sin(0.7)], atol=1e-12)
    assert z[3] * math.cos(z[6]) == pytest.approx(4.0)


def test_longitudinal_models_take_the_acceleration_and_measure_the_speed():
    """With [vehicle.longitudinal] the control a is the plant's acceleration and the state v is measured."""
    vehicles = pytest.importorskip("model.vehicles")
    longitudinal = getattr(vehicles, "Longitudinal", None)
    if longitudinal is None:
        pytest.skip("model.vehicles.Longitudinal not available")
    for jerk in (False, True):
        v = longitudinal(Truck(wheelbase=5.0), jerk=jerk)
        plant = SingleTrackPlant(v, Disturbance(), 0.5, {})
        x = np.array([0.0, 0.0, 0.0, 0.0, 2.0, *([0.5] if jerk else [])])
        z = plant.start(x)
        assert np.allclose(plant.state(z), x, atol=1e-12)
        z = plant.step(z, np.array([0.5 if not jerk else 0.0, 0.0]))  # a = 0.5 m/s^2 for 0.5 s
        assert plant.state(z)[4] == pytest.approx(2.25, abs=1e-9)


def read_csv(path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def small_scenario(tmp_path, plant: str = '[plant]\nmodel = "single-track"\n', final_time: float = 20.0):
    """The example's right turn at d = 5 m without the kinematic disturbances, in ``final_time`` s on 30 intervals."""
    text = TRUCK.read_text()
    text = text[: text.index("[disturbance]")] + "[control]\nsample_time = 0.1\n\n" + plant
    text = text.replace("final_time = 7.0", f"final_time = {final_time}").replace("intervals = 60", "intervals = 30")
    path = tmp_path / "st.toml"
    path.write_text(text)
    return path


def test_simulate_tracking_reports_the_mismatch(tmp_path):
    """``roundabout simulate --controller tracking`` on the single-track plant writes the summary's
    ``plant`` table: the lateral deviation from the plan, the side slip, the friction use, the bodies'
    clearance; the kinematic plant of the same scenario (``--plant kinematic``) has no such table."""
    scenario = small_scenario(tmp_path)
    res = subprocess.run([sys.executable, "-m", "model.cli", "simulate", scenario, "--out", tmp_path / "st",
                          "--controller", "tracking", "--quiet"], capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    assert res.returncode in (0, 1), res.stderr
    summary = json.loads((tmp_path / "st" / "summary.json").read_text())
    plant = summary["plant"]
    assert plant["model"] == "single-track"
    cols = read_csv(tmp_path / "st" / "closed_loop.csv")
    assert plant["max_side_slip"] == pytest.approx(float(np.max(np.abs(cols["plant_beta"]))))
    assert 0.0 < plant["max_side_slip"] < 0.5
    optimum = read_csv(tmp_path / "st" / "optimum" / "trajectory.csv")
    deviation = path_distance(np.column_stack([cols["x"], cols["y"]]), np.column_stack([optimum["x"], optimum["y"]]))
    assert plant["max_lateral_deviation"] == pytest.approx(float(np.max(deviation)))
    assert 0.0 < plant["max_lateral_deviation"] < 2.0
    assert plant["min_clearance"] == summary["min_clearance"] and plant["parameters"]["lf"] + plant["parameters"][
        "lr"] == pytest.approx(5.0)  # fmt: skip
    assert main(["simulate", str(scenario), "--out", str(tmp_path / "kin"), "--controller", "tracking", "--quiet",
                 "--plant", "kinematic"]) == 0  # fmt: skip
    kinematic = json.loads((tmp_path / "kin" / "summary.json").read_text())
    assert "plant" not in kinematic and "plant_beta" not in read_csv(tmp_path / "kin" / "closed_loop.csv")
    assert kinematic["final_position_error"] < summary["final_position_error"]


def test_runs_report_the_worst_mismatch(tmp_path):
    """With --runs 2 and measurement noise, the summary's ``plant`` holds the larger lateral deviation of the two."""
    scenario = small_scenario(tmp_path, '[disturbance]\nnoise = 0.05\n[plant]\nmodel = "single-track"\n')
    code = main(["simulate", str(scenario), "--out", str(tmp_path / "runs"), "--controller", "tracking", "--quiet",
                 "--runs", "2"])  # fmt: skip
    assert code in (0, 1)
    summary = json.loads((tmp_path / "runs" / "summary.json").read_text())
    cols = read_csv(tmp_path / "runs" / "closed_loop.csv")  # the first run's
    optimum = read_csv(tmp_path / "runs" / "optimum" / "trajectory.csv")
    first = path_distance(np.column_stack([cols["x"], cols["y"]]), np.column_stack([optimum["x"], optimum["y"]]))
    assert summary["runs"] == 2 and summary["plant"]["max_lateral_deviation"] >= float(np.max(first))
    assert summary["plant"]["min_clearance"] == summary["min_clearance"]


BAD = {
    "unknown key": ('[plant]\nmodel = "single-track"\nmas = 1.0\n', "plant.mas"),
    "model": ('[plant]\nmodel = "dynamic"\n', "plant.model"),
    "negative mass": ('[plant]\nmodel = "single-track"\nmass = -1.0\n', "plant.mass"),
    "not a number": ('[plant]\nmodel = "single-track"\nyaw_inertia = "big"\n', "plant.yaw_inertia"),
    "kinematic with numbers": ('[plant]\nmass = 9000.0\n', "plant.mass"),
    "axles": ('[plant]\nmodel = "single-track"\ncg_to_front_axle = 3.0\ncg_to_rear_axle = 3.0\n',
              "plant.cg_to_rear_axle"),
    "axle too long": ('[plant]\nmodel = "single-track"\ncg_to_front_axle = 5.0\n', "plant.cg_to_front_axle"),
    "limits": ('[plant]\nmodel = "single-track"\nacceleration_limits = [1.0, 2.0]\n', "plant.acceleration_limits"),
    "kinematic disturbance": ('[disturbance]\nspeed_gain = 0.9\n[plant]\nmodel = "single-track"\n',
                              "disturbance.speed_gain"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_plant_keys_exit_2_with_one_line(tmp_path, capsys, case):
    table, key = BAD[case]
    scenario = small_scenario(tmp_path, table)
    assert main(["simulate", str(scenario), "--out", str(tmp_path / "out"), "--controller", "tracking"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"roundabout: invalid input: {key}")
    assert not (tmp_path / "out").exists()


def test_models_the_single_track_plant_refuses(tmp_path, capsys):
    """A --plant that is not a model, the example's kinematic disturbances under ``--plant single-track``: exit 2
    with one line naming the key; the unicycle (no steering angle) is refused naming plant.model, the trailer's
    numbers on a truck, load transfer and a trailer centre of gravity beyond its axle on the tractor-trailer."""
    for path, key, model in ((small_scenario(tmp_path, ""), "--plant", "bogus"),
                             (TRUCK, "disturbance.speed_gain", "single-track")):  # fmt: skip
        out = tmp_path / "out"
        assert main(["simulate", str(path), "--out", str(out), "--controller", "tracking", "--plant", model]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and key in lines[0] and not out.exists()
    text = small_scenario(tmp_path, '[plant]\nmodel = "single-track"\n').read_text()
    truck = '[vehicle]\nmodel = "truck"\nwheelbase = 5.0\n'
    assert truck in text
    bad = tmp_path / "unicycle.toml"
    bad.write_text(text.replace(truck, '[vehicle]\nmodel = "unicycle"\n'))
    with pytest.raises(InputError, match="steering angle") as err:
        load_scenario(bad)
    assert err.value.key == "plant.model"
    trailer = '[vehicle]\nmodel = "tractor-trailer"\nwheelbase = 3.8\nhitch_offset = 0.5\ntrailer_wheelbase = 7.8\n'
    for vehicle, extra, key in ((truck, "trailer_mass = 1.0\n", "plant.trailer_mass"),
                                (trailer, "cg_height = 1.0\n", "plant.cg_height"),
                                (trailer, "hitch_to_trailer_cg = 7.8\n", "plant.hitch_to_trailer_cg")):  # fmt: skip
        bad.write_text(text.replace(truck, vehicle) + extra)
        with pytest.raises(InputError) as err:
            load_scenario(bad)
        assert err.value.key == key


def trailer_scenario(tmp_path) -> Path:
    """The small scenario with the tractor-semitrailer (d = 3.8 m, h = 0.5 m, L = 7.8 m), aligned at both ends."""
    text = small_scenario(tmp_path).read_text()
    text = text.replace(
        'model = "truck"\nwheelbase = 5.0\n',
        'model = "tractor-trailer"\nwheelbase = 3.8\nhitch_offset = 0.5\ntrailer_wheelbase = 7.8\n',
    )
    text = text.replace("phi = 0.0\n", "phi = 0.0\ntheta1 = 0.0\n", 1)
    text = text.replace("theta = -1.5707963267948966\n", "theta = -1.5707963267948966\ntheta1 = -1.5707963267948966\n")
    path = tmp_path / "trailer.toml"
    path.write_text(text)
    return path


def drive_articulated(speed: float, steer: float, distance: float = 40.0, h: float = 0.1):
    """As ``drive`` for the tractor-semitrailer: both plants' kinematic states, and the plant's last state."""
    vehicle = TractorTrailer(3.8, 0.5, 7.8)
    kin, st = Plant(vehicle, Disturbance(), h), TractorSemitrailerPlant(vehicle, Disturbance(), h, {})
    x = np.zeros(5)
    z = st.start(x, speed=speed)
    end = distance / speed
    kin_x, st_x = [x], [st.state(z)]
    for k in range(int(round(end / h))):
        t = k * h
        rate = steer / 2.0 if t < 2.0 else (-steer / 2.0 if end / 2 <= t < end / 2 + 2.0 else 0.0)
        u = np.array([speed, rate])
        x, z = kin.step(x, u), st.step(z, u)
        kin_x.append(x)
        st_x.append(st.state(z))
    return np.array(kin_x), np.array(st_x), z


def test_tractor_semitrailer_follows_the_kinematic_model_at_low_speed():
    """40 m steering to 0.05 rad and back: at 1 m/s within 3 cm and 2 mrad of trailer heading of the kinematic
    tractor-trailer (measured 1.1 cm, 0.3 mrad), at 8 m/s over 0.3 m apart (measured 0.58 m); below 0.1 m/s the
    kinematic model itself (1e-9)."""
    kin, st, _ = drive_articulated(1.0, 0.05)
    assert np.max(np.hypot(*(st[:, :2] - kin[:, :2]).T)) < 0.03
    assert np.max(np.abs(st[:, 4] - kin[:, 4])) < 0.002
    kin, st, _ = drive_articulated(8.0, 0.05)
    assert np.max(np.hypot(*(st[:, :2] - kin[:, :2]).T)) > 0.3
    kin, st, _ = drive_articulated(0.05, 0.2, distance=1.0)
    assert np.max(np.abs(st - kin)) < 1e-9


def test_tractor_semitrailer_reduces_to_the_single_track_model_without_a_trailer():
    """A trailer of 1 mg without cornering stiffness: the tractor's yaw and slip accelerations are those of the
    single-track model (no load transfer) within 1e-3, the difference being the exact slip angle's tangent
    against CommonRoad's linearised slip (delta = 0.01 rad, slip 0.013 rad)."""
    p = ArticulatedParameters(
        mass=8000.0, yaw_inertia=27600.0, lf=1.5, lr=2.3, hitch=0.5, trailer_wheelbase=7.8, trailer_mass=1e-6,
        trailer_yaw_inertia=1e-6, trailer_cg=4.0, cf=6.9, cr=8.0, ct=1e-9,
    )  # fmt: skip
    q = SingleTrackParameters(mass=8000.0, yaw_inertia=27600.0, lf=1.5, lr=2.3, cf=6.9, cr=8.0, h_cg=0.0, mu=0.8)
    u, w, r, delta = 10.0, 0.02, 0.05, 0.01
    f = articulated_rhs([0.0, 0.0, 0.0, 0.0, delta, u, w, r, r], 0.0, 0.0, p)
    lateral = w + q.lr * r  # the centre of gravity's lateral speed
    g = single_track_rhs([0.0, 0.0, delta, math.hypot(u, lateral), 0.0, r, math.atan(lateral / u)], 0.0, 0.0, q)
    assert f[7] == pytest.approx(g[5], rel=1e-3)
    slip_rate = (f[6] + q.lr * f[7]) / u / (1 + (lateral / u) ** 2)
    assert slip_rate == pytest.approx(g[6], rel=1e-3)


def test_tractor_semitrailer_steady_turn():
    """Constant speed and steering: the trailer settles to the tractor's yaw rate (a steady circle)."""
    plant = TractorSemitrailerPlant(TractorTrailer(3.8, 0.5, 7.8), Disturbance(), 5.0, {})
    z = plant.start(np.array([0.0, 0.0, 0.0, 0.1, 0.0]), speed=5.0)
    for _ in range(20):
        z = plant.step(z, np.array([5.0, 0.0]))
    assert abs(z[7] - z[8]) < 1e-6 * abs(z[7])
    assert 0.9 * 5.0 * math.tan(0.1) / 3.8 < z[7] < 5.0 * math.tan(0.1) / 3.8  # understeers a little


def test_simulate_tractor_semitrailer(tmp_path):
    """``simulate --controller tracking`` on the tractor-semitrailer plant reaches the goal, reports the mismatch."""
    scenario = trailer_scenario(tmp_path)
    assert main(["simulate", str(scenario), "--out", str(tmp_path / "tt"), "--controller", "tracking", "--quiet",
                 "--plant", "single-track"]) == 0  # fmt: skip
    summary = json.loads((tmp_path / "tt" / "summary.json").read_text())
    cols = read_csv(tmp_path / "tt" / "closed_loop.csv")
    assert summary["plant"]["max_side_slip"] == pytest.approx(float(np.max(np.abs(cols["plant_beta"]))))
    assert 0.0 < summary["plant"]["max_lateral_deviation"] < 1.0
    assert "plant_articulation" in cols and "trailer_mass" in summary["plant"]["parameters"]
