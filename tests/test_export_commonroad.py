"""One geometry, two routes (issue 21 item 5): ``roundabout export-commonroad`` and the 1 % check.

A parametric roundabout becomes a CommonRoad lanelet map (ring arcs between the junctions, entries
and exits, the apron as a closed border lanelet) whose corridor matches the parametric one, and a
map scenario of the same manoeuvre that ``roundabout solve`` solves to the same time within 1 %.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from model.cli import main
from model.problem.scenario import load_scenario
from model.problem.tables import toml_text
from model.scene.lanelet_map import MapRoute, read_map
from model.scene.roundabout_map import corridor_mismatch, roundabout_lanelets

ROOT = Path(__file__).resolve().parents[1]
TRUCK = ROOT / "examples" / "roundabout-truck.toml"


def roundabout(path: Path = TRUCK, **changes):
    data = tomllib.loads(path.read_text())
    data["roundabout"].update(changes)
    return data


def write(folder: Path, data: dict, name: str = "source.toml") -> Path:
    path = folder / name
    path.write_text(toml_text(data))
    return path


def export(folder: Path, source: Path, *extra: str) -> tuple[int, Path, Path]:
    xml, toml = folder / "map.xml", folder / "map.toml"
    code = main(["export-commonroad", str(source), "--out", str(xml), *extra])
    return code, xml, toml


@pytest.mark.parametrize("traffic", ["right", "left"])
def test_links_and_traffic_side(tmp_path, traffic):
    rb = load_scenario(write(tmp_path, roundabout(traffic=traffic))).ocp.road.roundabout
    net = roundabout_lanelets(rb, ring_lanes=2)
    k = len(rb.legs)
    assert [len(arcs) for arcs in net.ring] == [2 * k, 2 * k]
    for lane, arcs in enumerate(net.ring):
        for j, i in enumerate(arcs):
            assert arcs[(j + 1) % len(arcs)] in net.lanelets[i].successors
            d = net.lanelets[i]
            outer, inner = (d.right, d.left) if traffic == "right" else (d.left, d.right)
            r_out = np.hypot(*(outer - rb.center).T)
            assert np.allclose(r_out, rb.outer_radius - lane * rb.circulatory_width / 2)
            heading = np.cross(np.append(outer[1] - outer[0], 0), np.append(outer[0] - rb.center, 0))[2]
            assert np.sign(-heading) == rb.circulation  # arcs run in the circulation direction
    for i in range(k):
        first_arc = net.lanelets[net.entry[i]].successors
        assert len(first_arc) == 1 and first_arc[0] in net.ring[0]
        assert net.entry[i] in net.lanelets[first_arc[0]].predecessors
        (before,) = net.lanelets[net.exit[i]].predecessors
        assert before in net.ring[0] and net.exit[i] in net.lanelets[before].successors
        side = "adj_left" if traffic == "right" else "adj_right"
        assert getattr(net.lanelets[net.entry[i]], side) == (net.exit[i], False)
    apron = net.lanelets[net.apron]
    assert apron.kind == "border" and apron.predecessors == apron.successors == [net.apron]


@pytest.mark.parametrize("exit_number", [1, 2, 3, 4])
def test_the_map_corridor_is_the_parametric_one(tmp_path, exit_number):
    data = roundabout()
    data["route"]["exit"] = exit_number
    code, xml, toml = export(tmp_path, write(tmp_path, data))
    assert code == 0
    road = load_scenario(tmp_path / "source.toml").ocp.road
    route = load_scenario(toml).ocp.map_route
    for corridor, apron in ((route.lanes, False), (route.with_apron, True)):
        assert corridor.geom_type == "Polygon" and len(corridor.interiors) == 1  # no crack: only the island's hole
        found = corridor_mismatch(road.roundabout, road.route, corridor, apron=apron)
        assert found["fraction"] < 2e-4 and found["difference"] < 0.3, found
    assert np.allclose(route.start(), road.start(), atol=1e-3)
    assert np.allclose(route.goal(), road.goal(), atol=1e-3)  # the heading unwrapped alike: which way round


def test_a_coarse_sampling_is_measured_as_coarser(tmp_path):
    road = load_scenario(TRUCK).ocp.road
    found = {}
    for tol in (1e-2, 1e-4):
        code, xml, toml = export(tmp_path, TRUCK, "--tolerance", str(tol))
        assert code == 0
        found[tol] = corridor_mismatch(road.roundabout, road.route, load_scenario(toml).ocp.map_route.lanes)
    assert found[1e-4]["difference"] < found[1e-2]["difference"] / 5


def test_files_read_back_with_commonroad_io_and_our_reader(tmp_path):
    from commonroad.common.file_reader import CommonRoadFileReader

    code, xml, toml = export(tmp_path, TRUCK)
    assert code == 0
    scenario, problems = CommonRoadFileReader(str(xml)).open()
    types = {t.value for lanelet in scenario.lanelet_network.lanelets for t in lanelet.lanelet_type}
    assert types == {"urban", "border"} and len(problems.planning_problem_dict) == 0
    lanelet_map = read_map(xml)
    doc = tomllib.loads(toml.read_text())
    assert doc["map"]["file"] == "map.xml" and "roundabout" not in doc
    assert doc["vehicle"] == tomllib.loads(TRUCK.read_text())["vehicle"]
    route = MapRoute(lanelet_map, doc["route"]["from_lanelet"], doc["route"]["to_lanelet"])
    assert len(route.lanelets) >= 3
    check = subprocess.run([sys.executable, "-m", "model.cli", "check", str(toml)], cwd=ROOT, capture_output=True,
                           text=True, timeout=120)  # fmt: skip
    assert check.returncode == 0, check.stderr


@pytest.mark.parametrize(
    "case",
    ["missing", "no roundabout", "out is a folder", "ring lanes", "overwrites itself"],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, case):
    source = TRUCK
    args = []
    if case == "missing":
        source = tmp_path / "nope.toml"
    elif case == "no roundabout":
        source = ROOT / "examples" / "map-kackertstrasse-truck.toml"
    elif case == "out is a folder":
        (tmp_path / "map.xml").mkdir()
    elif case == "ring lanes":
        args = ["--ring-lanes", "0"]
    before = sorted(p.name for p in tmp_path.iterdir())
    if case == "overwrites itself":
        source = write(tmp_path, roundabout(), "map.toml")
        before = sorted(p.name for p in tmp_path.iterdir())
    code, _, _ = export(tmp_path, source, *args)
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("roundabout: invalid input:"), err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_the_same_manoeuvre_solved_both_ways_within_one_percent(tmp_path):
    """The rigid truck straight on (roundabout-truck.toml) at N = 40: parametric and on the exported map."""
    code, xml, toml = export(tmp_path, TRUCK)
    assert code == 0
    times = {}
    for name, source in (("parametric", TRUCK), ("map", toml)):
        out = tmp_path / name
        run = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(source), "--out", str(out), "--intervals",
                              "40", "--quiet"], cwd=ROOT, capture_output=True, text=True, timeout=300)  # fmt: skip
        assert run.returncode == 0, run.stderr
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "optimal" and summary["valid"]
        times[name] = summary["objective"]
    assert math.isclose(times["map"], times["parametric"], rel_tol=0.01), times
