"""Solving map scenarios (issue 21 items 2 and 4, first cut): roundabout solve on a [map] route.

The Kackertstrasse SU-30 route of docs/map-corridor.md (90 -> 102, N = 60) solves and validates
with its bodies as exact rectangles inside the corridor; its commonroad.xml, read back with
commonroad-io, holds one DynamicObstacle per body following the trajectory; the SU-30's
route straight on at Thiergarten (21 -> 90, its second exit), which the map search does not solve, exits 1
with a diagnosis naming the body and how far it leaves the corridor; the SU-30 straight on at
Kackertstrasse, which the first cut refused, validates; the search honours its time limit.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely

from model.problem.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]

BASE = """
name = "{name}"

[vehicle]
preset = "SU-30"

[bounds]
u1 = [0.0, 6.944444444444445]
u2 = [-0.5, 0.5]
phi = [-0.6, 0.6]

[map]
dataset = "{dataset}"

[route]
{route}

[problem]
objective = "time"
intervals = 60
"""
KACKERT = ("rounD/DEU_Kackertstrasse-1",
           "from_lanelet = 90\nto_lanelet = 102\nstart_offset = 19.0\ngoal_offset = -12.0")  # fmt: skip
THIERGARTEN = ("rounD/DEU_Thiergarten-1", "from_lanelet = 21\nto_lanelet = 90\nstart_offset = 12.0\ngoal_offset = -8.0")
# Kackertstrasse straight on (90 -> 19, the goal on lane 42 as the map study poses it) and the U-turn 11 -> 19
# (SU-30): the first cut's centre-line sequence ended "Ipopt infeasible" on both (their goal poses lie outside the
# conservative strips of the front disc, 0.395 m on 90 -> 19: no strip rows at fixed poses since)
STRAIGHT = ("rounD/DEU_Kackertstrasse-1", "from_lanelet = 90\nto_lanelet = 42\nstart_offset = 2.3288\n"
            "goal_offset = -10.8152\napron_lanelets = [50]\napron_use = 'all'")  # fmt: skip


def solve(folder: Path, name: str, case: tuple[str, str], *extra: str) -> tuple[subprocess.CompletedProcess, Path,
                                                                             Path]:  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(BASE.format(name=name, dataset=case[0], route=case[1]))
    out = folder / "out"
    run = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out), "--quiet", *extra],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)  # fmt: skip
    return run, path, out


@pytest.fixture(scope="module")
def kackertstrasse(tmp_path_factory):
    pytest.importorskip("commonroad")
    return solve(tmp_path_factory.mktemp("kackert"), "kackert-su30", KACKERT)


def trajectory(out: Path) -> dict[str, np.ndarray]:
    lines = (out / "trajectory.csv").read_text().splitlines()
    names, rows = lines[0].split(","), [[float(v) if v else np.nan for v in line.split(",")] for line in lines[1:]]
    return {n: np.array(c) for n, c in zip(names, np.array(rows).T, strict=True)}


def test_the_kackertstrasse_su30_route_solves_and_validates(kackertstrasse):
    run, path, out = kackertstrasse
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "optimal" and summary["valid"]
    assert summary["final_time"] == pytest.approx(15.7521, abs=5e-3)  # docs/map-corridor.md, N = 60
    assert summary["min_clearance"] > 0 and summary["min_clearance_dense"] > 0
    ocp = load_scenario(path).ocp
    assert summary["route_lanelets"] == sorted(ocp.map_route.corridor_lanelets)
    # the start (19 m along the route) lies beyond lanelet 90 (7.6 m), on 82; the rounD lanelets overlap
    # at the ring's entries, so a body inside the corridor may also cover lanelets outside it
    assert {82, 102} <= set(summary["lanelets_used"]) and 90 not in summary["lanelets_used"]
    # independently of the solve: every body's exact rectangle inside the corridor at every node
    cols = trajectory(out)
    poses = ocp.vehicle.body_poses()
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(cols)
        corridor = ocp.map_route.corridor(name).buffer(1e-6)
        assert all(corridor.contains(shapely.Polygon(c)) for c in body.corners(x, y, h))
    swept = json.loads((out / "swept_path.geojson").read_text())
    assert [f["properties"]["body"] for f in swept["features"]] == list(ocp.bodies)
    area = shapely.geometry.shape(swept["features"][0]["geometry"])
    assert area.within(ocp.map_route.corridor("vehicle").buffer(1e-3))  # map coordinates, inside the corridor


def test_commonroad_xml_has_one_obstacle_per_body_following_the_trajectory(kackertstrasse):
    from commonroad.common.file_reader import CommonRoadFileReader

    run, path, out = kackertstrasse
    assert run.returncode == 0, run.stderr
    scenario, _ = CommonRoadFileReader(str(out / "commonroad.xml")).open()
    ocp = load_scenario(path).ocp
    assert len(scenario.dynamic_obstacles) == len(ocp.bodies)
    assert len(scenario.lanelet_network.lanelets) == len(ocp.map_route.map.network.lanelets)
    cols = trajectory(out)
    poses = ocp.vehicle.body_poses()
    for obstacle, (name, body) in zip(scenario.dynamic_obstacles, ocp.bodies.items(), strict=True):
        assert obstacle.obstacle_shape.length == pytest.approx(body.length)
        assert obstacle.obstacle_shape.width == pytest.approx(body.width)
        states = [obstacle.initial_state, *obstacle.prediction.trajectory.state_list]
        t = np.array([s.time_step for s in states]) * scenario.dt
        assert t[-1] <= cols["t"][-1] + 1e-9 and t[-1] > cols["t"][-1] - scenario.dt
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(cols)
        centre = body.corners(x, y, h).mean(axis=1)  # the rectangle's centre at the nodes
        expected = np.column_stack([np.interp(t, cols["t"], centre[:, 0]), np.interp(t, cols["t"], centre[:, 1])])
        got = np.array([s.position for s in states])
        assert np.max(np.linalg.norm(got - expected, axis=1)) < 0.01
        heading = np.interp(t, cols["t"], np.unwrap(h))
        assert np.max(np.abs(np.array([s.orientation for s in states]) - heading)) < 1e-3


def test_a_route_the_strips_do_not_solve_exits_1_with_a_diagnosis(tmp_path):
    """Thiergarten 21 -> 90, SU-30: the projections drift (3.7 m a solve) from every start tried; the quick
    search (the centre line, no minimal-violation step) keeps the test short."""
    pytest.importorskip("commonroad")
    run, _, out = solve(tmp_path, "thiergarten-su30", THIERGARTEN, "--search", "quick")
    assert run.returncode == 1, run.stderr
    assert "leaves the corridor by" in run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert not summary["valid"] and summary["min_clearance"] < 0
    diagnosis = summary["diagnosis"]
    assert diagnosis["kind"] == "map corridor" and "body_clearance" in diagnosis["failed_checks"]
    worst = max(diagnosis["bodies"], key=lambda b: b["outside"])
    deepest = -min(summary["min_clearance"], summary["min_clearance_dense"])
    assert worst["body"] == "vehicle" and worst["outside"] == pytest.approx(deepest, abs=1e-9)
    assert [s["start"] for s in summary["search"]["sequences"]] == ["centre line x0.5"]


def test_a_straight_on_route_the_first_cut_did_not_solve_now_validates(tmp_path):
    """The goal pose's strip rows are gone (``fixed_nodes``): the SU-30 straight on at Kackertstrasse
    validates from the centre line, its bodies inside the corridor at every node (checked here again,
    and against commonroad-drivability-checker's road boundary of the written commonroad.xml)."""
    pytest.importorskip("commonroad")
    pycrcc = pytest.importorskip("commonroad_dc.pycrcc")
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle

    run, path, out = solve(tmp_path, "kackert-straight", STRAIGHT)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["valid"] and summary["min_clearance"] > 0 and summary["min_clearance_dense"] > 0
    ocp = load_scenario(path).ocp
    cols = trajectory(out)
    poses = ocp.vehicle.body_poses()
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(cols)
        corridor = ocp.map_route.corridor(name).buffer(1e-6)
        assert all(corridor.contains(shapely.Polygon(c)) for c in body.corners(x, y, h))
    scenario, _ = CommonRoadFileReader(str(out / "commonroad.xml")).open()
    _, boundary = create_road_boundary_obstacle(scenario, method="aligned_triangulation", axis=2)
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(cols)
        centre = body.corners(x, y, h).mean(axis=1)
        shrunk = [pycrcc.RectOBB(body.length / 2 - 0.01, body.width / 2 - 0.01, float(a), float(cx), float(cy))
                  for a, (cx, cy) in zip(h, centre, strict=True)]  # fmt: skip
        assert not any(boundary.collide(r) for r in shrunk), name


def su30_left_21_90() -> dict:
    """The SU-30 from lanelet 21 to 90 of Thiergarten, N = 30: a scenario document."""
    return {"name": "t", "vehicle": {"preset": "SU-30"},
            "bounds": {"u1": [0.0, 6.944444444444445], "u2": [-0.5, 0.5], "phi": [-0.6, 0.6]},
            "map": {"dataset": THIERGARTEN[0]},
            "route": {"from_lanelet": 21, "to_lanelet": 90, "start_offset": 12.0, "goal_offset": -8.0},
            "problem": {"objective": "time", "intervals": 30}}  # fmt: skip


def test_the_map_search_honours_its_time_limit():
    """With a budget smaller than one solve the first strip solve still runs (an answer or the evidence
    of a failure), then nothing more: the sequence and the later steps are cut, and ``search`` says so."""
    pytest.importorskip("commonroad")
    from model.problem.scenario import parse_scenario

    ocp = parse_scenario(su30_left_21_90()).ocp
    lines: list[str] = []
    sol = ocp.solve(intervals=30, time_limit=0.01, progress=lines.append)
    search = sol.search
    assert [len(s["solves"]) for s in search["sequences"]] == [1]
    assert search["stopped_by_time_limit"] and search["steps_skipped"]
    assert any("time limit of 0.01 s reached" in line for line in lines)
    assert sum("solve 1] N = 30" in line for line in lines) == 1
    assert not sol.ok and sol.diagnosis["kind"] == "map corridor"


def solve_route(tmp_path, kind: str, movement: str, *extra: str, where: str = "Thiergarten", vehicle: str = "SU-30",
                refused: bool | None = False) -> tuple[dict, Path, Path, subprocess.CompletedProcess]:  # fmt: skip
    """One route posed as benchmarks/check_map_routes.py poses it (N = 100, with the apron), solved by
    ``roundabout solve`` with ``extra`` (exit 0, or 1 if ``refused``; None: either): (summary, scenario file,
    output folder, the run)."""
    pytest.importorskip("commonroad")
    from benchmarks.check_map_routes import MAPS, apron_lanelets, write_scenario
    from model.scene.lanelet_map import dataset_file, read_map

    case = {"map": where, "dataset": MAPS[where], "kind": kind, "movement": movement, "vehicle": vehicle,
            "apron": True, "apron_lanelets": apron_lanelets(read_map(dataset_file(MAPS[where])))}  # fmt: skip
    path = write_scenario(case, tmp_path, 100)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out), "--quiet", *extra],
                         cwd=ROOT, capture_output=True, text=True, timeout=900)  # fmt: skip
    assert refused is None or run.returncode == (1 if refused else 0), run.stderr
    return json.loads((out / "summary.json").read_text()), path, out, run


def solve_thiergarten_route(tmp_path, kind: str, movement: str) -> tuple[dict, Path, Path]:
    """One SU-30 route through Thiergarten solved by ``roundabout solve --map-grid arclength`` (``solve_route``)."""
    return solve_route(tmp_path, kind, movement, "--map-grid", "arclength")[:3]


def test_the_arclength_grid_solves_a_u_turn_the_time_grid_refuses(tmp_path):
    """Thiergarten 106 -> 108 (U-turn, SU-30, N = 100, posed as benchmarks/check_map_routes.py poses it): the
    time grid's projections creep (refused, 0.518 m outside); ``--map-grid arclength`` validates, and the
    benchmark's independent checks (its own corridor, re-integration, commonroad.xml) pass."""
    from benchmarks.check_map_routes import check

    summary, path, out = solve_thiergarten_route(tmp_path, "U-turn", "106-108")
    assert summary["valid"] and summary["min_clearance"] > 0 and summary["min_clearance_dense"] >= 0
    assert summary["search"]["sequences"][0]["grid"] == "arclength"
    assert 18.0 < summary["final_time"] < 26.0  # docs/map-corridor.md: 22.05 s
    assert check(path, out)["checks_pass"]


def test_tight_strips_solve_a_left_turn_the_default_strips_refuse(tmp_path):
    """Thiergarten 106 -> 90 (left, SU-30, N = 100, as benchmarks/check_map_routes.py poses it, seed 1): on the
    arclength grid the penalty sequence converges needing 0.062 m of slack, the rectangles 0.013 m outside (the
    default strips' conservatism); the tight strips' penalty sequence and its mid-interval rows validate it, and
    the benchmark's independent checks pass."""
    from benchmarks.check_map_routes import check

    summary, path, out = solve_thiergarten_route(tmp_path, "left", "106-90")
    sequences = summary["search"]["sequences"]
    assert summary["valid"] and summary["min_clearance"] > 0 and summary["min_clearance_dense"] >= 0
    assert not any(s["valid"] for s in sequences if "strips" not in s)  # the default strips validate nothing
    assert any(s["valid"] and s["strips"] == "tight" for s in sequences if "strips" in s)
    assert 17.0 < summary["final_time"] < 22.0  # benchmarks/map-routes.md: 18.954 s
    assert check(path, out)["checks_pass"]


def test_a_refusal_reports_the_converged_penalty_answer():
    """The diagnosis of a refused map route names the converged penalty answer's exact clearance and strip slack
    (``penalty_answer``), beside the excess of the failed answer it reports (which may be far smaller: Thiergarten
    21 -> 50, EU semitrailer, benchmarks/map-routes.md: the tractor 0.015 m, the penalty answer 0.335 m)."""
    pytest.importorskip("commonroad")
    from model.problem.scenario import parse_scenario
    from model.search.maps import diagnosis

    sol = parse_scenario(su30_left_21_90()).ocp.solve(intervals=30, time_limit=0.01)
    assert not sol.ok
    assert "penalty_answer" not in sol.diagnosis  # the time limit cut the search before any penalty sequence
    evidence = {"exact_clearance": -0.335, "largest_slack": 0.402, "summed_slack": 29.0, "strips": "default"}
    out = diagnosis(sol, None, evidence)
    assert out["penalty_answer"] == evidence
    assert (
        "penalty sequence (default strips) converged with the bodies' least exact clearance -0.335 m" in out["message"]
    )
    assert "0.402 m of strip slack at most" in out["message"]


def test_a_refusal_says_which_checks_the_loop_round_the_ring_failed():
    """Once round the ring an answer may have every body inside at the nodes and still fail between them
    (Thiergarten 51 -> 90, SU-30: +0.002 m at the nodes, the integrated motion 0.021 m out): the diagnosis says
    which checks failed and by how much, not only the positive clearance at the nodes."""
    pytest.importorskip("commonroad")
    from model.problem.scenario import parse_scenario
    from model.search.maps import diagnosis

    sol = parse_scenario(su30_left_21_90()).ocp.solve(intervals=30, time_limit=0.01)
    loop = {"loops": 1, "valid": False, "exact_clearance": 0.002, "failed_checks": {"dense_clearance": 0.0212}}
    out = diagnosis(sol, loop=loop)
    assert "once more round the ring nothing validated either (least exact clearance +0.002 m at the nodes; " \
           "failing dense_clearance 0.021)" in out["message"]
    assert out["loop"] == loop


@pytest.mark.slow
def test_a_right_turn_too_tight_for_the_semitrailer_validates_once_round_the_ring(tmp_path):
    """Kackertstrasse 104 -> 85 (right, EU semitrailer, N = 100, as benchmarks/check_map_routes.py poses it, seed 0):
    every step on the direct path converges with the trailer outside the lanelets (benchmarks/map-routes.md); the
    search's last step, the same route once more round the ring (the same corridor), validates, says so, and the
    benchmark's independent checks pass."""
    from benchmarks.check_map_routes import check

    summary, path, out, run = solve_route(tmp_path, "right", "104-85", where="Kackertstrasse", vehicle="EU-semitrailer")
    sequences = summary["search"]["sequences"]
    assert summary["valid"] and summary["route_loops"] == 1 and summary["search"]["loop"]["valid"]
    assert not any(s["valid"] for s in sequences if "loops" not in s)  # nothing validated on the direct path
    from model.analysis.validation import DENSE_CLEARANCE_TOL  # the linear sub-steps: within the integrated's 0.02 m

    assert summary["min_clearance"] > 0 and summary["min_clearance_dense"] >= -DENSE_CLEARANCE_TOL
    assert "1 more time(s) round the ring" in run.stdout
    direct = load_scenario(path).ocp.final["theta"]  # the goal heading of the direct path
    assert trajectory(out)["theta"][-1] == pytest.approx(direct + 2 * np.pi, abs=1e-3)
    assert 18.0 < summary["final_time"] < 30.0  # benchmarks/map-routes.md: 22.628 s
    assert check(path, out)["checks_pass"]


@pytest.mark.slow
def test_a_body_swinging_out_between_the_nodes_of_the_integrated_motion_is_backed_off(tmp_path):
    """Thiergarten 51 -> 90 (right, SU-30, seed 2 of benchmarks/check_map_routes.py): once round the ring the
    tight strips' mid-interval answer had every body inside at the nodes and on the linear sub-steps (+0.004 m),
    yet re-integrated from each node the SU-30 left the corridor by 0.165 m between them, and the solve said
    validated; with ``dense_clearance`` on maps it was refused (on 2N still 0.021 m out, at the end of an interval
    whose speed jumps from 0 to 5.1 m/s). The backed-off rows (``back_offs``) narrow the strips next to such
    intervals: validated, and the benchmark's independent checks pass (the integrated motion within 0.02 m)."""
    from benchmarks.check_map_routes import check

    summary, path, out, run = solve_route(tmp_path, "right", "51-90")
    best = next(s for s in summary["search"]["sequences"] if s["valid"])
    assert best["backed_off"] > 0 and best["intervals"] == 200 and best["loops"] == 1
    assert summary["validation"]["dense_clearance"]["passed"] and summary["route_loops"] == 1
    assert 26.0 < summary["final_time"] < 35.0  # benchmarks/map-routes.md: 30.773 s
    assert check(path, out)["checks_pass"]


@pytest.mark.slow
def test_a_u_turn_whose_tight_answer_cuts_between_the_nodes_validates_on_the_finer_grid(tmp_path):
    """Thiergarten 21 -> 23 (U-turn, SU-30, seeds 2 and 3 of benchmarks/check_map_routes.py): on the tight strips
    the penalty answer has every body inside at the nodes, but the free steps' one-step error (0.056 m) and the
    linear sub-steps fail, as they do after the mid-interval rows; the same on 2N validates (refused before,
    0.073 m outside between the nodes), and the benchmark's independent checks pass."""
    from benchmarks.check_map_routes import check

    summary, path, out, run = solve_route(tmp_path, "U-turn", "21-23")
    sequences = summary["search"]["sequences"]
    best = next(s for s in sequences if s["valid"])
    assert best["strips"] == "tight" and best["intervals"] == 200 and best["between"]
    assert summary["min_clearance"] > 0 and summary["route_loops"] == 0  # on the direct path
    assert 20.0 < summary["final_time"] < 27.0  # benchmarks/map-routes.md: 23.430 s
    assert check(path, out)["checks_pass"]
