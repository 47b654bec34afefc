"""The map study's model side (model/studies/maps.py): movements from a lanelet graph, a cell, its measures."""

from __future__ import annotations

import tomllib
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
import shapely

from model.cli import main
from model.errors import InputError
from model.problem.maps import map_of, pose_clearances
from model.problem.scenario import parse_scenario
from model.scene.lanelet_map import dataset_file, read_map
from model.studies.maps import (
    apron_gap,
    apron_use_measures,
    cell_document,
    cell_name,
    entries_and_exits,
    find_movement,
    movements,
    parse_cell,
    ring_lanelets,
    solve_cell,
    straight_state,
)
from model.studies.roads import preset_vehicle

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # commonroad-io's protobuf modules

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = ROOT / "workflows" / "scenarios" / "maps" / "kackertstrasse.toml"


@pytest.fixture(scope="module")
def kackertstrasse():
    return read_map(dataset_file("rounD/DEU_Kackertstrasse-1"))


@pytest.fixture(scope="module")
def template():
    return tomllib.loads(TEMPLATE.read_text())


def drivable_digraph(lanelet_map) -> nx.DiGraph:
    """The drivable lanelets and their successors, built here from commonroad-io's objects."""
    g = nx.DiGraph()
    for lanelet in lanelet_map.network.lanelets:
        if lanelet_map.drivable(lanelet.lanelet_id):
            g.add_node(lanelet.lanelet_id)
    for i in list(g.nodes):
        g.add_edges_from((i, j) for j in lanelet_map.lanelet(i).successor if j in g)
    return g


def test_kackertstrasse_movements_agree_with_networkx(kackertstrasse):
    g = drivable_digraph(kackertstrasse)
    ring = {i for c in nx.strongly_connected_components(g) if len(c) > 1 for i in c}
    entries = sorted(i for i in g if g.in_degree(i) == 0)
    exits = sorted(i for i in g if g.out_degree(i) == 0)
    assert ring_lanelets(kackertstrasse) == sorted(ring) and len(ring) == 8
    assert entries_and_exits(kackertstrasse) == (entries, exits)
    found = {m.name: m for m in movements(kackertstrasse)}
    expected = {f"{a}-{b}" for a in entries for b in exits
                if a != b and nx.has_path(g, a, b) and any(ring & set(p) for p in nx.all_simple_paths(g, a, b))}
    assert set(found) == expected and len(found) == 20  # 4 entries x 5 exits; 18 -> 13 bypasses the ring
    assert "18-13" not in found and {"90-102", "11-19", "104-84"} <= set(found)
    for m in found.values():  # each a chain of successors from its entry to its exit through the ring
        assert m.lanelets[0] == m.entry and m.lanelets[-1] == m.exit and ring & set(m.lanelets)
        assert all(g.has_edge(a, b) for a, b in zip(m.lanelets, m.lanelets[1:], strict=False))


def test_neuweilers_open_ring_is_closed_by_the_links_the_map_leaves_out():
    lanelet_map = read_map(dataset_file("rounD/DEU_Neuweiler-1"))
    g = drivable_digraph(lanelet_map)
    assert not any(len(c) > 1 for c in nx.strongly_connected_components(g))  # open in the map
    ring = set(ring_lanelets(lanelet_map))
    assert {113, 126, 150, 155, 158, 164, 169, 172, 174, 177} <= ring and not ring & {107, 119, 157, 182}
    end, start = (shapely.Point(lanelet_map.lanelet(i).center_vertices[k]) for i, k in ((177, -1), (158, 0)))
    assert lanelet_map.polygon(150).contains(end) and lanelet_map.polygon(155).contains(start)
    entries, exits = entries_and_exits(lanelet_map)  # the gap's ends are neither
    assert 158 not in entries and not {160, 177} & set(exits) and {119, 137, 166} <= set(entries)
    found = {m.name: m for m in movements(lanelet_map)}
    assert {"119-182", "137-157", "166-107", "166-201"} <= set(found)
    for m in found.values():  # real chains of successors (the added links only find the ring)
        assert all(g.has_edge(a, b) for a, b in zip(m.lanelets, m.lanelets[1:], strict=False))
        assert ring & set(m.lanelets)


def test_an_exported_roundabout_has_every_entry_exit_pair(tmp_path):
    xml = tmp_path / "map.xml"
    assert main(["export-commonroad", str(ROOT / "examples" / "roundabout-truck.toml"), "--out", str(xml)]) == 0
    lanelet_map = read_map(xml)
    legs = range(4)
    assert {m.name for m in movements(lanelet_map)} == {f"{100 + a}-{200 + b}" for a in legs for b in legs}
    assert ring_lanelets(lanelet_map) == sorted(i for i in lanelet_map.ids if 1000 <= i < 2000)


def test_a_map_without_a_ring_has_no_movements():
    lanelet_map = read_map(ROOT / "tests" / "data" / "maps" / "two-lanes.xml")
    assert ring_lanelets(lanelet_map) == [] and movements(lanelet_map) == []


def test_cell_names_round_trip_and_bad_ones_are_refused(kackertstrasse):
    for preset, movement, apron in (("EU-semitrailer", "90-102", True), ("SU-30", "11-19", False)):
        assert parse_cell(cell_name(preset, movement, apron)) == (preset, movement, apron)
    for bad in ("SU-30_90-102", "SU-30_90102_apron", "SU-30_90-102_yes"):
        with pytest.raises(InputError, match="cell"):
            parse_cell(bad)
    with pytest.raises(InputError, match="movement.*90-90.*movements: 11-19"):
        find_movement(kackertstrasse, "90-90")


@pytest.mark.parametrize(("preset", "apron", "use", "articulation"), [
    ("SU-30", True, "all", False), ("EU-semitrailer", True, "trailer", True), ("P", True, "none", False),
    ("EU-semitrailer", False, "none", True),
])  # fmt: skip
def test_a_cell_document_poses_the_movement_with_every_body_inside(kackertstrasse, template, preset, apron, use,
                                                                    articulation):  # fmt: skip
    doc = cell_document(template, kackertstrasse, preset, "90-102", apron, 40)
    route = doc["route"]
    movement = find_movement(kackertstrasse, "90-102")
    assert route["from_lanelet"] == 90 and route["to_lanelet"] in movement.lanelets[-3:]
    assert route["apron_use"] == use and route["apron_lanelets"] == ([50] if apron else [])
    assert doc["vehicle"] == {"preset": preset}
    assert ("phi" in doc["bounds"]) == (preset_vehicle(preset)[2] is None)  # the template's only without the preset's
    assert ("articulation" in doc["bounds"]) == articulation
    assert doc["problem"]["intervals"] == 40 and doc["name"] == cell_name(preset, "90-102", apron)
    ocp = parse_scenario(doc, path=TEMPLATE).ocp  # refuses a start or goal with a body outside the corridor
    assert ocp.map_route.lanelets[0] == 90 and ocp.map_route.apron_use == use
    # the start is the least offset (in 1 m steps) at which the vehicle fits: 1 m less leaves the corridor
    back = {**doc, "route": {**route, "start_offset": route["start_offset"] - 1.0}}
    if back["route"]["start_offset"] >= 0:
        with pytest.raises(InputError, match="route.start_offset"):
            parse_scenario(back, path=TEMPLATE)


def test_a_vehicle_that_cannot_stand_on_the_exit_is_refused(kackertstrasse, template):
    with pytest.raises(InputError, match="movement.*11-19.*no goal pose of the WB-62"):
        cell_document(template, kackertstrasse, "WB-62", "11-19", True, 40)


def test_the_apron_measures_bound_what_is_on_the_apron(kackertstrasse, template):
    doc = cell_document(template, kackertstrasse, "SU-30", "90-102", True, 40)
    ocp = parse_scenario(doc, path=TEMPLATE).ocp
    route = ocp.map_route
    gap = apron_gap(route)
    centre = shapely.centroid(kackertstrasse.polygon(50))  # lanelet 50: a narrow ring inside the ring's inner edge
    outer = max(centre.distance(shapely.Point(p)) for p in kackertstrasse.polygon(50).exterior.coords)
    assert gap > 1.0 and gap == pytest.approx(centre.distance(route.lanes) - outer, abs=0.05)
    vehicle, bodies, _ = preset_vehicle("SU-30")
    r = vehicle.roles

    def at(x, y, heading):
        state = straight_state("SU-30", heading) | {r.x: x, r.y: y}
        return {"t": np.array([0.0, 1.0]), **{k: np.full(2, v) for k, v in state.items()}}

    x, y, heading = route.start()
    assert apron_use_measures(ocp, at(x, y, heading), route.apron_lanelets) == {"apron_area_m2": 0.0,
                                                                                "apron_used_m": 0.0}
    apron = kackertstrasse.polygon(50)
    cx, cy = np.asarray(kackertstrasse.lanelet(50).center_vertices)[0]
    across = at(cx, cy, 0.3)  # a truck parked across the apron ring
    got = apron_use_measures(ocp, across, route.apron_lanelets)
    corners = bodies["vehicle"].corners(cx, cy, 0.3)
    rect = shapely.Polygon(corners)
    # the apron region: lanelet 50 and, with the template's apron_gap, the strip it paves between it and the lanes
    region = apron.union(route.with_apron.difference(route.lanes)).difference(route.lanes)
    assert route.apron_gap > gap and region.area > apron.difference(route.lanes).area
    assert got["apron_area_m2"] == pytest.approx(rect.intersection(region).area, rel=0.02)
    on_apron = rect.intersection(region)  # sampled on a 2 cm grid inside it
    x0, y0, x1, y1 = on_apron.bounds
    grid = shapely.points(np.stack(np.meshgrid(np.arange(x0, x1, 0.02), np.arange(y0, y1, 0.02)), -1).reshape(-1, 2))
    inside = grid[shapely.contains(on_apron, grid)]
    deepest = float(np.max(shapely.distance(inside, route.lanes)))
    assert got["apron_used_m"] == pytest.approx(deepest, abs=0.03)
    assert apron_use_measures(ocp, across, ()) == {"apron_area_m2": 0.0, "apron_used_m": 0.0}
    assert min(pose_clearances(route, vehicle, bodies, {k: v[0] for k, v in across.items()}).values()) < 0


def test_apron_gap_paves_the_strip_between_the_lanes_and_the_apron(kackertstrasse, template):
    """docs/map-format.md: with apron_gap = g the apron is A | (close(C | A, g) - close(C, g)); 0: the lanelets."""
    import dataclasses

    doc = cell_document(template, kackertstrasse, "EU-semitrailer", "90-102", True, 40)
    route = parse_scenario(doc, path=TEMPLATE).ocp.map_route
    lanelets = dataclasses.replace(route, apron_gap=0.0)
    gap = apron_gap(route)  # 2.1 m on this map: the strip no lanelet covers
    narrow = dataclasses.replace(route, apron_gap=0.5 * gap)  # narrower than the strip: nothing paved
    assert lanelets.with_apron.area == pytest.approx(narrow.with_apron.area, rel=1e-6)
    assert route.with_apron.area > lanelets.with_apron.area + 50.0  # the ring of the strip round the island
    assert route.with_apron.contains(lanelets.with_apron.buffer(-1e-6))
    with pytest.raises(InputError, match="apron_gap"):
        dataclasses.replace(route, apron_gap=-1.0)


def test_the_template_names_a_map_with_its_apron(template):
    lanelet_map = map_of(template, TEMPLATE.parent)
    assert template["route"]["apron_lanelets"] == [50] and 50 in lanelet_map.ids
    with pytest.raises(InputError, match="map"):
        map_of({"route": {}})


class FakeSolution:
    """What solve_cell reads of a Solution: ok, status, the validation's checks."""

    def __init__(self, intervals: int, failed: list[str]):
        self.intervals, self.status = intervals, "validation_failed" if failed else "optimal"
        self.validation = {"checks": {k: {"passed": k not in failed} for k in ("body_clearance", "body_clearance_dense",
                                                                                 *failed)}}  # fmt: skip
        self.ok = not failed


class FakeOCP:
    def __init__(self, outcomes: dict[int, list[str]]):
        self.outcomes, self.asked = outcomes, []

    def solve(self, intervals: int):
        self.asked.append(intervals)
        return FakeSolution(intervals, self.outcomes[intervals])


@pytest.mark.parametrize(("outcomes", "asked", "ok"), [
    ({100: []}, [100], True),                                                    # passes: one solve
    ({100: ["body_clearance_dense"], 200: []}, [100, 200], True),                # only between nodes: 2N
    ({100: ["body_clearance_dense"], 200: ["body_clearance_dense"]}, [100, 200], False),  # and no further
    ({100: ["body_clearance", "body_clearance_dense"]}, [100], False),           # at the nodes too: no re-solve
    ({100: ["one_step_error"], 200: []}, [100, 200], True),                      # a free step's accuracy: 2N
    ({100: ["body_clearance", "one_step_error"]}, [100], False),                 # with the nodes: no re-solve
])  # fmt: skip
def test_a_cell_is_solved_again_on_2n_only_where_it_fails_between_the_nodes(outcomes, asked, ok):
    ocp = FakeOCP(outcomes)
    solution, tried = solve_cell(ocp, 100)
    assert ocp.asked == asked and [t["intervals"] for t in tried] == asked and solution.ok == ok
    assert tried[-1]["valid"] == ok and tried[0]["failed_checks"] == outcomes[100]


@pytest.mark.parametrize("preset", ["SU-30", "EU-semitrailer"])
def test_an_operational_cell_poses_and_starts_with_the_longitudinal_states(kackertstrasse, template, preset):
    """At the preset's limits (free a at the start, v the crawl speed) the poses are checked and the map search's
    centre-line start carries every state (both raised KeyError 'a' before)."""
    from model.direct.map_corridor import centre_line_start, strips
    from model.vehicles import operational_limits

    doc = cell_document(template, kackertstrasse, preset, "90-102", True, 40, operational=True)
    ocp, lim = parse_scenario(doc, path=TEMPLATE).ocp, operational_limits(preset)
    assert doc["vehicle"] == {"preset": preset, "operational": True} and "u1" not in doc["bounds"]
    assert ocp.bounds["v"] == tuple(template["bounds"]["u1"]) and ocp.initial["v"] == lim.crawl_speed
    assert ocp.bounds["a"] == lim.acceleration and "a" not in ocp.initial  # a free at the start
    start = centre_line_start(ocp, 40, strips(ocp))
    assert set(ocp.vehicle.states) <= set(start.values) and not start.values["a"].any()


@pytest.mark.slow
def test_an_operational_cell_solves_within_the_presets_limits(kackertstrasse, template):
    """EU-semitrailer 90-102 with the apron at its limits (measured: Tf 23.09 s, 41 s CPU at N = 100)."""
    from model.vehicles import operational_limits

    doc = cell_document(template, kackertstrasse, "EU-semitrailer", "90-102", True, 100, operational=True)
    ocp, lim = parse_scenario(doc, path=TEMPLATE).ocp, operational_limits("EU-semitrailer")
    sol, _ = solve_cell(ocp, 100)
    assert sol.ok
    cols = sol.columns
    assert cols["v"][0] == pytest.approx(lim.crawl_speed, abs=1e-6) and np.max(cols["v"]) <= ocp.bounds["v"][1] + 1e-6
    assert lim.acceleration[0] - 1e-6 <= np.min(cols["a"]) and np.max(cols["a"]) <= lim.acceleration[1] + 1e-6
    lateral = sol.validation["measures"]["lateral_acceleration"]
    assert lateral["max_abs_nodes"] <= lim.lateral_acceleration + 1e-6


def test_the_map_tables_rows_and_section_say_the_limits():
    """A cell at the preset's limits says them and what it reached; one without says so, against the preset's."""
    import sys

    from model.vehicles import operational_limits

    sys.path.insert(0, str(ROOT / "workflows" / "scripts"))
    try:
        import map_study_table as mst
    finally:
        sys.path.remove(str(ROOT / "workflows" / "scripts"))
    lim = operational_limits("SU-30")
    base = {"preset": "SU-30", "movement": "90-102", "apron": True, "apron_use": "all", "intervals": 100,
            "valid": True, "final_time": 20.0, "route": {"to_lanelet": 102}}  # fmt: skip
    held = {**base, "operational": True, "initial_speed": lim.crawl_speed, "speed_bound": [0.0, 6.9],
            "max_abs_lateral_acceleration": 1.5, "min_acceleration": -1.25, "max_acceleration": 1.0}  # fmt: skip
    free = {**base, "apron": False, "operational": False, "max_abs_lateral_acceleration": 3.5}
    rows = [mst.flat(held), mst.flat(free)]
    assert rows[0]["limits"].startswith(f"operational limits of the SU-30: a in [{lim.acceleration[0]:g}, "
                                        f"{lim.acceleration[1]:g}]") and "a in [-1.25, 1.00] m/s^2" in rows[0]["limits"]
    assert rows[1]["limits"] == mst.limits_note("SU-30", False, 3.5, (None, None))
    assert f"above the SU-30's allowed {lim.lateral_acceleration:g} m/s^2" in rows[1]["limits"]
    import pandas as pd

    from model.studies.roads import operational_text

    text = mst.limits_paragraph(pd.DataFrame(rows))
    assert text.startswith("1 of the 2 cells run") and operational_text("SU-30") in text
    assert "v in [0, 6.9] m/s" in text
    assert mst.limits_paragraph(pd.DataFrame(rows[1:])).startswith("Every cell is solved with the kinematic model")
