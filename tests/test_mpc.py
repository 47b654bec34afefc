"""NMPC (model/simulation/mpc.py) in a small nominal closed loop of its own.

The plant here is the truck integrated accurately (scipy, rtol 1e-10) under a zero-order hold,
with a speed gain, a steering bias and an actuator delay added by hand, so these tests do not
depend on the simulation layer's plant.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model.problem.closed_loop import ControlSettings, Disturbance
from model.problem.scenario import load_scenario
from model.simulation.mpc import MPC, MPCSettings, TimeLayout
from model.simulation.mpc.rti import RealTimeIteration
from tests.conftest import ROOT

SCENARIOS = ROOT / "workflows" / "scenarios"


@dataclass
class Run:
    """A closed-loop run: final state, energy under the hold, per-step controller seconds."""

    final: np.ndarray
    energy: float
    seconds: list[float] = field(default_factory=list)


def truck_plant(wheelbase: float, gain: float = 1.0, bias: float = 0.0):
    """x' = g u1 cos th, y' = g u1 sin th, th' = g u1 tan(phi + b) / d, phi' = u2."""

    def f(_t, s, u):
        v = gain * u[0]
        return [v * math.cos(s[2]), v * math.sin(s[2]), v * math.tan(s[3] + bias) / wheelbase, u[1]]

    return f


def simulate(controller, x0, end, dt: float, plant, delay: int = 0) -> Run:
    """Zero-order hold at ``dt`` until ``end()`` (the last sample cut at the end); ``delay`` samples dead time."""
    t, x = 0.0, np.array(x0, dtype=float)
    pending = [np.zeros(2)] * delay
    run = Run(final=x, energy=0.0)
    while t < end() - 1e-9:
        t0 = time.perf_counter()
        u = np.asarray(controller(t, x, np.array(pending).reshape(-1, 2)), dtype=float)
        run.seconds.append(time.perf_counter() - t0)
        pending.append(u)
        acting = pending.pop(0)
        h = min(dt, end() - t)
        x = solve_ivp(plant, (t, t + h), x, args=(acting,), rtol=1e-10, atol=1e-10).y[:, -1]
        run.energy += 0.5 * h * float(acting @ acting)
        t += h
    run.final = x
    return run


def replay(solution, dt: float):
    """The open-loop controller: the optimum's controls at the sample times (delay known)."""
    cols = solution.columns

    def control(t, _y, pending):
        at = t + len(pending) * dt
        return np.array([np.interp(at, cols["t"], cols[c]) for c in ("u1", "u2")])

    return control


def errors(ocp, x: np.ndarray) -> tuple[float, float]:
    """Final position (m) and heading (rad) errors."""
    f = ocp.final
    return math.hypot(x[0] - f["x"], x[1] - f["y"]), abs(x[2] - f["theta"])


def start(ocp) -> list[float]:
    return [ocp.initial[s] for s in ocp.vehicle.states]


@pytest.fixture(scope="module")
def paper():
    """Scenario 2, case 1 (d = 0.02 m, energy, Tf = 1.53 s)."""
    sc = load_scenario(SCENARIOS / "s2-case1.toml")
    return sc.ocp.solve(intervals=sc.intervals)


@pytest.fixture(scope="module")
def truck_energy():
    """The closed-loop study's real truck (d = 5 m, energy-optimal right turn in 7 s)."""
    sc = load_scenario(SCENARIOS / "closed-loop" / "truck.toml")
    return sc.ocp.solve(intervals=sc.intervals)


@pytest.fixture(scope="module")
def real():
    """The real truck (d = 5 m, 10 m/s), first exit, time-optimal."""
    sc = load_scenario(SCENARIOS / "time-real-s1.toml")
    return sc.ocp.solve(intervals=sc.intervals)


# The paper's scale is 25 times faster than the real truck's (d / u1max = 0.02 s against 0.5 s):
# a 0.05 s hold there is coarser than the real truck's 0.1 s (at 0.1 s the hold alone costs
# 0.6 % of energy, see benchmarks/bench_mpc.py).
PAPER_DT = 0.05


def test_undisturbed_paper_scale_reproduces_the_optimum_energy(paper):
    mpc = MPC(paper, ControlSettings(PAPER_DT, 40))
    run = simulate(mpc.make_step, start(paper.ocp), lambda: mpc.final_time, PAPER_DT, truck_plant(0.02))
    position, heading = errors(paper.ocp, run.final)
    assert run.energy == pytest.approx(paper.energy, rel=0.01)
    assert position < 0.005 and heading < 0.02  # m on a 1 m scene; rad
    assert not any(s.get("used") is False for s in mpc.steps)
    assert np.max(np.abs(mpc.d_hat)) < 1e-3  # the estimate sees the integrator's error only


def test_undisturbed_real_truck_reaches_the_goal_at_the_optimum_time(real):
    mpc = MPC(real, ControlSettings(0.1, 40))
    run = simulate(mpc.make_step, start(real.ocp), lambda: mpc.final_time, 0.1, truck_plant(5.0))
    position, heading = errors(real.ocp, run.final)
    assert not mpc.offset_free  # the time objective: no disturbance estimate by default
    assert mpc.final_time == pytest.approx(real.final_time, rel=0.01)
    assert run.energy == pytest.approx(real.energy, rel=0.01)
    assert position < 0.05 and heading < 0.01
    assert np.median(run.seconds) < 0.5 * 0.1  # typical step well inside the sample (the max: bench_mpc.py)


@pytest.mark.parametrize(
    "case, dt, gain, bias",
    [("real", 0.1, 0.95, 0.02), ("paper", PAPER_DT, 0.97, 0.005)],
)
def test_disturbed_mpc_halves_the_open_loop_error(request, case, dt, gain, bias):
    sol = request.getfixturevalue(case)
    plant = truck_plant(sol.ocp.vehicle.wheelbase, gain, bias)
    open_loop = simulate(replay(sol, dt), start(sol.ocp), lambda: sol.final_time, dt, plant)
    mpc = MPC(sol, ControlSettings(dt, 40))
    closed = simulate(mpc.make_step, start(sol.ocp), lambda: mpc.final_time, dt, plant)
    assert errors(sol.ocp, closed.final)[0] <= 0.5 * errors(sol.ocp, open_loop.final)[0]
    assert errors(sol.ocp, closed.final)[1] <= 0.5 * errors(sol.ocp, open_loop.final)[1]


def delayed_runs(real, plant, delay: int) -> tuple[MPC, Run, Run]:
    """The same dead time against a controller that predicts through ``pending`` and one that ignores it."""
    untimed = MPCSettings(budget=100.0)  # what is tested is the prediction, not this machine's speed
    aware = MPC(real, ControlSettings(0.1, 40), Disturbance(delay=0.1 * delay), untimed)
    with_delay = simulate(aware.make_step, start(real.ocp), lambda: aware.final_time, 0.1, plant, delay=delay)
    blind = MPC(real, ControlSettings(0.1, 40), settings=untimed)

    def ignoring(t, y, _pending):
        return blind.make_step(t, y, np.zeros((0, 2)))

    without = simulate(ignoring, start(real.ocp), lambda: blind.final_time, 0.1, plant, delay=delay)
    return aware, with_delay, without


def test_a_known_delay_is_predicted_through(real):
    """One sample of dead time, nominal plant: the prediction is exact, so the goal is reached exactly."""
    aware, with_delay, without = delayed_runs(real, truck_plant(5.0), 1)
    assert aware.steps[0]["t"] == pytest.approx(0.1)  # the first plan starts where its control acts
    assert aware.steps[-1]["t"] == pytest.approx(aware.steps[-2]["t"] + 0.1)
    assert errors(real.ocp, with_delay.final)[0] < 0.01
    assert errors(real.ocp, without.final)[0] > 10 * errors(real.ocp, with_delay.final)[0]
    assert not any(s.get("used") is False for s in aware.steps)


def test_a_longer_delay_with_disturbance(real):
    _, with_delay, without = delayed_runs(real, truck_plant(5.0, 0.95, 0.02), 2)
    assert errors(real.ocp, with_delay.final)[0] < 0.5
    assert errors(real.ocp, with_delay.final)[0] < errors(real.ocp, without.final)[0]


def test_prediction_through_pending_controls_matches_the_model(real):
    mpc = MPC(real, ControlSettings(0.1, 40))
    u = np.array([[8.0, 0.2], [9.0, -0.1]])
    x = np.array(start(real.ocp))
    for held in u:
        x = solve_ivp(truck_plant(5.0), (0, 0.1), x, args=(held,), rtol=1e-11, atol=1e-11).y[:, -1]
    assert mpc.predict(np.array(start(real.ocp)), u) == pytest.approx(x, abs=1e-6)


def test_a_state_inside_the_keep_out_disc_gives_a_control(real):
    mpc = MPC(real, ControlSettings(0.1, 40))
    ob = real.ocp.obstacles[0]
    inside = np.array([ob.center[0] - 0.8 * ob.keep_out, ob.center[1] - 0.3 * ob.keep_out, -0.5, 0.1])
    u = mpc.make_step(1.0, inside, np.zeros((0, 2)))
    assert u.shape == (2,) and np.all(np.isfinite(u))
    lo, hi = zip(*(real.ocp.bounds[c] for c in ("u1", "u2")), strict=True)
    assert np.all(u >= np.array(lo) - 1e-9) and np.all(u <= np.array(hi) + 1e-9)


def test_a_failed_step_follows_the_previous_plan(real):
    mpc = MPC(real, ControlSettings(0.1, 40))
    first = mpc.make_step(0.0, np.array(start(real.ocp)), np.zeros((0, 2)))
    assert not mpc.failed and np.all(np.isfinite(first))
    planned = np.array([mpc.plan.mean(c, 0.1, 0.2) for c in ("u1", "u2")])
    u = mpc.make_step(0.1, np.array([np.nan, 0.0, 0.0, 0.0]), np.zeros((0, 2)))
    assert mpc.failed
    assert u == pytest.approx(planned)


def test_a_road_scenario_with_a_body_solves_its_steps():
    """Body discs in the roundabout corridor: the horizon starts from the reference (disc centres
    included, not zero: that is the island's centre, where the distance is not differentiable)."""
    sc = load_scenario(ROOT / "workflows" / "roads" / "truck-straight-on.toml")
    sol = sc.ocp.solve(intervals=sc.intervals)
    mpc = MPC(sol, ControlSettings(0.1, 40), settings=MPCSettings(budget=100.0))
    cols = sol.columns
    for t in (0.0, 0.1):
        y = np.array([np.interp(t, cols["t"], cols[k]) for k in sol.ocp.vehicle.states])
        y[1] += 0.2  # pushed sideways in its lane
        u = mpc.make_step(t, y, np.zeros((0, 2)))
        assert not mpc.failed and np.all(np.isfinite(u))


def test_time_layout_moves_node_values_in_time():
    n = 4
    fractions = np.concatenate([np.arange(n + 1) / n, np.arange(1, n + 1) / n, [np.nan]])
    layout = TimeLayout(fractions, n)
    old, new = np.linspace(0.0, 2.0, n + 1), np.linspace(0.5, 2.5, n + 1)
    vector = np.concatenate([3 * old, 3 * old[1:] + 1, [7.0]])
    moved = layout.move(vector, old, new)
    expect_nodes = 3 * np.minimum(new, 2.0)  # linear inside, held beyond the old end
    assert moved[: n + 1] == pytest.approx(expect_nodes)
    assert moved[n + 1 : 2 * n + 1] == pytest.approx(3 * np.minimum(new[1:], 2.0) + 1)
    assert moved[-1] == 7.0


def offset_runs(sol, dt: float, gain: float, bias: float) -> dict[bool, tuple[MPC, Run]]:
    """The same disturbed plant against the MPC with and without the disturbance estimate."""
    plant = truck_plant(sol.ocp.vehicle.wheelbase, gain, bias)
    out = {}
    for offset_free in (False, True):
        mpc = MPC(sol, ControlSettings(dt, 40), settings=MPCSettings(offset_free=offset_free, budget=100.0))
        out[offset_free] = (mpc, simulate(mpc.make_step, start(sol.ocp), lambda m=mpc: m.final_time, dt, plant))
    return out


def test_offset_free_mpc_ends_closer_under_a_persistent_disturbance(paper):
    """Paper scale, 3 % slower and a 5 mrad steering bias: the estimate ends closer in position and
    heading than the nominal model (measured 0.0018 m / 0.015 rad against 0.0082 m / 0.034 rad)."""
    runs = offset_runs(paper, PAPER_DT, 0.97, 0.005)
    (_, nominal), (mpc, estimated) = runs[False], runs[True]
    (position, heading), (position0, heading0) = errors(paper.ocp, estimated.final), errors(paper.ocp, nominal.final)
    assert position < 0.5 * position0 and heading < 0.7 * heading0
    assert mpc.d_hat[2] > 0  # the bias turns the truck faster than the model (positive phi + b)


def test_offset_free_mpc_reaches_the_real_truck_goal(truck_energy):
    """The study's real truck, 5 % slower and a 1-degree steering bias (level 1 without wind, delay or
    noise): within 2 % of the start-goal distance and 0.05 rad. The nominal model ends there too; the
    estimate ends with a smaller heading error, the position limited by u1 at its bound near the end."""
    ocp = truck_energy.ocp
    runs = offset_runs(truck_energy, 0.1, 0.95, 0.017)
    (plain, nominal), (mpc, estimated) = runs[False], runs[True]
    position, heading = errors(ocp, estimated.final)
    assert position <= 0.02 * ocp.straight_distance() and heading <= 0.05
    assert heading < errors(ocp, nominal.final)[1]
    assert not any(s.get("used") is False for s in plain.steps + mpc.steps)


@pytest.mark.parametrize("tolerance", [1.0, 0.0])
def test_a_step_stopped_early_is_used_exactly_when_feasible(real, tolerance):
    """One Ipopt iteration per step: an iterate within ``feasible_inf_pr`` is used and ``truncated``,
    one outside it is ``failed`` (the previous plan followed)."""
    ipopt = {**MPCSettings().ipopt, "max_iter": 1}
    mpc = MPC(real, ControlSettings(0.1, 40), settings=MPCSettings(ipopt=ipopt, feasible_inf_pr=tolerance))
    y = np.array(start(real.ocp))
    y[1] += 0.5
    mpc.make_step(0.0, y, np.zeros((0, 2)))
    step = mpc.steps[-1]
    assert step["status"] == "iteration_limit" and step["limit"]
    feasible = step["violation"] <= tolerance
    assert feasible == (tolerance > 0)
    assert step["used"] == step["truncated"] == mpc.truncated == feasible
    assert mpc.failed == (not feasible)


@pytest.fixture(scope="module")
def road():
    sc = load_scenario(ROOT / "workflows" / "roads" / "truck-straight-on.toml")
    return sc.ocp.solve(intervals=sc.intervals)


def rti_problem(mpc: MPC, start: float, push: float) -> np.ndarray:
    """Set the horizon's problem at ``start`` from the plan's state pushed sideways; the shifted warm start."""
    hm, plan = mpc.horizon, mpc.plan
    state = {k: float(np.interp(start, plan.times, plan.values[k])) for k in hm.states}
    state["y"] += push
    length, free = mpc._horizon(start)
    target, weights = mpc._target(start + length, final=free)
    times = start + np.linspace(0.0, length, hm.n + 1)
    hm.set_problem(state, length, free, target, weights, mpc.d_hat, times)
    x0 = hm.columns.move(plan.x, plan.times, times)
    for k, val in state.items():
        x0[hm.node_cols[k][0]] = val
    hm.fill_slacks(x0)
    return x0


def test_a_real_time_iteration_is_a_fixed_point_at_the_optimum_and_repairs_a_push(road):
    """From the horizon's own optimum the condensed SQP step is (almost) zero; from a state pushed
    0.2 m sideways one step brings the dynamics defects from decimetres to millimetres."""
    mpc = MPC(road, ControlSettings(0.1, 40), settings=MPCSettings(realtime=True, budget=100.0))
    hm = mpc.horizon
    x0 = rti_problem(mpc, 0.0, 0.0)
    res = hm.solve(x0, None, {"tol": 1e-10, "max_iter": 300})
    assert res.status == "optimal"
    mpc.rti.refresh_hessian()
    still = mpc.rti.step(res.x)
    assert still.success and still.step < 1e-3
    pushed = rti_problem(mpc, 0.1, 0.2)
    before = hm.violation(pushed)
    step = mpc.rti.step(pushed)
    assert step.success and before > 0.1
    assert hm.violation(step.x) < 0.02 * before


@pytest.mark.parametrize("interval_samples", [1, 2])
def test_real_time_steps_follow_the_road(road, interval_samples):
    """Real-time iterations in the closed loop (pushed 0.2 m at two samples): each step is used,
    most of them real-time iterations, and the controls stay finite and inside their bounds; with
    two samples per interval the same 4 s horizon has half the intervals."""
    control = ControlSettings(0.1, 40, interval_samples)
    mpc = MPC(road, control, settings=MPCSettings(realtime=True, budget=100.0))
    assert mpc.horizon.n == 40 // interval_samples and mpc.horizon_time == pytest.approx(4.0)
    cols = road.columns
    for t in np.arange(0.0, 0.6, 0.1):
        y = np.array([np.interp(t, cols["t"], cols[k]) for k in road.ocp.vehicle.states])
        y[1] += 0.2 if t in (0.0, 0.3) else 0.0
        u = mpc.make_step(float(t), y, np.zeros((0, 2)))
        assert not mpc.failed and np.all(np.isfinite(u))
        for c, val in zip(road.ocp.vehicle.controls, u, strict=True):
            lo, hi = road.ocp.bounds[c]
            assert lo - 1e-9 <= val <= hi + 1e-9
    assert sum(s["realtime"] for s in mpc.steps) >= 4


def test_a_capped_qp_gives_its_intermediate_iterate(road):
    """With qpOASES' working-set changes capped at 1 the pushed state's QP stops early: the step
    reports the cap, is accepted (the caller's violation test decides) and moves off the start."""
    settings = MPCSettings(realtime=True, budget=100.0, qp_options={"nWSR": 1})
    mpc = MPC(road, ControlSettings(0.1, 40), settings=settings)
    pushed = rti_problem(mpc, 0.1, 0.2)
    step = mpc.rti.step(pushed)
    assert step.status.startswith("Maximum number of working set recalculations")
    assert step.success and step.step > 0.0
    assert np.all(np.isfinite(step.x)) and not np.array_equal(step.x, pushed)


def test_the_stagewise_qp_takes_the_condensed_step(road):
    """The uncondensed QP in hpipm's stage layout (``qp_solver="hpipm"``) is the condensed QP written
    stage by stage: from the pushed state its step agrees with qpOASES' to the interior point's
    tolerance and repairs the dynamics as well."""
    mpc = MPC(road, ControlSettings(0.1, 40), settings=MPCSettings(realtime=True, budget=100.0))
    hm = mpc.horizon
    stagewise = RealTimeIteration(hm.model, hm.nlp, hm.states, "hpipm", mpc.settings.rti_regularization,
                                  controls=hm.controls)  # fmt: skip
    sw = stagewise.stagewise
    assert len(sw.nx) == hm.n + 1 and sw.nv == sum(sw.nx) + sum(sw.nu)
    pushed = rti_problem(mpc, 0.1, 0.2)
    before = hm.violation(pushed)
    dense, staged = mpc.rti.step(pushed), stagewise.step(pushed)
    assert dense.success and staged.success and staged.qp_iterations > 0
    assert np.max(np.abs(staged.x - dense.x)) < 1e-2 * dense.step
    assert hm.violation(staged.x) < 0.02 * before


def test_the_stagewise_qp_needs_the_controls(road):
    mpc = MPC(road, ControlSettings(0.1, 40), settings=MPCSettings(realtime=True, budget=100.0))
    with pytest.raises(ValueError, match="control names"):
        RealTimeIteration(mpc.horizon.model, mpc.horizon.nlp, mpc.horizon.states, "hpipm")


def test_without_the_realtime_key_a_receding_horizon_gets_the_real_time_iteration(road):
    """``realtime=None`` (a ``[control]`` without ``realtime``): a receding horizon's steps are real-time
    iterations; ``False`` keeps warm-started Ipopt; an iteration that cannot be built (no such QP
    solver) falls back to Ipopt with the reason, unless it was asked for by name."""
    control = ControlSettings(0.1, 40, 2)
    default = MPC(road, control, settings=MPCSettings(realtime=None, budget=100.0))
    assert default.rti is not None and default.mpc_step == "real-time iteration"
    assert "(real-time iteration, 20 intervals of 2 samples" in default.name
    u = default.make_step(0.0, np.array([road.columns[k][0] for k in road.ocp.vehicle.states]), np.zeros((0, 2)))
    assert np.all(np.isfinite(u)) and default.steps[-1]["realtime"]
    off = MPC(road, control, settings=MPCSettings(realtime=False, budget=100.0))
    assert off.rti is None and off.mpc_step == "warm-started Ipopt (realtime = false)"
    assert MPCSettings().realtime is False  # the class's own default is unchanged
    unbuilt = MPC(road, control, settings=MPCSettings(realtime=None, qp_solver="nosuch", budget=100.0))
    assert unbuilt.rti is None and "(warm-started Ipopt" in unbuilt.name
    assert unbuilt.mpc_step.startswith("warm-started Ipopt (the real-time iteration cannot be built")
    assert "nosuch" in unbuilt.mpc_step
    with pytest.raises(ValueError, match="nosuch"):
        MPC(road, control, settings=MPCSettings(realtime=True, qp_solver="nosuch"))


def test_without_the_realtime_key_a_shrinking_horizon_keeps_warm_started_ipopt(paper):
    """The whole remaining manoeuvre as the horizon: warm-started Ipopt, and the summary's reason says so."""
    mpc = MPC(paper, ControlSettings(0.05, "shrinking"), settings=MPCSettings(realtime=None, budget=100.0))
    assert mpc.rti is None
    assert mpc.mpc_step.startswith('warm-started Ipopt (horizon = "shrinking": the horizon is the whole remaining')
    asked = MPC(paper, ControlSettings(0.05, "shrinking"), settings=MPCSettings(realtime=True, budget=100.0))
    assert asked.rti is not None and asked.mpc_step == "real-time iteration"
