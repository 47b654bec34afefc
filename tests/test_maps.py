"""Real roundabouts from CommonRoad lanelet maps (docs/map-format.md): reading, routes, corridors, poses, bad input.

The real maps are the rounD roundabouts of the installed commonroad-dataset-converter data
(DEU_Kackertstrasse-1, DEU_Neuweiler-1, DEU_Thiergarten-1); the hand-written ones are in
tests/data/maps/ (two parallel lanes and a sidewalk; files that are not maps). Routes and
corridors are checked against networkx on the same lanelet graph, computed here independently.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pyomo.environ as pyo
import pytest
import shapely

from model.errors import InputError
from model.problem.scenario import load_scenario
from model.scene.lanelet_map import MapRoute, dataset_file, dataset_names, read_map

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # commonroad-io's protobuf modules

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "maps"
EXAMPLE = ROOT / "examples" / "map-kackertstrasse-truck.toml"
ROUND = ["rounD/DEU_Kackertstrasse-1", "rounD/DEU_Neuweiler-1", "rounD/DEU_Thiergarten-1"]
# (map, from_lanelet, to_lanelet): through the ring where the map has one (Neuweiler's ring is open)
REAL_ROUTES = [(ROUND[0], 82, 102), (ROUND[1], 119, 107), (ROUND[2], 21, 108), (ROUND[2], 106, 23)]

CAR = """
[vehicle]
model = "truck"
wheelbase = 3.0

[vehicle.body]
length = 5.0
width = 2.0
rear_overhang = 1.0

[bounds]
u1 = [0.0, 5.0]
u2 = [-0.5, 0.5]
phi = [-0.6, 0.6]

[problem]
objective = "time"
intervals = 50
"""


def cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT)  # fmt: skip


def scenario_file(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def two_lanes(tmp_path: Path, route: str, extra: str = "") -> Path:
    """A scenario on tests/data/maps/two-lanes.xml (copied beside it: map.file is relative to the scenario)."""
    (tmp_path / "two-lanes.xml").write_bytes((DATA / "two-lanes.xml").read_bytes())
    return scenario_file(tmp_path, CAR + f'\n[map]\nfile = "two-lanes.xml"\n\n[route]\n{route}\n{extra}')


def graph(route: MapRoute, lane_changes: bool) -> nx.DiGraph:
    """The drivable lanelets and their successors (and same-direction neighbours), weighted by the
    centre-line length of the lanelet entered."""
    m, g = route.map, nx.DiGraph()
    for lanelet in m.network.lanelets:
        i = lanelet.lanelet_id
        nexts = list(lanelet.successor)
        if lane_changes:
            sides = ((lanelet.adj_left, lanelet.adj_left_same_direction),
                     (lanelet.adj_right, lanelet.adj_right_same_direction))  # fmt: skip
            nexts += [a for a, same in sides if a and same]
        for j in nexts:
            if m.drivable(i) and m.drivable(j):
                cv = m.lanelet(j).center_vertices
                g.add_edge(i, j, weight=float(np.sum(np.linalg.norm(np.diff(cv, axis=0), axis=1))))
    return g


# --------------------------------------------------------------------------- the real maps


def test_the_rounD_maps_are_installed_and_listed():
    names = dataset_names()
    for name in ROUND:
        assert name in names and dataset_file(name).is_file()
    assert "INTERACTION/DEU_Roundabout-1" in names


@pytest.mark.parametrize("name", ROUND)
def test_every_rounD_map_reads_with_drivable_lanelets(name):
    m = read_map(dataset_file(name))
    assert len(m.ids) >= 80
    kinds = {m.kind(i) for i in m.ids if not m.drivable(i)}
    assert any("sidewalk" in k or "border" in k for k in kinds)  # they are there, and kept out
    for i in m.ids:
        if m.drivable(i):
            assert m.polygon(i).is_valid and m.polygon(i).area > 0


@pytest.mark.parametrize(("name", "start", "goal"), REAL_ROUTES)
def test_real_route_is_the_shortest_successor_chain(name, start, goal):
    route = MapRoute(read_map(dataset_file(name)), start, goal)
    g = graph(route, lane_changes=False)
    path = route.lanelets
    assert path[0] == start and path[-1] == goal
    assert all(g.has_edge(a, b) for a, b in zip(path, path[1:], strict=False))
    best = nx.shortest_path_length(g, start, goal, weight="weight")
    mine = sum(g[a][b]["weight"] for a, b in zip(path, path[1:], strict=False))
    assert mine == pytest.approx(best, rel=1e-12)
    # the centre line is the lanelets' centre lines end to end (joined across the maps' mm gaps)
    lengths, lines = route.map.lengths, [route.map.lanelet(i).center_vertices for i in path]
    gaps = [float(np.linalg.norm(b[0] - a[-1])) for a, b in zip(lines, lines[1:], strict=False)]
    assert max(gaps) < 0.05
    assert route.line.length == pytest.approx(sum(lengths[i] for i in path) + sum(gaps), abs=1e-6)
    first, last = route.map.lanelet(start).center_vertices, route.map.lanelet(goal).center_vertices
    assert np.allclose(route.line.points[0], first[0]) and np.allclose(route.line.points[-1], last[-1])


@pytest.mark.parametrize(("name", "start", "goal"), REAL_ROUTES)
def test_real_corridor_is_every_lanelet_on_a_legal_path(name, start, goal):
    route = MapRoute(read_map(dataset_file(name)), start, goal)
    g = graph(route, lane_changes=False)
    legal = (nx.descendants(g, start) | {start}) & (nx.ancestors(g, goal) | {goal})
    assert route.corridor_lanelets == sorted(legal)
    rings = [c for c in nx.strongly_connected_components(g) if len(c) > 1]
    for ring in rings:  # a closed circulating ring the route passes through is in the corridor whole
        if ring & set(route.lanelets):
            assert ring <= set(route.corridor_lanelets)
    corridor = route.lanes
    assert corridor.is_valid
    parts = [route.map.polygon(i) for i in route.corridor_lanelets]
    assert corridor.area == pytest.approx(shapely.union_all(parts).area, rel=1e-3)
    assert corridor.buffer(1e-6).covers(shapely.LineString(route.line.points))


def test_kackertstrasse_ring_and_apron():
    route = MapRoute(read_map(dataset_file(ROUND[0])), 82, 102, apron_lanelets=(50,), apron_use="trailer")
    assert {45, 46, 48, 51, 53, 54, 55, 57} <= set(route.corridor_lanelets)  # the whole ring
    assert 50 not in route.corridor_lanelets  # the apron (a border lanelet) only where apron_use allows
    assert route.corridor("trailer").area > route.corridor("vehicle").area + 10
    assert route.corridor("vehicle").equals(route.lanes)


def test_start_and_goal_poses_lie_on_the_centre_lines():
    m = read_map(dataset_file(ROUND[0]))
    route = MapRoute(m, 82, 102, start_offset=12.0, goal_offset=-8.0)
    x, y, heading = route.start()
    assert route.line.project(np.array([x, y])) == pytest.approx(12.0, abs=1e-6)
    goal_line = shapely.LineString(m.lanelet(102).center_vertices)
    gx, gy, _ = route.goal()
    assert goal_line.distance(shapely.Point(gx, gy)) < 1e-9
    assert goal_line.line_locate_point(shapely.Point(gx, gy)) == pytest.approx(m.lengths[102] - 8.0, abs=1e-6)
    ahead = route.line.point(14.0) - route.line.point(10.0)
    assert abs(np.arctan2(ahead[1], ahead[0]) - heading) < 0.05


def test_the_example_checks_and_prints_the_route():
    out = cli("check", EXAMPLE)
    assert out.returncode == 0, out.stderr
    assert "route lanelets: 82 75 74 47 45 48 51 53 54 56 101 102" in out.stdout
    assert "corridor: 15 lanelets" in out.stdout and "area " in out.stdout and "route length: " in out.stdout


def test_simulating_or_deriving_a_map_is_refused_until_it_is_implemented(tmp_path):
    out = cli("simulate", EXAMPLE, "--out", tmp_path / "o", "--controller", "open-loop")
    assert out.returncode == 2 and "not implemented yet" in out.stderr
    assert not (tmp_path / "o").exists()
    with pytest.raises(InputError, match="not implemented"):
        load_scenario(EXAMPLE).ocp.pmp()


def test_checking_a_map_loads_no_solver():
    code = (
        "import sys; from model.cli import main; main(['check', 'examples/map-kackertstrasse-truck.toml']);"
        "print(sorted(m for m in ('pyomo', 'casadi', 'pandas', 'matplotlib', 'scipy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"


# --------------------------------------------------------------------------- the hand-written map


def test_lane_changes_only_where_allowed(tmp_path):
    m = read_map(DATA / "two-lanes.xml")
    with pytest.raises(InputError, match="route.to_lanelet: no path from lanelet 1 to lanelet 4"):
        MapRoute(m, 1, 4)
    route = MapRoute(m, 1, 4, lane_changes=True)
    assert route.steps == [(1, "start"), (3, "lane change"), (4, "successor")]
    assert route.corridor_lanelets == [1, 2, 3, 4]  # not the sidewalk 5 beside lanelet 1
    assert route.lanes.area == pytest.approx(4 * 20 * 3.5)
    assert route.line.points.tolist() == [[0, 1.75], [5, 1.75], [15, 5.25], [20, 5.25], [30, 5.25], [40, 5.25]]
    straight = MapRoute(m, 1, 2, lane_changes=True)  # a successor chain exists: no lane change taken
    assert straight.lanelets == [1, 2] and straight.corridor_lanelets == [1, 2, 3, 4]
    assert MapRoute(m, 1, 2).corridor_lanelets == [1, 2]


def test_a_scenario_on_the_hand_written_map(tmp_path):
    path = two_lanes(tmp_path, "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\ngoal_offset = -5.0")
    ocp = load_scenario(path).ocp
    assert ocp.road is None and ocp.map_route.lanelets == [1, 2]
    assert ocp.initial == {"x": 5.0, "y": 1.75, "theta": 0.0, "phi": 0.0}
    assert ocp.final == {"x": 35.0, "y": 1.75, "theta": 0.0}


BAD = {  # route table -> the key named in the one line (every one exits 2, writing nothing)
    "from_lanelet = 9\nto_lanelet = 2": "route.from_lanelet",
    "from_lanelet = 1\nto_lanelet = 5": "route.to_lanelet",  # a sidewalk
    "from_lanelet = 2\nto_lanelet = 1": "route.to_lanelet",  # no path
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 50.0": "route.start_offset",
    "from_lanelet = 1\nto_lanelet = 2\ngoal_offset = -21.0": "route.goal_offset",
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 0.0": "route.start_offset",  # the body sticks out behind
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\ngoal_offset = 19.0": "route.goal_offset",  # in front
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\nenter = 0": "route.enter",
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\nlane_changes = 1": "route.lane_changes",
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\napron_lanelets = [7]": "route.apron_lanelets",
    "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\napron_use = 'some'": "route.apron_use",
    "from_lanelet = 1.0\nto_lanelet = 2": "route.from_lanelet",
    "to_lanelet = 2": "route.from_lanelet",
}


@pytest.mark.parametrize("route", BAD, ids=list(BAD.values()))
def test_bad_routes_exit_2_with_one_line(tmp_path, route):
    out = cli("solve", two_lanes(tmp_path, route), "--out", tmp_path / "o")
    assert out.returncode == 2, out.stdout + out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"roundabout: invalid input: {BAD[route]}: "), lines
    assert not (tmp_path / "o").exists()


MAP_BAD = {
    'file = "missing.xml"': ("map.file", "no such file"),
    f'file = "{DATA / "not-xml.xml"}"': ("map.file", "not a CommonRoad XML file"),
    f'file = "{DATA / "not-commonroad.xml"}"': ("map.file", "not a CommonRoad XML file"),
    f'file = "{DATA / "no-lanelets.xml"}"': ("map.file", "no lanelets"),
    'dataset = "rounD/DEU_Kackerstrasse-1"': ("map.dataset", "did you mean 'rounD/DEU_Kackertstrasse-1'"),
    'dataset = "rounD/DEU_Kackertstrasse-1"\nfile = "x.xml"': ("map", "exactly one of map.file"),
    'url = "x"': ("map.url", "unknown key"),
}


@pytest.mark.parametrize("table", MAP_BAD, ids=[k for k, _ in MAP_BAD.values()])
def test_bad_maps_exit_2_with_one_line(tmp_path, table):
    path = scenario_file(tmp_path, CAR + f"\n[map]\n{table}\n\n[route]\nfrom_lanelet = 1\nto_lanelet = 2\n")
    out = cli("check", path)
    key, words = MAP_BAD[table]
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(lines) == 1, out.stderr
    assert lines[0].startswith(f"roundabout: invalid input: {key}: ") and words in lines[0], lines[0]


def test_a_map_without_a_route(tmp_path):
    path = scenario_file(tmp_path, CAR + '\n[map]\ndataset = "rounD/DEU_Neuweiler-1"\n')
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.key == "route"


def test_a_map_with_another_scene_or_the_other_route_format(tmp_path):
    route = "\n[route]\nfrom_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\n"
    disc = "\n[[obstacles]]\ncenter = [0.0, 50.0]\nradius = 1.0\n"
    ring = "\n[roundabout]\ncenter = [0.0, 0.0]\ninscribed_diameter = 40.0\ncirculatory_width = 6.0\n"
    for extra, key in ((disc, "map"), (ring, "map")):
        path = two_lanes(tmp_path, route.split("[route]\n")[1], extra)
        with pytest.raises(InputError) as err:
            load_scenario(path)
        assert err.value.key == key
    both = scenario_file(tmp_path, CAR + ring + "\n[route]\nenter = 0\nexit = 1\nfrom_lanelet = 3\n")
    with pytest.raises(InputError) as err:
        load_scenario(both)
    assert err.value.key == "route.from_lanelet"


def test_the_goal_heading_is_the_start_heading_plus_the_route_turn():
    m = read_map(dataset_file(ROUND[2]))
    u_turn = MapRoute(m, 21, 23)  # round the ring and back out of the same leg
    assert u_turn.turn() == pytest.approx(np.pi, abs=0.1)
    assert u_turn.goal()[2] - u_turn.start()[2] == pytest.approx(u_turn.turn(), abs=0.05)
    right = MapRoute(m, 106, 23)  # the bypass: a right turn
    assert right.goal()[2] - right.start()[2] == pytest.approx(right.turn(), abs=0.05) and right.turn() < -1.5


def test_a_looped_route_goes_once_more_round_the_ring_in_the_same_corridor():
    """Kackertstrasse 104 -> 85 (a right turn) looped: the ring's cycle of successors (found here with networkx)
    inserted after the first ring lanelet, the corridor unchanged, the turn and the goal heading 2 pi further."""
    m = read_map(dataset_file(ROUND[0]))
    right = MapRoute(m, 104, 85)
    loop = right.looped()
    assert loop is not None and loop.loops == 1 and right.loops == 0
    g = graph(right, lane_changes=False)
    first = next(i for i in right.lanelets if any(i in c for c in nx.simple_cycles(g)))
    k = right.lanelets.index(first)
    inserted = loop.lanelets[k + 1 : len(loop.lanelets) - len(right.lanelets) + k + 1]
    assert inserted[-1] == first and len(inserted) > 2
    assert all(g.has_edge(a, b) for a, b in zip([first, *inserted], inserted, strict=False))
    assert loop.lanelets[: k + 1] + loop.lanelets[k + 1 + len(inserted) :] == right.lanelets
    assert loop.corridor_lanelets == right.corridor_lanelets
    assert loop.turn() - right.turn() == pytest.approx(2 * np.pi, abs=0.1)
    assert loop.goal()[2] - right.goal()[2] == pytest.approx(2 * np.pi, abs=1e-9)
    assert loop.goal()[:2] == right.goal()[:2] and loop.start() == right.start()
    assert MapRoute(m, 104, 100).looped() is None  # two lanelets of one leg: no ring on the way


def test_a_chained_projection_follows_a_line_that_passes_a_place_twice():
    """On one and a half turns of a circle the nearest point of the line is ambiguous where it overlaps; with
    ``chain`` the points of a path project near their predecessor's projection, without it they jump a turn."""
    from model.scene.curvilinear import frame

    t = np.linspace(0.0, 3 * np.pi, 400)
    line = 10.0 * np.column_stack([np.cos(t), np.sin(t)])
    path = 1.05 * line[::10]  # outside the line, in the line's order
    chained = frame(line, chain=5.0).project(path[:, None, :])[:, 0]
    assert np.all(np.diff(chained) > 0) and chained[-1] > 80.0
    plain = frame(line).project(path)
    assert np.any(np.diff(plain) < 0)
    first_turn = frame(line[:130], chain=5.0)
    assert np.allclose(first_turn.project(path[:13, None, :])[:, 0], frame(line[:130]).project(path[:13]))


# --------------------------------------------------------------------------- the curvilinear frame (item 2 prototype)


def test_lateral_extents_of_a_straight_lane_and_a_ring():
    from model.scene.curvilinear import conservative, frame, lateral_extents

    lane = shapely.box(0.0, -1.5, 50.0, 2.5)  # the line runs along y = 0: 2.5 m to the left, 1.5 m to the right
    fr = frame(np.array([[0.0, 0.0], [50.0, 0.0]]), step=0.5, sigma=2.0)
    left, right = lateral_extents(lane, fr)
    inner = (fr.s > 1) & (fr.s < 49)
    assert np.allclose(left[inner], 2.5) and np.allclose(right[inner], 1.5)
    ring = shapely.Point(0, 0).buffer(20.0, 256).difference(shapely.Point(0, 0).buffer(14.0, 256))
    angles = np.linspace(0, 1.5 * np.pi, 200)
    fr = frame(17.0 * np.column_stack([np.cos(angles), np.sin(angles)]), step=0.25, sigma=1.0)  # ccw: island left
    left, right = lateral_extents(ring, fr)
    inner = (fr.s > 3) & (fr.s < fr.s[-1] - 3)
    assert np.allclose(left[inner] + right[inner], 6.0, atol=0.01)  # the smoothed circle lies 3 cm inside R = 17
    assert np.allclose(left[inner], 3.0, atol=0.05) and np.allclose(right[inner], 3.0, atol=0.05)
    k = int(np.argmin(np.abs(fr.s - 20.0)))
    bump = np.full(len(fr.s), 3.0)
    bump[k] = 0.5  # one narrow sample: within 2 m of it the conservative extent is 0.5, beyond it 3
    low = conservative(fr, bump, window=2.0)
    near, far = np.abs(fr.s - fr.s[k]) <= 2.0, np.abs(fr.s - fr.s[k]) > 2.0
    assert np.all(low[near] == 0.5) and np.all(low[far] == 3.0)


def test_the_curved_offset_is_the_distance_to_the_frames_circle():
    """docs/map-corridor.md (curved strips): the frame's curvature on a circle, and the offset from the
    osculating circle against R - |p - o| for points up to a quarter turn along it, either turn."""
    from model.direct.map_corridor import curved_offset
    from model.scene.curvilinear import frame

    angles = np.linspace(0, np.pi, 400)
    for sign in (1.0, -1.0):  # ccw (left turn, kappa > 0) and cw
        fr = frame(15.0 * np.column_stack([np.cos(angles), sign * np.sin(angles)]), step=0.25, sigma=1.0)
        inner = (fr.s > 5) & (fr.s < fr.s[-1] - 5)
        assert np.allclose(fr.curvature(fr.s[inner]), sign / 15.0, rtol=0.01)
        rng = np.random.default_rng(1)
        k = int(np.argmin(np.abs(fr.s - 20.0)))
        c, t, n, kappa = fr.points[k], fr.tangents[k], fr.normals[k], float(fr.curvature(fr.s[k]))
        centre = c + n / kappa
        p = c + rng.uniform(-12, 12, (50, 1)) * t + rng.uniform(-4, 4, (50, 1)) * n
        exact = np.sign(kappa) * (1 / abs(kappa) - np.linalg.norm(p - centre, axis=1))
        assert np.allclose(curved_offset((p - c) @ t, (p - c) @ n, kappa), exact, atol=1e-9)
    assert curved_offset(3.0, 0.7, 0.0) == 0.7  # a straight frame: the offset along the normal


@pytest.mark.parametrize("example", ["map-kackertstrasse-truck.toml", "map-kackertstrasse-semitrailer.toml"])
def test_the_strip_prototype_keeps_the_exact_rectangles_in_the_real_corridor(example):
    """docs/map-corridor.md: the fixed-projection strips, re-projected until they settle, on N = 40."""
    from model.direct.map_corridor import solve_map

    ocp = load_scenario(ROOT / "examples" / example).ocp
    result = solve_map(ocp, intervals=40, iterations=6)
    last = result.iterates[-1]
    checks = last.solution.validation["checks"]
    # at the nodes the rectangles stay inside; between them (judged since map scenarios solve,
    # ``body_clearance_dense`` and, on the integrated motion, ``dense_clearance``) N = 40 cuts an edge
    # (measured: the truck -4.0 cm, the semitrailer -31 cm)
    from model.analysis.validation import BETWEEN_NODES

    assert all(c["passed"] for k, c in checks.items() if k not in BETWEEN_NODES), checks
    assert last.moved < 0.05 and len(result.iterates) <= 4
    assert last.exact_clearance >= 0.0  # the rectangles, not the discs, in the shapely corridor
    route_length = ocp.map_route.goal_s - ocp.map_route.start_offset
    assert 0.8 * route_length / 6.944444444444445 < last.solution.final_time < 1.2 * route_length / 6.0


def test_disc_extents_keep_a_disc_inside_the_corridor():
    from model.scene.curvilinear import disc_extents, frame

    lane = shapely.box(0.0, -1.5, 50.0, 2.5)
    fr = frame(np.array([[0.0, 0.0], [50.0, 0.0]]), step=0.5, sigma=2.0)
    left, right = disc_extents(lane, fr, radius=1.0)
    inner = (fr.s > 1.5) & (fr.s < 48.5)
    assert np.allclose(left[inner], 1.5) and np.allclose(right[inner], 0.5)
    assert np.all(left[fr.s < 0.9] == -1.0)  # at the lane's start a disc of 1 m does not fit
    # a notch in the left edge: beside it the disc may move less, though the normal there misses the notch
    notched = lane.difference(shapely.box(24.0, 1.8, 26.0, 3.0))
    left, _ = disc_extents(notched, fr, radius=1.0)
    beside = np.abs(fr.s - 23.5) < 0.01
    assert np.all(left[beside] < 1.5) and np.all(left[beside] > 0.0)
    for k in np.flatnonzero(inner):  # every allowed centre keeps its disc in the corridor
        centre = shapely.Point(*(fr.points[k] + left[k] * fr.normals[k]))
        assert notched.buffer(1e-9).covers(centre.buffer(1.0 - 1e-6, 64))


def test_lanelet_polygons_agree_with_the_drivability_checkers_road_boundary():
    """Our lanelet polygons (left bound + reversed right bound, united) against an independent reading:
    commonroad-drivability-checker's road-boundary obstacle of the same map. A rectangle inside the
    union (clearance > 0) must not hit the boundary, one that reaches over the union's edge must."""
    import commonroad_dc.pycrcc as pycrcc
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle

    from model.scene.geometry import clearance
    from model.scene.lanelet_map import union

    m = read_map(DATA / "two-lanes.xml")
    road = union(m.polygon(i) for i in m.ids)  # the two lanes and the sidewalk: 40 m x 9 m
    _, boundary = create_road_boundary_obstacle(m.scenario, method="aligned_triangulation", axis=2)
    checked = 0
    for cx in (4.0, 10.0, 20.0, 30.0, 36.0):
        for cy in np.arange(-3.0, 8.01, 0.25):
            for heading in (0.0, 0.3):
                box = shapely.affinity.rotate(shapely.box(cx - 2, cy - 1, cx + 2, cy + 1), heading, use_radians=True)
                gap = clearance(road, np.asarray(box.exterior.coords)[:4])
                if abs(gap) < 1e-6:
                    continue  # touching: either answer is right
                hit = boundary.collide(pycrcc.RectOBB(2.0, 1.0, heading, cx, cy))
                assert hit == (gap < 0), (cx, cy, heading, gap)
                checked += 1
    assert checked > 350, checked


def test_the_relaxed_strips_measure_how_far_a_disc_must_leave_them(tmp_path):
    """Strips moved 0.5 m to the left of the whole route: the fixed start and goal put every cover
    disc 0.5 m right of its strip there, but those two nodes have no strip rows (``fixed_nodes``: the
    boundary values fix the pose, its exact rectangle is checked instead); the nodes next to them
    must leave their strips by less (the truck cannot step sideways), and in between the truck
    drives within the strips."""
    from model.direct.map_corridor import fixed_nodes, solve_map, strips

    path = two_lanes(tmp_path, "from_lanelet = 1\nto_lanelet = 2\nstart_offset = 5.0\ngoal_offset = -5.0")
    ocp = load_scenario(path).ocp
    assert fixed_nodes(ocp, 20) == {"vehicle": (0, 20)}
    st = strips(ocp)
    st.lower["vehicle"][:], st.upper["vehicle"][:] = 0.5, 1.0
    last = solve_map(ocp, intervals=20, iterations=3, st=st, relax=True).iterates[-1]
    total, largest = last.violation
    assert 0.1 < largest < 0.5 - 1e-3  # measured 0.252 m at the node next to the start or goal
    m = last.solution.model
    nodes = list(m.nodes)
    per_node = np.array([sum(pyo.value(v[t]) for v in m.strip_slacks) for t in nodes])
    assert abs(per_node[0]) < 1e-6 and abs(per_node[-1]) < 1e-6  # no rows there: their slacks go to 0
    assert per_node[1] > 0.1 and per_node[-2] > 0.1
    assert np.all(per_node[5:-5] < 1e-6)  # in between within the strips
    assert total == pytest.approx(per_node.sum(), abs=1e-9)


def test_the_arclength_grid_holds_each_node_at_its_arclength():
    """docs/map-corridor.md, the arclength grid: node k's reference point lies on the frame's normal at the
    fixed arclength s_k (``add_node_rows``; its projection is s_k), the steps are free (they sum to Tf and
    differ) and the answer validates as the time grid's does (N = 40, the truck at Kackertstrasse)."""
    from model.direct.map_corridor import node_arclengths, solve_map, strips

    ocp = load_scenario(ROOT / "examples" / "map-kackertstrasse-truck.toml").ocp
    st = strips(ocp)
    n = 40
    result = solve_map(ocp, intervals=n, iterations=6, st=st, arclength=True)
    last = result.iterates[-1]
    sol = last.solution
    assert sol.status in ("optimal", "validation_failed") and last.moved < 0.05
    checks = sol.validation["checks"]
    assert all(c["passed"] for k, c in checks.items() if k != "body_clearance_dense"), checks
    xy = np.column_stack([np.asarray(sol.columns[p], float) for p in ocp.vehicle.position])
    s = node_arclengths(ocp, n, st)
    c, tangent, _ = st.frame.at(s)
    assert np.max(np.abs(np.einsum("kd,kd->k", tangent, xy - c))) < 1e-6  # the row: on the normal at s_k
    # so each node's station is its s_k (the nearest point of the sampled frame: within 2 cm, its kinks)
    assert np.max(np.abs(st.frame.project(xy) - s)) < 0.03
    t = np.asarray(sol.columns["t"], float)
    steps = np.diff(t)
    assert t[0] == 0.0 and t[-1] == pytest.approx(sol.final_time) and np.all(steps > 0)
    assert steps.max() > 1.05 * steps.min()  # a free grid, not equal steps of Tf
    # on the time grid the same nodes' stations are not the equal steps of arclength
    timed = solve_map(ocp, intervals=n, iterations=6, st=st).iterates[-1].solution
    xy = np.column_stack([np.asarray(timed.columns[p], float) for p in ocp.vehicle.position])
    assert np.max(np.abs(st.frame.project(xy) - s)) > 0.1
