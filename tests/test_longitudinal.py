"""Longitudinal dynamics (docs/dynamics-format.md): the speed a state, the acceleration (or jerk) a control.

The solved answers are checked here independently of the project's validation: the extended truck
written out by hand, re-integrated by scipy from trajectory.csv's nodes under linear controls, its
bounds, and the final time against the point-mass bound for the path driven.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from model.errors import InputError
from model.problem.scenario import parse_scenario
from model.vehicles import Longitudinal, TractorTrailer, Tricycle, Truck, Unicycle, sym

REST = """
name = "{name}"
[vehicle]
model = "truck"
wheelbase = 5.0
[vehicle.longitudinal]
acceleration = [-2.0, 1.0]
{jerk}
[bounds]
v = [0.0, 8.33]
u2 = [-0.4, 0.4]
phi = [-0.6, 0.6]
lateral_acceleration = [-2.0, 2.0]
[initial]
x = 0.0
y = 0.0
theta = 0.0
phi = 0.0
v = {v0}
[final]
x = 60.0
y = 10.0
theta = 0.0
v = 0.0
[problem]
objective = "time"
intervals = 60
"""


def _doc(**kw) -> dict:
    import tomllib

    text = REST.format(**({"name": "rest", "jerk": "", "v0": 0.0} | kw))
    return tomllib.loads(text)


@pytest.mark.parametrize("cls", [Truck, Tricycle, Unicycle, TractorTrailer])
@pytest.mark.parametrize("jerk", [False, True])
def test_every_model_gets_the_speed_as_a_state(cls, jerk):
    base = cls()
    ext = Longitudinal(base, jerk=jerk)
    assert ext.states == base.states + (("v", "a") if jerk else ("v",))
    assert ext.controls == tuple(("j" if jerk else "a") if c == base.roles.speed else c for c in base.controls)
    f, g = ext.dynamics(), base.dynamics()
    for name in base.states:
        assert (f[name] - g[name].subs(sym(base.roles.speed), sym("v"))).simplify() == 0
    assert f["v"] == sym("a")
    assert (f.get("a") == sym("j")) if jerk else ("a" not in f)
    assert ext.roles.speed == "v" and ext.roles.acceleration == "a"


def _bad(doc: dict) -> str:
    with pytest.raises(InputError) as err:
        parse_scenario(doc)
    return str(err.value)


def test_the_contracts_bad_inputs_name_the_key():
    doc = _doc()
    doc["bounds"]["u1"] = [-1.0, 1.0]
    assert "bounds.u1" in _bad(doc) and "state v" in _bad(doc)
    doc = _doc()
    del doc["bounds"]["v"]
    assert "bounds.v" in _bad(doc)
    for pair in ([0.0, 1.0], [-1.0, 0.0], [1.0, -1.0], [-math.inf, 1.0], [1.0], "fast"):
        doc = _doc()
        doc["vehicle"]["longitudinal"]["acceleration"] = pair
        assert "vehicle.longitudinal.acceleration" in _bad(doc)
    doc = _doc(jerk="jerk = [-1.0, 1.0]")
    doc["initial"]["a"] = 3.0
    assert "initial.a" in _bad(doc)
    doc = _doc()
    doc["vehicle"]["longitudinal"]["jerks"] = [-1.0, 1.0]
    assert "vehicle.longitudinal.jerks" in _bad(doc)
    doc = _doc()
    doc["vehicle"]["operational"] = True
    assert "vehicle.operational" in _bad(doc)  # no preset


def test_operational_takes_the_presets_limits_and_the_file_overrides_them():
    doc = _doc()
    doc["vehicle"] = {"preset": "SU-30", "operational": True, "longitudinal": {"acceleration": [-1.5, 0.8]}}
    del doc["bounds"]["v"], doc["bounds"]["u2"]
    ocp = parse_scenario(doc).ocp
    assert ocp.vehicle.states[-2:] == ("v", "a") and ocp.vehicle.controls == ("j", "u2")
    assert ocp.bounds["a"] == (-1.5, 0.8)  # the file's
    assert ocp.bounds["j"] == (-1.0, 1.0) and ocp.bounds["v"] == pytest.approx((0.0, 50 / 3.6))
    assert ocp.bounds["u2"] == (-0.4, 0.4)
    assert ocp.bounds["lateral_acceleration"] == (-2.0, 2.0)  # the file's [bounds] over the preset's


def test_a_bad_input_on_the_command_line_writes_nothing(tmp_path):
    doc = REST.format(name="bad", jerk="", v0=0.0).replace("v = [0.0, 8.33]", "u1 = [0.0, 8.33]")
    path = tmp_path / "bad.toml"
    path.write_text(doc)
    run = subprocess.run(
        [sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2
    assert run.stderr.strip().count("\n") == 0 and "bounds.u1" in run.stderr
    assert not (tmp_path / "out").exists()


def _extended_truck(t, y, u_at, d, jerk):
    """The extended truck written out here (not from the project): x, y, theta, phi, v (, a)."""
    x, yy, th, phi, v, *rest = y
    u = u_at(t)
    acc = rest[0] if jerk else u[0]
    out = [v * math.cos(th), v * math.sin(th), v * math.tan(phi) / d, u[1], acc]
    return out + ([u[0]] if jerk else [])


def _point_mass_time(length: float, v0: float, vf: float, vmax: float, up: float, down: float) -> float:
    """Least time to drive ``length`` from v0 to vf with |dv/dt| in [-down, up] and v <= vmax."""
    peak = math.sqrt((2 * up * down * length + down * v0**2 + up * vf**2) / (up + down))
    if peak <= vmax:
        return (peak - v0) / up + (peak - vf) / down
    ramp = (vmax**2 - v0**2) / (2 * up) + (vmax**2 - vf**2) / (2 * down)
    return (vmax - v0) / up + (vmax - vf) / down + (length - ramp) / vmax


@pytest.mark.parametrize(
    "jerk, v0", [("", 0.0), ("jerk = [-1.0, 1.0]", 0.0), ("", 5.0)], ids=["rest", "jerk", "rolling"]
)
def test_solved_answers_pass_an_independent_check(tmp_path, jerk, v0):
    path = tmp_path / "s.toml"
    path.write_text(REST.format(name="s", jerk=jerk, v0=v0))
    out = tmp_path / "out"
    run = subprocess.run(
        [sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["valid"] and summary["longitudinal"]["bounds"]["a"] == [-2.0, 1.0]
    tr = pd.read_csv(out / "trajectory.csv")
    has_jerk = bool(jerk)
    names = ["t", "x", "y", "theta", "phi", "v", "a", "j"][: 7 + has_jerk]
    assert list(tr.columns[: len(names)]) == names
    t = tr["t"].to_numpy()
    controls = tr[["j" if has_jerk else "a", "u2"]].to_numpy()
    states = ["x", "y", "theta", "phi", "v"] + (["a"] if has_jerk else [])
    X = tr[states].to_numpy()
    worst = 0.0
    for k in range(len(t) - 1):
        h = t[k + 1] - t[k]

        def u_at(s, k=k, h=h):
            w = (s - t[k]) / h
            return (1 - w) * controls[k] + w * controls[k + 1]

        sol = solve_ivp(_extended_truck, (t[k], t[k + 1]), X[k], args=(u_at, 5.0, has_jerk), rtol=1e-10, atol=1e-10)
        worst = max(worst, float(np.max(np.abs(sol.y[:2, -1] - X[k + 1, :2]))))
    assert worst < 0.02  # the trapezoid's one-step error, metres
    tol = 1e-6
    assert tr["v"].between(-tol, 8.33 + tol).all() and tr["a"].between(-2 - tol, 1 + tol).all()
    if has_jerk:
        assert tr["j"].between(-1 - tol, 1 + tol).all()
    lateral = tr["v"] ** 2 * np.tan(tr["phi"]) / 5.0
    assert lateral.abs().max() <= 2.0 + tol
    assert tr["v"].iloc[0] == pytest.approx(v0, abs=1e-6) and tr["v"].iloc[-1] == pytest.approx(0.0, abs=1e-6)
    driven = float(np.sum(np.hypot(np.diff(tr["x"]), np.diff(tr["y"]))))
    assert summary["final_time"] >= _point_mass_time(driven, v0, 0.0, 8.33, 1.0, 2.0) - 1e-6
    assert summary["final_time"] <= 1.05 * _point_mass_time(driven, v0, 0.0, 8.33, 1.0, 2.0) + (2.0 if jerk else 0.5)


def test_derive_prints_the_speeds_costate_and_the_accelerations_switching_function(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(REST.format(name="s", jerk="", v0=0.0))
    run = subprocess.run([sys.executable, "-m", "model.cli", "derive", str(path)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "p_v' = " in run.stdout and "psi_a = dH/da = p_v" in run.stdout


def test_seed_models_are_unchanged_without_the_table():
    doc = _doc()
    del doc["vehicle"]["longitudinal"], doc["bounds"]["v"], doc["initial"]["v"], doc["final"]["v"]
    doc["bounds"]["u1"] = [-8.33, 8.33]
    ocp = parse_scenario(doc).ocp
    assert type(ocp.vehicle) is Truck and ocp.vehicle.controls == ("u1", "u2")


def test_docs_copy_the_contract():
    shared = Path(__file__).resolve().parents[2] / "shared" / "dynamics-format.md"
    if not shared.exists():
        pytest.skip("no shared/ beside the checkout")
    assert shared.read_text() in (Path(__file__).resolve().parents[1] / "docs" / "dynamics-format.md").read_text()


def _casadi_reference(n: int, jerk: bool) -> float:
    """Least time of the rest-to-rest truck by an independent CasADi Opti transcription (trapezoid, N steps)."""
    import casadi as ca

    opti = ca.Opti()
    nx = 6 if jerk else 5
    X, U, tf = opti.variable(nx, n + 1), opti.variable(2, n + 1), opti.variable()

    def f(x, u):
        acc = x[5] if jerk else u[0]
        rows = [x[4] * ca.cos(x[2]), x[4] * ca.sin(x[2]), x[4] * ca.tan(x[3]) / 5.0, u[1], acc]
        return ca.vertcat(*(rows + ([u[0]] if jerk else [])))

    h = tf / n
    for k in range(n):
        opti.subject_to(X[:, k + 1] == X[:, k] + h / 2 * (f(X[:, k], U[:, k]) + f(X[:, k + 1], U[:, k + 1])))
    opti.subject_to(X[:5, 0] == [0, 0, 0, 0, 0])
    opti.subject_to(X[[0, 1, 2, 4], n] == [60.0, 10.0, 0.0, 0.0])
    opti.subject_to(opti.bounded(0.0, X[4, :], 8.33))
    opti.subject_to(opti.bounded(-0.6, X[3, :], 0.6))
    opti.subject_to(opti.bounded(-0.4, U[1, :], 0.4))
    opti.subject_to(opti.bounded(-2.0, X[4, :] ** 2 * ca.tan(X[3, :]) / 5.0, 2.0))
    if jerk:
        opti.subject_to(opti.bounded(-2.0, X[5, :], 1.0))
        opti.subject_to(opti.bounded(-1.0, U[0, :], 1.0))
    else:
        opti.subject_to(opti.bounded(-2.0, U[0, :], 1.0))
    opti.subject_to(tf >= 1.0)
    s = np.linspace(0, 1, n + 1)
    opti.set_initial(X[0, :], 60 * s)
    opti.set_initial(X[1, :], 10 * s)
    opti.set_initial(X[4, :], 4.0 * np.sin(np.pi * s))
    opti.set_initial(tf, 16.0)
    opti.minimize(tf)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "max_iter": 3000})
    return float(opti.solve().value(tf))


@pytest.mark.parametrize("jerk", [False, True], ids=["acceleration", "jerk"])
def test_the_final_time_is_at_most_an_independent_casadi_references(tmp_path, jerk):
    path = tmp_path / "s.toml"
    path.write_text(REST.format(name="s", jerk="jerk = [-1.0, 1.0]" if jerk else "", v0=0.0))
    run = subprocess.run(
        [sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(tmp_path / "o"), "--quiet"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    reference = _casadi_reference(summary["intervals"], jerk)
    assert summary["final_time"] <= reference * (1 + 1e-4)


@pytest.mark.parametrize("cls", [Truck, Tricycle, Unicycle, TractorTrailer])
def test_one_rule_names_the_integrated_states_and_the_pose_states(cls):
    base = cls()
    assert base.roles.integrated == () and base.integrated_states == () and base.pose_states == base.states
    assert Longitudinal(base).integrated_states == ("v",) and Longitudinal(base, jerk=True).integrated_states == (
        "v",
        "a",
    )
    for ext in (Longitudinal(base), Longitudinal(base, jerk=True)):
        assert ext.pose_states == base.states  # a start fixes these; v (and a) are free unless stated


def test_the_ends_complete_the_pose_the_same_way_everywhere():
    from model.problem.ocp import end_pose

    ext = Longitudinal(TractorTrailer(), jerk=True)
    goal = end_pose(ext, {"x": 1.0, "y": 2.0, "theta": 0.5}, {"x": 0.0, "phi": 0.3, "theta1": 0.1, "v": 4.0})
    assert goal == {"x": 1.0, "y": 2.0, "theta": 0.5, "phi": 0.0, "theta1": 0.5, "v": 0.0, "a": 0.0}
    assert end_pose(ext, {"theta": 0.5, "v": 3.0, "theta1": 0.2})["v"] == 3.0  # what an end states wins
    assert end_pose(ext, {"theta": 0.5, "v": 3.0, "theta1": 0.2})["theta1"] == 0.2
    # a start must fix every pose state, never v or a
    doc = _doc(jerk="jerk = [-1.0, 1.0]")
    del doc["initial"]["v"]
    assert parse_scenario(doc).ocp.initial.get("v") is None
    del doc["initial"]["phi"]
    assert "initial.phi" in _bad(doc)


def test_a_route_leaves_v_and_a_to_the_file_and_the_pose_checks_ignore_them():
    from model.analysis.bounds import pose_clearances

    doc = tomllib_loads(Path(__file__).resolve().parents[1] / "examples" / "roundabout-semitrailer-operational.toml")
    ocp = parse_scenario(doc).ocp
    assert set(ocp.vehicle.integrated_states) <= set(ocp.vehicle.states)
    gaps = pose_clearances(ocp)
    moved = dict(ocp.final) | dict.fromkeys(ocp.vehicle.integrated_states, 7.0)
    ocp.final = moved  # v and a are part of no pose: the same clearances
    assert pose_clearances(ocp) == gaps
    doc["final"] = {"x": 1.0}
    assert "final.x" in _bad(doc)  # the route sets the pose


def tomllib_loads(path: Path) -> dict:
    import tomllib

    return tomllib.loads(path.read_text())


def _rest_ocp(v_lo: float, goal: tuple[float, float, float], jerk: bool = False, longitudinal: bool = True):
    doc = _doc(jerk="jerk = [-1.0, 1.0]" if jerk else "")
    doc["bounds"]["v"] = [v_lo, 8.33]
    doc["final"] |= {"x": goal[0], "y": goal[1], "theta": goal[2]}
    if not longitudinal:
        del doc["vehicle"]["longitudinal"], doc["bounds"]["v"], doc["initial"]["v"], doc["final"]["v"]
        doc["bounds"]["u1"] = [v_lo, 8.33]
    return parse_scenario(doc).ocp


def test_the_reversing_starts_are_tried_where_they_exist_and_the_speed_may_reverse():
    from model.search.multistart import reeds_shepp_starts

    routes = lambda ocp: [route for _, route in reeds_shepp_starts(ocp)]  # noqa: E731
    everything = ["reeds-shepp", "reeds-shepp-reverse-in", "reeds-shepp-reverse-out"]
    # no word reverses into (or out of) 60 m x 10 m: reeds_shepp returns the empty path, a stand-still start
    assert routes(_rest_ocp(-3.0, (60.0, 10.0, 0.0))) == ["reeds-shepp"]
    assert routes(_rest_ocp(-3.0, (0.0, 6.0, 0.0), jerk=True)) == everything  # parallel parking
    assert routes(_rest_ocp(0.0, (0.0, 6.0, 0.0))) == []  # every word reverses, v >= 0 cannot
    assert routes(_rest_ocp(-3.0, (0.0, 6.0, 0.0), longitudinal=False)) == everything  # the seed model as before
    assert routes(_rest_ocp(-3.0, (60.0, 10.0, 0.0), longitudinal=False)) == everything


def test_a_reversing_start_converges_and_beats_the_shortest_word():
    from model.search.multistart import solve_pass

    ocp = _rest_ocp(-3.0, (0.0, 6.0, 0.0), jerk=True)
    shortest, reversing = (solve_pass(ocp, 60, "none", route=r) for r in ("reeds-shepp", "reeds-shepp-reverse-in"))
    assert shortest.ok and reversing.ok and reversing.iterations < 200
    assert reversing.objective < shortest.objective  # measured 14.557 s against 14.629 s


@pytest.mark.parametrize("jerk", [False, True])
def test_the_limited_path_guess_is_consistent_and_within_the_limits(jerk):
    from model.search.guess import reeds_shepp_start_path
    from model.search.paths import LIMIT_SHARE, limited_path_guess

    ocp = _rest_ocp(-3.0, (0.0, 6.0, 0.0), jerk=jerk)
    path = reeds_shepp_start_path(ocp)
    assert path.cusps == 2
    values, tf = limited_path_guess(ocp.vehicle, path, 200, ocp.bounds, ocp.initial, ocp.final)
    t = np.linspace(0.0, tf, 201)
    assert set(values) == set(ocp.vehicle.states) | set(ocp.vehicle.controls)
    v = values["v"]
    assert v[0] == pytest.approx(0.0, abs=1e-12) and v[-1] == pytest.approx(0.0, abs=1e-9)
    assert np.sum(np.diff(np.sign(v[np.abs(v) > 1e-9])) != 0) == 2  # through 0 at each cusp
    xdot, ydot = np.gradient(values["x"], t), np.gradient(values["y"], t)
    assert np.max(np.abs(xdot - v * np.cos(values["theta"]))) < 0.05  # the poses move at v
    assert np.max(np.abs(ydot - v * np.sin(values["theta"]))) < 0.05
    assert np.max(np.abs(np.gradient(v, t) - values["a"])) < 0.05  # a is v's rate
    lo, hi = ocp.bounds["a"]
    assert values["a"].min() >= LIMIT_SHARE * lo - 1e-9 and values["a"].max() <= LIMIT_SHARE * hi + 1e-9
    if jerk:
        assert np.abs(values["j"]).max() <= LIMIT_SHARE * 1.0 + 1e-9
    assert v.min() >= -LIMIT_SHARE * 3.0 - 1e-9 and v.max() <= LIMIT_SHARE * 8.33 + 1e-9
    forward_only = _rest_ocp(0.0, (0.0, 6.0, 0.0), jerk=jerk)
    assert limited_path_guess(forward_only.vehicle, path, 60, forward_only.bounds) is None
