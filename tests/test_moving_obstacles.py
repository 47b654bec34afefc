"""Moving obstacles (issue 19 item 1): the pose, the disc cover, the scenario key, the NLP rows, validation."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
import shapely
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from model import OCP, Energy, Truck
from model.analysis.bodies import rectangle_gaps
from model.analysis.validation import validate
from model.direct.bodies import disc_count as body_disc_count
from model.errors import InputError
from model.problem.scenario import load_scenario
from model.scene import Circle, MovingVehicle, Obstacle
from model.scene.moving import disc_count
from tests.conftest import ROOT, TRUCK_BOUNDS

CROSSING = ROOT / "examples" / "crossing-car.toml"


def crossing_point_problem() -> OCP:
    """The format example's truck (a point) driving 1 m along x in 4.5 s; a 0.3 x 0.1 m rectangle
    crosses x = 0.5 northwards at t = 2 s, where the straight drive at constant speed is at t = 2.25 s."""
    car = MovingVehicle(0.3, 0.1, trajectory=((0.0, 0.5, -1.0, math.pi / 2), (4.0, 0.5, 1.0, math.pi / 2)))
    return OCP(vehicle=Truck(0.1), cost=Energy(), bounds=TRUCK_BOUNDS, final_time=4.5,
               initial={"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}, final={"x": 1.0, "y": 0.0, "theta": 0.0},
               moving_obstacles=[car], name="crossing-point")  # fmt: skip


# -- the pose -----------------------------------------------------------------------------------
def test_sampled_heading_turns_the_short_way_round():
    car = MovingVehicle(4.5, 1.8, trajectory=((0.0, 0.0, 0.0, 3.1), (1.0, 1.0, 0.0, -3.1)))
    _, _, h = car.pose(np.array([0.0, 0.5, 1.0]))
    assert h[1] == pytest.approx(math.pi, abs=1e-12)  # through pi, not through 0
    assert h[2] - h[0] == pytest.approx(2 * math.pi - 6.2, abs=1e-12)


def test_sampled_pose_is_linear_between_and_held_outside_the_samples():
    car = MovingVehicle(4.5, 1.8, trajectory=((1.0, 0.0, 0.0, 0.0), (3.0, 4.0, 2.0, 1.0)))
    x, y, h = car.pose(np.array([-5.0, 1.0, 2.0, 3.0, 99.0]))
    assert x.tolist() == [0.0, 0.0, 2.0, 4.0, 4.0]
    assert y.tolist() == [0.0, 0.0, 1.0, 2.0, 2.0]
    assert h.tolist() == [0.0, 0.0, 0.5, 1.0, 1.0]
    vx, _, w = car.rate(np.array([0.5, 2.0, 3.5]))
    assert vx.tolist() == [0.0, 2.0, 0.0] and w.tolist() == [0.0, 0.5, 0.0]


@pytest.mark.parametrize("yaw_rate", [0.0, 1e-9, 0.4, -1.3])
def test_arc_prediction_matches_numeric_integration(yaw_rate):
    from scipy.integrate import solve_ivp

    car = MovingVehicle(4.5, 1.8, start=(3.0, -2.0, 0.7), speed=8.0, yaw_rate=yaw_rate)
    times = np.linspace(0.0, 6.0, 13)
    sol = solve_ivp(lambda t, s: [8.0 * math.cos(s[2]), 8.0 * math.sin(s[2]), yaw_rate], (0.0, 6.0),
                    [3.0, -2.0, 0.7], t_eval=times, rtol=1e-12, atol=1e-12)  # fmt: skip
    assert np.allclose(np.array(car.pose(times)), sol.y, atol=1e-8)
    vx, vy, w = car.rate(times)  # the rates are the right-hand side
    assert np.allclose([vx, vy], [8.0 * np.cos(sol.y[2]), 8.0 * np.sin(sol.y[2])], atol=1e-8)


@pytest.mark.parametrize("motion", [
    {"start": (1.0, 2.0, 0.3), "speed": 5.0, "yaw_rate": 0.5},
    {"trajectory": ((0.0, 0.0, 0.0, 0.0), (2.0, 4.0, 1.0, 1.0), (3.0, 4.0, 3.0, 2.5))},
])  # fmt: skip
def test_symbolic_keep_out_and_disc_velocities_agree_with_the_numeric_pose(motion):
    car = MovingVehicle(4.5, 1.8, safety=0.2, **motion)
    assert isinstance(car, Obstacle) and isinstance(Circle((0.0, 0.0), 1.0), Obstacle)
    x, y, t = sp.symbols("x y t", real=True)
    rows = car.constraint_at(x, y, t)
    centres, radius = car.discs(np.array([0.7, 2.4]))
    for k, when in enumerate((0.7, 2.4)):
        values = [float(c.subs({x: 10.0, y: -3.0, t: when})) for c in rows]
        assert values == pytest.approx(np.hypot(10.0 - centres[k, :, 0], -3.0 - centres[k, :, 1]) - radius - 0.2)
    eps = 1e-6  # inside a segment (samples) the disc centres move at disc_velocities
    numeric = (car.discs(np.array([0.7 + eps]))[0] - car.discs(np.array([0.7 - eps]))[0]) / (2 * eps)
    assert np.allclose(car.disc_velocities(np.array([0.7])), numeric, atol=1e-5)


# -- shapes ---------------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(
    length=st.floats(0.5, 20.0), width=st.floats(0.3, 4.0), x=st.floats(-50, 50), y=st.floats(-50, 50),
    heading=st.floats(-7.0, 7.0), u=st.lists(st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)), min_size=1,
                                            max_size=20),
)  # fmt: skip
def test_the_disc_cover_contains_the_rectangle(length, width, x, y, heading, u):
    car = MovingVehicle(length, width, trajectory=((0.0, x, y, heading),))
    centres, radius = car.discs(0.0)
    assert len(centres) == disc_count(length, width) == body_disc_count(length, width)
    assert radius <= 1.1 * width / 2 + 1e-12  # the bodies' slack: at most 10 % beyond the sides
    c, s = math.cos(heading), math.sin(heading)
    local = np.array(u + [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]) * [length, width]
    points = np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])
    distance = np.min(np.hypot(points[:, None, 0] - centres[:, 0], points[:, None, 1] - centres[:, 1]), axis=1)
    assert np.all(distance <= radius * (1 + 1e-9))


def test_point_clearance_is_the_exact_distance_to_the_rectangle():
    car = MovingVehicle(4.0, 2.0, safety=0.5, start=(1.0, 1.0, 0.6), speed=0.0)
    rect = car.rectangle(0.0)
    rng = np.random.default_rng(3)
    pts = rng.uniform(-6, 8, size=(200, 2))
    exact = np.array([rect.exterior.distance(shapely.Point(p)) * (-1 if rect.contains(shapely.Point(p)) else 1)
                      for p in pts])  # fmt: skip
    assert np.allclose(car.clearance_at(pts[:, 0], pts[:, 1], 0.0), exact - 0.5, atol=1e-12)


def test_rectangle_gaps_are_distances_apart_and_depths_when_overlapping():
    a = MovingVehicle(4.0, 2.0, start=(0.0, 0.0, 0.0), speed=0.0).corners(np.zeros(3))
    b = np.stack([MovingVehicle(4.0, 2.0, start=(dx, 0.0, 0.0), speed=0.0).corners(0.0) for dx in (7.0, 3.5, 0.0)])
    assert rectangle_gaps(a, b).tolist() == pytest.approx([3.0, -0.5, -2.0])


# -- the scenario key ------------------------------------------------------------------------------
HEAD = """[vehicle]\nmodel = "truck"\nwheelbase = 0.1\n[bounds]\nu1 = [-1.0, 1.0]\nu2 = [-0.35, 0.35]
[initial]\nx = 0.0\ny = 0.0\ntheta = 0.0\nphi = 0.0\n[final]\nx = 1.0\ny = 0.0\ntheta = 0.0
[problem]\nobjective = "energy"\nfinal_time = 4.5\n[[moving_obstacles]]\n"""
GOOD = "length = 0.3\nwidth = 0.1\ntrajectory = [[0, 0.5, -1, 1.57], [4, 0.5, 1, 1.57]]\n"
BAD_MOVING = {
    "no_motion": ("length = 0.3\nwidth = 0.1\n", "moving_obstacles[0].trajectory"),
    "both_forms": (GOOD + "start = [0, 0, 0]\nspeed = 1.0\n", "moving_obstacles[0].trajectory"),
    "no_length": ("width = 0.1\nstart = [2, 2, 0]\nspeed = 1.0\n", "moving_obstacles[0].length"),
    "zero_width": (GOOD.replace("width = 0.1", "width = 0.0"), "moving_obstacles[0].width"),
    "negative_length": (GOOD.replace("length = 0.3", "length = -1.0"), "moving_obstacles[0].length"),
    "negative_safety": (GOOD + "safety = -0.1\n", "moving_obstacles[0].safety"),
    "nan_sample": (GOOD.replace("[4, 0.5, 1, 1.57]", "[4, nan, 1, 1.57]"), "moving_obstacles[0].trajectory[1]"),
    "short_sample": (GOOD.replace("[4, 0.5, 1, 1.57]", "[4, 0.5, 1]"), "moving_obstacles[0].trajectory[1]"),
    "times_decrease": (GOOD.replace("[4, 0.5", "[0, 0.5"), "moving_obstacles[0].trajectory[1]"),
    "empty_trajectory": ("length = 0.3\nwidth = 0.1\ntrajectory = []\n", "moving_obstacles[0].trajectory"),
    "speed_with_samples": (GOOD + "speed = 1.0\n", "moving_obstacles[0].speed"),
    "no_speed": ("length = 0.3\nwidth = 0.1\nstart = [2, 2, 0]\n", "moving_obstacles[0].speed"),
    "short_start": ("length = 0.3\nwidth = 0.1\nstart = [2, 2]\nspeed = 1.0\n", "moving_obstacles[0].start"),
    "infinite_speed": ("length = 0.3\nwidth = 0.1\nstart = [2, 2, 0]\nspeed = inf\n", "moving_obstacles[0].speed"),
    "nan_yaw_rate": ("length = 0.3\nwidth = 0.1\nstart = [2, 2, 0]\nspeed = 1.0\nyaw_rate = nan\n",
                     "moving_obstacles[0].yaw_rate"),
    "unknown_key": (GOOD + "colour = 'red'\n", "moving_obstacles[0].colour"),
    "misspelled_key": (GOOD + "saftey = 0.1\n", "moving_obstacles[0].saftey"),
    "string_length": (GOOD.replace("length = 0.3", 'length = "long"'), "moving_obstacles[0].length"),
    "start_inside": ("length = 0.3\nwidth = 0.1\nstart = [0, 0, 0]\nspeed = 1.0\n", "initial.x"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD_MOVING))
def test_a_bad_moving_obstacle_exits_2_naming_the_key_and_writes_nothing(case, tmp_path):
    body, key = BAD_MOVING[case]
    path = tmp_path / "bad.toml"
    path.write_text(HEAD + body)
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out)],
                         capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and f"{key}:" in lines[0], res.stderr
    assert not out.exists()


def test_a_good_moving_obstacle_is_read_alone_with_discs_or_with_a_road(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(HEAD + GOOD + "[[moving_obstacles]]\nlength = 2\nwidth = 1\nstart = [5, 5, 0]\nspeed = -1\n"
                    "yaw_rate = 0.1\nsafety = 0.05\n")  # fmt: skip
    ocp = load_scenario(path).ocp
    assert [ob.safety for ob in ocp.moving_obstacles] == [0.0, 0.05]
    assert ocp.moving_obstacles[1].speed == -1.0 and ocp.moving_obstacles[0].trajectory[1] == (4.0, 0.5, 1.0, 1.57)
    path.write_text(path.read_text() + "[[obstacles]]\ncenter = [0.5, 0.5]\nradius = 0.1\n")
    assert len(load_scenario(path).ocp.obstacles) == 1
    road = load_scenario(CROSSING).ocp
    assert road.road is not None and len(road.moving_obstacles) == 1 and road.bodies


def test_the_python_dsl_takes_moving_vehicles_and_refuses_other_things():
    assert crossing_point_problem().moving_obstacles[0].length == 0.3
    with pytest.raises(InputError, match=r"moving_obstacles\[0\]"):
        OCP(**{**vars(crossing_point_problem()), "moving_obstacles": [Circle((3.0, 0.0), 0.1)]})


# -- the NLP and the validation -----------------------------------------------------------------------
def straight_through(ocp: OCP, n: int = 40) -> dict[str, np.ndarray]:
    """The drive at constant speed along x that ignores the obstacle: dynamically exact, through it."""
    t = np.linspace(0.0, ocp.final_time, n + 1)
    speed = ocp.final["x"] / ocp.final_time
    zero = np.zeros(n + 1)
    return {"t": t, "x": speed * t, "y": zero, "theta": zero, "phi": zero, "u1": zero + speed, "u2": zero}


def test_validation_fails_a_trajectory_forced_through_the_moving_obstacle():
    ocp = crossing_point_problem()
    report = validate(ocp, straight_through(ocp), ocp.final_time)
    checks = report["checks"]
    assert not report["passed"] and not checks["moving_clearance"]["passed"]
    assert all(c["passed"] for k, c in checks.items() if k != "moving_clearance")  # only the car is hit
    assert report["measures"]["min_clearance_moving"] == pytest.approx(0.125 - 0.15)  # at t = 2.25 s, x = 0.5
    free = OCP(**{**vars(ocp), "moving_obstacles": ()})
    assert validate(free, straight_through(free), free.final_time)["passed"]


def test_a_point_mass_solve_keeps_clear_of_the_moving_rectangle():
    ocp = crossing_point_problem()
    sol = ocp.solve(intervals=40, search="quick")
    assert sol.ok, sol.status
    m = sol.model
    assert len(m.moving_discs) == 7 == disc_count(0.3, 0.1) and len(m.moving_cx) == 7 * 41  # (obstacle, disc, node)
    centres, _ = ocp.moving_obstacles[0].discs(sol.columns["t"])
    filled = [m.moving_cy[0, 1, m.nodes[k]].value for k in (0, 20, 40)]  # indexed by node tau, like the states
    assert filled == pytest.approx(centres[[0, 20, 40], 1, 1].tolist())
    t, x, y = sol.columns["t"], sol.columns["x"], sol.columns["y"]  # the exact rectangle, checked here again
    car = ocp.moving_obstacles[0]
    gaps = [car.rectangle(tk).distance(shapely.Point(xk, yk)) for tk, xk, yk in zip(t, x, y, strict=True)]
    assert min(gaps) > 0 and sol.validation["measures"]["min_clearance_moving"] == pytest.approx(min(gaps))
    assert "mu_moving" in sol.columns and sol.columns["mu_moving"].max() > 0  # the car pushes the path away
    summary = sol.summary()
    assert summary["min_clearance_moving"] > 0 and "min_clearance_moving_dense" in summary
    cert = sol.certificate
    assert cert["items"]["hamiltonian"]["status"] == "not applicable" and "hamiltonian" in cert["not_applicable"]
    assert cert["items"]["adjoint"]["passed"] and cert["items"]["complementarity"]["passed"]


def test_a_warm_re_solve_with_another_final_time_moves_the_obstacle_to_the_new_node_times():
    from model import Resolver

    ocp = crossing_point_problem()
    first = ocp.solve(intervals=40, search="quick", accuracy=None)
    again = Resolver(first).solve(final_time=5.0)
    assert again.ok and again.final_time == 5.0
    centres, _ = ocp.moving_obstacles[0].discs(again.columns["t"])
    assert again.columns["t"][-1] == pytest.approx(5.0)
    filled = [again.model.moving_cy[0, 3, again.model.nodes[k]].value for k in (10, 40)]
    assert filled == pytest.approx(centres[[10, 40], 3, 1].tolist())
    assert again.validation["measures"]["min_clearance_moving"] >= 0


def test_the_crossing_car_road_example_solves_with_the_car_and_would_collide_without(tmp_path):
    """A free final time: the fixed point on Tf settles; every node clears the car's exact rectangle."""
    from model.direct.solve import solve_starts
    from model.search.multistart import start_values

    ocp = load_scenario(CROSSING).ocp
    n = 30
    sol = solve_starts(ocp, n, "none", [start_values(ocp, n, "none", None)])[0]
    assert sol.ok, sol.status
    fixed = sol.timings["moving_fixed_point"]
    assert fixed["settled"] and fixed["resolves"] >= 1
    assert float(sol.model.moving_tf_ref.value) == pytest.approx(sol.final_time, rel=1e-6)
    measures = sol.validation["measures"]
    assert measures["min_clearance_moving"] >= 0 and measures["min_clearance"] >= 0  # the car and the corridor
    car = ocp.moving_obstacles[0]
    from model.analysis.bodies import body_corners

    corners = body_corners(ocp, sol.columns)["vehicle"]
    gaps = [shapely.Polygon(c).distance(car.rectangle(t)) for c, t in zip(corners, sol.columns["t"], strict=True)]
    assert min(gaps) >= car.safety
    alone = OCP(**{**vars(ocp), "moving_obstacles": ()})
    ignored = solve_starts(alone, n, "none", [start_values(alone, n, "none", None)])[0]
    assert ignored.ok and ignored.final_time < sol.final_time  # the car costs time, ...
    hit = validate(ocp, ignored.columns, ignored.final_time)["checks"]["moving_clearance"]
    assert not hit["passed"]  # ... or a collision


def test_static_circle_problems_keep_their_objective():
    """The paper's s1 at N = 40 (one start): the objective main gives, 0.2585005675661006, to 1e-9."""
    ocp = load_scenario(ROOT / "workflows" / "scenarios" / "s1.toml").ocp
    sol = ocp.solve(intervals=40, search="quick")
    assert sol.ok and sol.objective == pytest.approx(0.2585005675661006, rel=1e-9)
    assert not hasattr(sol.model, "moving_discs")


# -- figures --------------------------------------------------------------------------------------------
def _other_vehicles(ax) -> list:
    from matplotlib.colors import to_rgb

    from model.plotting.figures import MOVING_COLOR

    return [p for p in ax.patches if tuple(p.get_edgecolor()[:3]) == pytest.approx(to_rgb(MOVING_COLOR))]


def test_the_figures_draw_the_other_vehicle_to_scale_at_the_bodies_times():
    import matplotlib.pyplot as plt
    import pandas as pd

    from model.plotting.figures import path_panel
    from model.plotting.roads import pose_nodes, road_figure

    ocp = crossing_point_problem()
    fig, ax = plt.subplots()
    path_panel(ax, pd.DataFrame(straight_through(ocp)), ocp)
    drawn = _other_vehicles(ax)
    assert len(drawn) == 5
    assert np.allclose(drawn[-1].get_xy()[:4], ocp.moving_obstacles[0].outline(4.5))  # the rectangle at Tf
    plt.close(fig)
    road = load_scenario(CROSSING).ocp  # a drive along x from the start to the goal: enough to draw
    t = np.linspace(0.0, 12.0, 41)
    cols = {"t": t, "x": np.linspace(-50.0, 50.0, 41), "y": np.full(41, -2.0), "theta": 0 * t, "phi": 0 * t,
            "u1": 0 * t + 100 / 12, "u2": 0 * t}  # fmt: skip
    fig = road_figure(road, cols)
    nodes = pose_nodes(road, cols)
    drawn = _other_vehicles(fig.axes[0])
    assert len(drawn) == len(nodes)
    car = road.moving_obstacles[0]
    assert np.allclose(drawn[3].get_xy()[:4], car.outline(t[nodes[3]]))
    assert np.ptp(drawn[3].get_xy()[:4, 0]) <= car.length + 1e-9  # to scale: 4.5 m x 1.8 m
    plt.close(fig)


def test_each_row_family_is_one_casadi_template():
    """The rules index only Pyomo components (no Python lookups by node), so Pyomo templatises them:
    one template per family instead of one expression walk per row (5 s more setup at N = 80)."""
    import casadi as ca

    from model.direct.transcription import build_model
    from model.nlp.casadi_nlp import CasadiNLP
    from model.nlp.pyomo_sx import PyomoToSX, component_rows

    cases = ((load_scenario(CROSSING).ocp, "moving_vehicle_keep_out"), (crossing_point_problem(), "moving_keep_out"))
    for ocp, name in cases:
        m = build_model(ocp, 10, "none")
        nlp = CasadiNLP(m)
        walk = PyomoToSX({id(v): i for i, v in enumerate(nlp.variables)}, ca.SX.sym("x", len(nlp.variables)),
                         {id(q): i for i, q in enumerate(nlp.params)}, ca.SX.sym("p", len(nlp.params)))  # fmt: skip
        rows = m.component(name)
        assert len(rows) == len(m.moving_discs) * len(m.tau) * (len(m.moving_vehicle_ahead) if ocp.bodies else 1)
        block = component_rows(rows, walk, [])
        assert block is not None and block.n == len(rows)


RECTANGLES = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-4, 4), st.floats(0.5, 6), st.floats(0.3, 3))


@settings(max_examples=80, deadline=None)
@given(a=RECTANGLES, b=RECTANGLES)
def test_rectangle_gaps_agree_with_shapely(a, b):
    """Apart: shapely's exact distance; overlapping: minus a depth no larger than either rectangle's half-diagonal."""
    ra, rb = (MovingVehicle(r[3], r[4], trajectory=((0.0, r[0], r[1], r[2]),)) for r in (a, b))
    ca, cb = ra.corners(np.zeros(1)), rb.corners(np.zeros(1))
    gap = float(rectangle_gaps(ca, cb)[0])
    pa, pb = shapely.Polygon(ca[0]), shapely.Polygon(cb[0])
    if pa.intersects(pb):
        assert gap <= 0 and -gap <= min(math.hypot(a[3], a[4]), math.hypot(b[3], b[4]))
        if pa.intersection(pb).area > 1e-9:  # moving b by the depth along some axis separates them: depth > 0
            assert gap < 0
    else:
        assert gap == pytest.approx(pa.distance(pb), abs=1e-12)


def test_a_tractor_semitrailer_keeps_both_bodies_clear_of_the_car():
    from model.direct.moving import moving_rows
    from model.direct.transcription import build_model

    ocp = load_scenario(ROOT / "examples" / "roundabout-semitrailer.toml").ocp
    ocp = OCP(**{**vars(ocp), "moving_obstacles": load_scenario(CROSSING).ocp.moving_obstacles})
    m = build_model(ocp, 10, "none")
    assert [family for family, _ in moving_rows(m)] == ["vehicle_moving", "trailer_moving"]
    assert len(m.moving_trailer_keep_out) == len(m.moving_discs) * len(m.moving_trailer_ahead) * 11
