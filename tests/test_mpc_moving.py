"""The MPC on a crossing car: the horizon's moving obstacles follow the horizon's node times.

examples/crossing-car.toml in closed loop with a 0.2 s sample and a 4 s horizon (20 intervals),
the open-loop optimum on N = 60, Ipopt's per-step wall-time budget lifted (``MPCSettings.budget``:
on a loaded machine the default 0.8 x sample time stops most steps early, and that measures the
machine, not the controller). The bodies are checked as exact rectangles against the car's
(``model.simulation.loop.moving_distances``). The probe: the same run with the horizon's filler
removed (the car frozen where the first fill put it) collides.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pyomo.environ as pyo
import pytest

from model.analysis.bodies import moving_clearances
from model.direct.families import transcription_of
from model.direct.moving import moving_rows
from model.plotting.closed_loop import closed_loop_figure
from model.problem.closed_loop import ControlSettings
from model.problem.methods import DEFAULT_SOLVE, load_method
from model.problem.scenario import load_scenario
from model.simulation.loop import make_controller, simulate
from model.simulation.mpc import MPC, MPCSettings
from tests.conftest import ROOT
from tests.test_mpc import rti_problem

CROSSING = ROOT / "examples" / "crossing-car.toml"
CONTROL = ControlSettings(0.2, 20)


@pytest.fixture(scope="module")
def crossing():
    sc = load_scenario(CROSSING)
    sol = sc.ocp.solve(intervals=60, method=load_method(DEFAULT_SOLVE))
    assert sol.ok
    return sc, sol


def controller(crossing) -> MPC:
    sc, sol = crossing
    return MPC(sol, CONTROL, sc.disturbance, MPCSettings(budget=1e3))


def test_the_horizon_fills_the_car_at_its_absolute_node_times_with_soft_rows(crossing):
    sc, _ = crossing
    hm = controller(crossing).horizon
    m, car = hm.model, sc.ocp.moving_obstacles[0]
    times = 3.0 + np.linspace(0.0, 4.0, hm.n + 1)
    hm.set_node_times(times)
    centres, _ = car.discs(times)
    got = np.array([[pyo.value(m.moving_cx[0, j, t]), pyo.value(m.moving_cy[0, j, t])] for t in m.nodes
                    for j in range(centres.shape[1])]).reshape(centres.shape)  # fmt: skip
    assert got == pytest.approx(centres, abs=1e-12)
    assert pyo.value(m.moving_t0) == 3.0 and pyo.value(m.moving_tf_ref) == pytest.approx(4.0)
    moving_slacks = [v for v in transcription_of(m).slack_columns if v.local_name.startswith("moving_")]
    assert len(moving_slacks) == len(sc.ocp.bodies)  # one per body and obstacle, priced with the others
    assert all(v.ub > 0 for s in moving_slacks for v in s.values())


def test_mpc_keeps_the_bodies_clear_of_the_crossing_car_and_reaches_the_goal(crossing):
    sc, sol = crossing
    run = simulate(sc, sol, controller(crossing), sc.disturbance, CONTROL)
    s = run.summary
    safety = sc.ocp.moving_obstacles[0].safety
    clear = moving_clearances(sc.ocp, {k: run.columns[k] for k in ("t", *sc.ocp.vehicle.states)})
    assert np.all(clear >= 0.0)  # every sample: the bodies' rectangles at least the safety from the car's
    assert s["min_distance_moving"] == pytest.approx(float(np.min(clear)) + safety)
    assert s["min_distance_moving"] >= safety and not s["collided"]
    assert s["failed_steps"] == 0 and s["reached_goal"]


def test_probe_the_frozen_car_collides_and_the_summary_fails_the_run(crossing):
    sc, sol = crossing
    mpc = controller(crossing)
    mpc.horizon.model.node_parameters.clear()  # the car stays where the first fill (t = 0 .. Tf) put it
    s = simulate(sc, sol, mpc, sc.disturbance, CONTROL).summary
    assert s["min_distance_moving"] < sc.ocp.moving_obstacles[0].safety
    assert s["collided"] and not s["reached_goal"]


def test_a_real_time_step_meets_every_moving_row_by_raising_its_shared_slack(crossing):
    """The car's discs put 0.3 m beside the truck's planned nodes: a real-time iteration cannot move
    the truck off them in one step, so its slacks carry the rows. Each body's slack at a node is
    shared by the rows of the car's discs there, and the rows are met from above (``(r - s)^2 - d^2
    <= 0``): at the step's point every moving row holds, each shared slack raised by the largest
    need among its rows."""
    sc, sol = crossing
    mpc = MPC(sol, CONTROL, sc.disturbance, MPCSettings(realtime=True, budget=1e3))
    hm, m = mpc.horizon, mpc.horizon.model
    x0 = rti_problem(mpc, 1.0, 0.0)
    px, py = sc.ocp.vehicle.position
    X, Y = x0[hm.node_cols[px]], x0[hm.node_cols[py]]
    for (i, j, t) in m.moving_cx:
        k = list(m.nodes).index(t)
        m.moving_cx[i, j, t].set_value(float(X[k]) + 0.3 + 0.5 * j)
        m.moving_cy[i, j, t].set_value(float(Y[k]))
        m.moving_vx[i, j, t].set_value(0.0)
        m.moving_vy[i, j, t].set_value(0.0)
    hm.nlp.refresh_parameters()
    rows = np.concatenate([hm.nlp.rows_of(c) for _, c in moving_rows(m)])
    rows = rows[rows >= 0]
    nlp = hm.nlp
    nlp.set_primals(x0)
    g0 = nlp.evaluate_constraints()[rows]
    lb, ub = nlp.constraints_lb()[rows], nlp.constraints_ub()[rows]
    assert np.max(np.maximum(lb - g0, g0 - ub)) > 1.0  # the start violates the rows by metres squared
    step = mpc.rti.step(x0)
    assert step.success
    nlp.set_primals(step.x)
    g = nlp.evaluate_constraints()[rows]
    assert np.all(g >= lb - 1e-6) and np.all(g <= ub + 1e-6)


def test_the_scenario_s_own_control_table_drives_a_real_time_mpc_past_the_car(crossing):
    """``[control] realtime = true`` (as ``roundabout simulate --controller mpc`` reads it): every step
    a real-time iteration on 20 intervals of two samples; no failed step, the car cleared, the goal."""
    sc, sol = crossing
    assert sc.control.realtime and sc.control.intervals == 20
    mpc = make_controller("mpc", sol, sc.control, sc.disturbance)()
    assert mpc.settings.realtime and "real-time iteration, 20 intervals of 2 samples" in mpc.name
    run = simulate(sc, sol, mpc, sc.disturbance, sc.control)
    s = run.summary
    assert all(step["realtime"] for step in mpc.steps)
    assert s["failed_steps"] == 0 and not s["collided"] and s["reached_goal"]
    assert s["min_distance_moving"] >= sc.ocp.moving_obstacles[0].safety
    fig = closed_loop_figure(sc.ocp, sol.columns, run.columns, s)  # the car and the bodies drawn to scale
    labels = {p.get_label() for p in fig.axes[0].patches}
    assert {"other vehicle", "truck"} <= labels and "least distance to another vehicle" in fig._suptitle.get_text()
    plt.close(fig)


def test_the_same_file_without_the_realtime_key_runs_the_real_time_iteration(crossing, tmp_path):
    """examples/crossing-car.toml with its ``realtime = true`` line removed: the key absent, the MPC of
    ``roundabout simulate`` is still the real-time iteration (summary.json ``mpc_step`` says so), every
    step one, the car cleared by its safety and the goal reached."""
    sc, sol = crossing
    text = CROSSING.read_text()
    assert "\nrealtime = true\n" in text
    path = tmp_path / "no-key.toml"
    path.write_text(text.replace("\nrealtime = true\n", "\n"))
    plain = load_scenario(path)
    assert plain.control.realtime is None and plain.control.intervals == 20
    mpc = make_controller("mpc", sol, plain.control, plain.disturbance)()
    run = simulate(plain, sol, mpc, plain.disturbance, plain.control)
    s = run.summary
    assert s["mpc_step"] == "real-time iteration" and all(step["realtime"] for step in mpc.steps)
    assert s["failed_steps"] == 0 and not s["collided"] and s["reached_goal"]
    assert s["min_distance_moving"] >= plain.ocp.moving_obstacles[0].safety
