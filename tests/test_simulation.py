"""roundabout simulate (docs/closed-loop-format.md): the plant, the controllers, the outputs, bad inputs."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model.cli import main
from model.errors import InputError
from model.problem.closed_loop import ControlSettings, Disturbance, parse_closed_loop
from model.problem.scenario import Scenario, load_scenario, parse_scenario
from model.simulation.controllers import OpenLoop, Tracking
from model.simulation.loop import SUMMARY_KEYS, simulate
from model.simulation.plant import Plant
from model.vehicles import TractorTrailer, Tricycle
from tests.conftest import ROOT, straight_time

TRUCK = ROOT / "examples" / "closed-loop-truck.toml"
CONTRACT_KEYS = {
    "controller", "steps", "final_position_error", "final_heading_error", "energy", "final_time",
    "min_clearance", "solve_seconds_mean", "solve_seconds_max", "realtime_factor", "failed_steps",
    "reached_goal", "goal_tolerance",
}  # fmt: skip


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True, cwd=ROOT
    )


def read_csv(path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


@pytest.fixture(scope="module")
def tracked(tmp_path_factory):
    """The example run through the command line with the tracking controller."""
    out = tmp_path_factory.mktemp("tracked")
    res = run("simulate", TRUCK, "--out", out, "--controller", "tracking")
    return res, out


@pytest.fixture(scope="module")
def optimum():
    scenario = load_scenario(TRUCK)
    solution = scenario.ocp.solve(intervals=40)
    assert solution.ok
    return scenario, solution


def truck_plant(table: dict, wheelbase: float):
    """The contract's truck plant written out by hand (not from model.vehicles)."""
    g = table.get("speed_gain", 1.0)
    b = table.get("steering_bias", 0.0)
    wx, wy = table.get("drift", [0.0, 0.0])
    d = table.get("wheelbase", wheelbase)

    def rhs(_t, s, u1, u2):
        _, _, theta, phi = s
        return [g * u1 * math.cos(theta) + wx, g * u1 * math.sin(theta) + wy, g * u1 * math.tan(phi + b) / d, u2]

    return rhs


def test_closed_loop_states_are_what_the_disturbed_plant_does(tracked):
    """Re-integrate closed_loop.csv from its first row under its listed controls: same states to 1e-6."""
    res, out = tracked
    assert res.returncode in (0, 1), res.stderr
    doc = tomllib.loads(TRUCK.read_text())
    rhs = truck_plant(doc["disturbance"], doc["vehicle"]["wheelbase"])
    cols = read_csv(out / "closed_loop.csv")
    assert list(cols)[:7] == ["t", "x", "y", "theta", "phi", "u1", "u2"]
    states = np.column_stack([cols[s] for s in ("x", "y", "theta", "phi")])
    x = states[0]
    worst = 0.0
    for k in range(len(cols["t"]) - 1):
        span = (cols["t"][k], cols["t"][k + 1])
        x = solve_ivp(rhs, span, x, args=(cols["u1"][k], cols["u2"][k]), method="DOP853", rtol=1e-12, atol=1e-12).y[
            :, -1
        ]
        worst = max(worst, float(np.max(np.abs(x - states[k + 1]))))
    assert worst < 1e-6
    # the delay is in the listed controls: the applied u1 of the first 0.1 s is the standstill's zero
    assert cols["u1"][0] == 0.0 and cols["sent_u1"][0] != 0.0
    assert cols["u1"][-1] == cols["u1"][-2]


def test_summary_has_every_contract_key_and_the_exit_code_follows_it(tracked):
    res, out = tracked
    summary = json.loads((out / "summary.json").read_text())
    assert CONTRACT_KEYS <= set(summary) and set(SUMMARY_KEYS) == CONTRACT_KEYS
    assert summary["controller"].startswith("tracking")
    assert summary["steps"] == 70 and summary["final_time"] == pytest.approx(7.0)
    assert summary["realtime_factor"] == pytest.approx(summary["solve_seconds_max"] / 0.1)
    assert 0.0 < summary["step_cpu_seconds_mean"] <= summary["step_cpu_seconds_max"]
    assert "mpc_step" not in summary  # the MPC's only
    assert res.returncode == (0 if summary["reached_goal"] else 1)
    assert (out / "optimum" / "trajectory.csv").exists()


def test_open_loop_replay_without_disturbance_reaches_the_goal(optimum):
    """Sample means of the optimum's controls under the ZOH: within 0.5 % of the 45.7 m start-goal distance."""
    scenario, solution = optimum
    none = Disturbance()
    result = simulate(scenario, solution, OpenLoop(solution, scenario.control), none, scenario.control)
    distance = scenario.ocp.straight_distance()
    assert result.summary["final_position_error"] < 0.005 * distance
    assert result.summary["final_heading_error"] < 0.01
    assert result.summary["reached_goal"]
    assert result.summary["energy"] == pytest.approx(solution.energy, rel=0.01)


def test_with_a_disturbance_open_loop_misses_and_tracking_does_much_better(optimum):
    scenario, solution = optimum
    dist, control = scenario.disturbance, scenario.control
    open_loop = simulate(scenario, solution, OpenLoop(solution, control), dist, control).summary
    tracking = simulate(scenario, solution, Tracking(solution, control, dist), dist, control).summary
    assert not open_loop["reached_goal"]
    assert tracking["final_position_error"] < open_loop["final_position_error"] / 10
    assert tracking["final_heading_error"] < open_loop["final_heading_error"] / 5
    assert tracking["reached_goal"]


BAD = {
    "misspelled": (("speed_gain = 0.95", "speed_gian = 0.95"), "did you mean 'speed_gain'"),
    "delay_not_multiple": (("delay = 0.1", "delay = 0.15"), "disturbance.delay"),
    "negative_noise": (("noise = 0.03", "noise = -0.03"), "disturbance.noise"),
    "zero_speed_gain": (("speed_gain = 0.95", "speed_gain = 0.0"), "disturbance.speed_gain"),
    "horizon_one": (("horizon = 40", "horizon = 1"), "control.horizon"),
    "interval_not_dividing": (("horizon = 40", "horizon = 40\ninterval_samples = 3"), "control.interval_samples"),
    "interval_zero": (("horizon = 40", "horizon = 40\ninterval_samples = 0"), "control.interval_samples"),
    "one_interval": (("horizon = 40", "horizon = 40\ninterval_samples = 40"), "control.interval_samples"),
    "realtime_not_bool": (("realtime = false", 'realtime = "yes"'), "control.realtime"),
}


def test_interval_samples_divide_the_horizon():
    """``control.interval_samples`` gives the MPC's prediction intervals; the default is one per sample."""
    assert ControlSettings(0.1, 40).intervals == 40
    assert ControlSettings(0.1, 40, 2).intervals == 20
    assert ControlSettings(0.1, "shrinking").intervals is None
    with pytest.raises(ValueError, match="does not divide"):
        _ = ControlSettings(0.1, 40, 3).intervals
    _, control = parse_closed_loop({"control": {"horizon": 40, "interval_samples": 4}})
    assert control.intervals == 10
    with pytest.raises(InputError, match="shrinking"):
        parse_closed_loop({"control": {"horizon": "shrinking", "interval_samples": 2}})


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_closed_loop_keys_exit_2_with_one_line_and_nothing_written(tmp_path, case):
    (old, new), expected = BAD[case]
    text = TRUCK.read_text()
    assert old in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, new))
    res = run("simulate", bad, "--out", tmp_path / "out", "--controller", "tracking")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("roundabout: invalid input:") and expected in lines[0]
    assert not (tmp_path / "out").exists()


def test_bad_command_line_exits_2(tmp_path, capsys, monkeypatch):
    existing = tmp_path / "file"
    existing.write_text("")
    assert main(["simulate", str(TRUCK), "--out", str(existing), "--controller", "tracking"]) == 2
    assert main(["simulate", str(TRUCK), "--out", str(tmp_path / "a"), "--controller", "tracking", "--runs", "0"]) == 2
    monkeypatch.setitem(sys.modules, "model.simulation.mpc", None)  # as before mpc.py exists
    assert main(["simulate", str(TRUCK), "--out", str(tmp_path / "b"), "--controller", "mpc"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and "mpc controller not available yet" in lines[2]
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_runs_write_one_line_per_seed_with_different_noise(tmp_path):
    out = tmp_path / "out"
    res = run("simulate", TRUCK, "--out", out, "--controller", "tracking", "--runs", "3", "--intervals", "40")
    assert res.returncode in (0, 1), res.stderr
    with open(out / "runs.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["seed"]) for r in rows] == [0, 1, 2]
    assert len({r["final_position_error"] for r in rows}) == 3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 3 and CONTRACT_KEYS <= set(summary)
    rate = sum(r["reached_goal"] == "true" for r in rows) / 3
    assert summary["reached_goal_rate"] == pytest.approx(rate)
    worst = max(float(r["final_position_error"]) for r in rows)
    assert summary["final_position_error"] == pytest.approx(worst)
    assert res.returncode == (0 if rate == 1 else 1)


def test_plants_of_the_other_models_step_as_their_equations_say():
    """Tricycle and tractor-trailer plants, one disturbed sample against the equations written by hand."""
    g, b, (wx, wy), h = 0.9, 0.03, (0.1, -0.2), 0.2
    u1, u2 = 2.0, 0.3
    tri = Plant(Tricycle(wheelbase=2.0), Disturbance(g, b, (wx, wy), {"wheelbase": 2.2}), h)
    x0 = np.array([1.0, 2.0, 0.3, 0.1])

    def tricycle(_t, s):
        _, _, th, ph = s
        v = g * u1 * math.cos(ph + b)
        return [v * math.cos(th) + wx, v * math.sin(th) + wy, g * u1 * math.sin(ph + b) / 2.2, u2]

    expected = solve_ivp(tricycle, (0, h), x0, rtol=1e-12, atol=1e-12, method="DOP853").y[:, -1]
    assert np.max(np.abs(tri.step(x0, np.array([u1, u2])) - expected)) < 1e-8

    lengths = {"wheelbase": 4.0, "trailer_wheelbase": 8.0}
    trailer = Plant(TractorTrailer(3.8, 0.5, 7.8), Disturbance(g, b, (wx, wy), lengths), h)
    x0 = np.array([0.0, 0.0, 0.2, -0.1, 0.4])

    def semi(_t, s):
        _, _, th, ph, th1 = s
        rate = g * u1 * (math.sin(th - th1) + 0.5 / 4.0 * math.tan(ph + b) * math.cos(th - th1)) / 8.0
        return [g * u1 * math.cos(th) + wx, g * u1 * math.sin(th) + wy, g * u1 * math.tan(ph + b) / 4.0, u2, rate]

    expected = solve_ivp(semi, (0, h), x0, rtol=1e-12, atol=1e-12, method="DOP853").y[:, -1]
    assert np.max(np.abs(trailer.step(x0, np.array([u1, u2])) - expected)) < 1e-8


def test_a_time_problem_runs_to_the_optimum_final_time_with_a_shorter_last_sample():
    """Straight 1 m at |u1| <= 1: Tf = 1 s; with h = 0.3 s the last sample lasts 0.1 s."""
    scenario = Scenario(ocp=straight_time(), control=ControlSettings(sample_time=0.3))
    solution = scenario.ocp.solve(intervals=20)
    assert solution.ok
    none = Disturbance()
    result = simulate(scenario, solution, Tracking(solution, scenario.control, none), none, scenario.control)
    t = result.columns["t"]
    assert t[-1] == pytest.approx(solution.final_time, abs=1e-9) and np.diff(t)[-1] < 0.3 - 1e-6
    assert result.summary["steps"] == len(t) - 1 == math.ceil(solution.final_time / 0.3 - 1e-9)
    assert result.summary["reached_goal"] and result.summary["final_position_error"] < 1e-3


def test_model_specific_disturbance_keys():
    """The trailer's lengths as a table; a steering bias on the unicycle (no steering angle) is refused."""
    doc = {
        "vehicle": {"model": "tractor-trailer"},
        "bounds": {"u1": [-1.0, 1.0], "u2": [-0.5, 0.5]},
        "initial": {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0, "theta1": 0.0},
        "problem": {"objective": "energy", "final_time": 5.0},
        "disturbance": {"wheelbase": {"wheelbase": 4.0, "trailer_wheelbase": 8.1}},
    }
    assert parse_scenario(doc).disturbance.wheelbase == {"wheelbase": 4.0, "trailer_wheelbase": 8.1}
    doc["disturbance"] = {"wheelbase": {"trailer_wheelbse": 8.1}}
    with pytest.raises(InputError, match="did you mean 'trailer_wheelbase'"):
        parse_scenario(doc)
    doc["vehicle"] = {"model": "unicycle"}
    doc["initial"] = {"x": 0.0, "y": 0.0, "theta": 0.0}
    doc["disturbance"] = {"steering_bias": 0.01}
    with pytest.raises(InputError, match="disturbance.steering_bias"):
        parse_scenario(doc)


def test_without_the_realtime_key_the_mpc_step_is_left_to_the_controller():
    """``[control]`` without ``realtime`` is None (the real-time iteration wherever it applies,
    ``MPCSettings.realtime``); ``true`` and ``false`` stay what they say."""
    assert parse_closed_loop({})[1].realtime is None
    assert parse_closed_loop({"control": {"horizon": 40}})[1].realtime is None
    assert parse_closed_loop({"control": {"realtime": False}})[1].realtime is False
    assert parse_closed_loop({"control": {"realtime": True}})[1].realtime is True


ROAD = ROOT / "examples" / "roundabout-truck.toml"


def test_simulate_takes_the_time_limit_of_solve_with_its_default(tmp_path):
    """``--time-limit`` is solve's option with solve's default; a bad value is one line, exit 2."""
    text = run("simulate", "--help").stdout.replace("\n", " ")
    assert "--time-limit SECONDS" in text and "default 300" in " ".join(text.split())
    res = run("simulate", TRUCK, "--out", tmp_path / "out", "--controller", "tracking", "--time-limit", "0")
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "--time-limit" in lines[0]
    assert not (tmp_path / "out").exists()


def test_a_plan_solve_beyond_the_time_limit_is_refused_and_nothing_is_simulated(tmp_path):
    """A budget no road search can meet (50 ms): the plan solve stops with solve's diagnosis, the
    command exits 1 as solve does for a failed solve, and no closed loop is run or written."""
    out = tmp_path / "out"
    res = run("simulate", ROAD, "--out", out, "--controller", "mpc", "--intervals", 30, "--time-limit", 0.05)
    assert res.returncode == 1, res.stderr
    assert "roundabout: FAILED (" in res.stderr and "within the time limit of 0.05 s" in res.stderr
    assert res.stderr.count("reached: the search stops") == 1  # solve's progress line
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reached_goal"] is False and "the open-loop solve failed" in summary["status"]
    optimum = json.loads((out / "optimum" / "summary.json").read_text())
    assert optimum["diagnosis"]["kind"] == "time limit" and optimum["search"]["time_limit"] == 0.05
    assert not (out / "closed_loop.csv").exists()
