"""Gap acceptance at the truck's entry and the traffic-engineering formulas of the traffic study."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from model.problem.scenario import parse_scenario
from model.traffic.gaps import (
    HCM_CRITICAL_GAP,
    HCM_FOLLOW_UP,
    Entry,
    adams_delay,
    entry_times,
    gap_capacity,
    hcm_capacity,
    offered_gaps,
    passages,
    raff_critical_gap,
)
from model.traffic.study import cell_document, cell_name, conflicting_demand, group_measures, parse_cell

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "traffic-roundabout.toml"


def scenario(rate: float | None = None):
    doc = tomllib.loads(EXAMPLE.read_text())
    return parse_scenario(doc if rate is None else cell_document(doc, rate, 0))


def circling(t0: float, angle0: float, radius: float = 17.0, speed: float = 8.0, steps: int = 60) -> dict:
    """A vehicle on the ring, counter-clockwise from ``angle0`` (rad) at ``t0``, sampled every 0.1 s."""
    t = t0 + 0.1 * np.arange(steps)
    a = angle0 + speed / radius * (t - t0)
    return {"t": t, "x": radius * np.cos(a), "y": radius * np.sin(a)}


def columns(vehicles: dict[str, dict]) -> dict[str, np.ndarray]:
    out = {"t": [], "id": [], "x": [], "y": []}
    for vid, v in vehicles.items():
        out["t"] += list(v["t"])
        out["x"] += list(v["x"])
        out["y"] += list(v["y"])
        out["id"] += [vid] * len(v["t"])
    return {k: np.array(v) for k, v in out.items()}


def test_passages_time_each_crossing_of_the_entrys_conflict_line():
    # the truck enters from leg 0 (axis 180 degrees); counter-clockwise circulation crosses it going to 181 degrees
    sc = scenario()
    omega = 8.0 / 17.0
    a = columns({"a": circling(0.0, math.pi - 0.5), "b": circling(3.0, math.pi - 0.2), "c": circling(0.0, 0.1)})
    got = passages(sc, a)
    assert got == pytest.approx([0.5 / omega, 3.0 + 0.2 / omega], abs=1e-9)  # c never reaches 180 degrees


def test_passages_ignore_vehicles_off_the_ring_and_going_the_other_way():
    sc = scenario()
    off = circling(0.0, math.pi - 0.3, radius=30.0)  # on a leg's reach, not on the ring roadway
    back = circling(0.0, math.pi + 0.3, speed=-8.0)
    assert len(passages(sc, columns({"off": off, "back": back}))) == 0


def test_entry_times_of_a_truck_driving_straight_at_the_ring():
    sc = scenario()
    t = 0.1 * np.arange(300)
    x = -60.0 + 2.0 * t  # rear axle, 2 m/s along y = -2 towards the centre
    cols = {"t": t, "x": x, "y": np.full_like(t, -2.0), "theta": np.zeros_like(t), "phi": np.zeros_like(t)}
    e = entry_times(sc, cols)
    front, rear = 8.0 - 1.5, -1.5  # the body's front bumper and rear from the rear axle
    ro = math.sqrt(20.0**2 - 4.0)  # the curb circle at y = -2
    assert e.entry == pytest.approx((60 - ro - front) / 2, abs=0.1)
    assert e.arrival == pytest.approx((60 - ro - 10.0 - front) / 2, abs=0.1)
    assert e.occupancy == pytest.approx((front - rear) / 2, abs=0.15)


def test_offered_gaps_accepted_contains_the_entry_rejected_are_complete_headways():
    e = Entry(arrival=10.0, entry=20.0, cleared=22.0)
    accepted, rejected = offered_gaps(np.array([5.0, 11.0, 14.0, 18.0, 27.0]), e, end=30.0)
    assert accepted == pytest.approx(9.0)
    assert rejected == pytest.approx([3.0, 4.0])
    assert offered_gaps(np.array([5.0, 11.0]), e, end=30.0)[0] == pytest.approx(19.0)  # censored by the run's end
    assert offered_gaps(np.array([25.0]), e, end=30.0)[0] is None


def test_raff_crossing_and_its_degenerate_cases():
    assert raff_critical_gap([4.0, 5.0, 6.0], [1.0, 2.0, 3.0, 4.5]) == pytest.approx(4.25)
    assert raff_critical_gap([7.0, 9.0], []) == 7.0
    assert raff_critical_gap([], [1.0]) is None


def test_adams_delay_limits():
    tc = 5.0
    assert adams_delay(0.0, tc) == 0.0
    assert adams_delay(1e-6, tc) == pytest.approx(1e-6 * tc**2 / 2, rel=1e-4)  # q t_c^2 / 2 for small q
    assert adams_delay(0.2, tc) == pytest.approx((math.exp(1.0) - 2.0) / 0.2)


def test_siegloch_with_the_hcms_gaps_is_the_hcm_formula():
    for vc in (0.0, 300.0, 900.0, 1500.0):
        assert 3600 * gap_capacity(vc / 3600, HCM_CRITICAL_GAP, HCM_FOLLOW_UP) == pytest.approx(hcm_capacity(vc))
    assert hcm_capacity(0.0) == 1380.0


def test_conflicting_demand_counts_the_exits_beyond_the_entry():
    # example: 300 veh/h from legs 1 and 3, exits (0.25, 0.5, 0.25, 0): from leg 3 the 2nd and 3rd exits pass
    # the truck's entry (leg 0), from leg 1 none does (its 3rd exit is leg 0 itself, left before the line)
    assert 3600 * conflicting_demand(scenario()) == pytest.approx(225.0)
    assert 3600 * conflicting_demand(scenario(600.0)) == pytest.approx(600.0)  # 1/3 x 600 from leg 2, 2/3 from leg 3
    assert conflicting_demand(scenario(0.0)) == 0.0


def test_cell_names_round_trip():
    assert parse_cell(cell_name("EU-semitrailer", 600, "sumo")) == ("EU-semitrailer", 600.0, "sumo")


def test_group_measures_pool_the_gaps_and_subtract_the_free_line_time():
    def run(line, accepted, rejected, passages=10, seconds=60.0):
        return {"entry": 1.0, "line_time": line, "accepted_gap": accepted, "rejected_gaps": rejected,
                "occupancy": 2.0, "passages": passages, "recorded_seconds": seconds, "entry_wait": 0.0}  # fmt: skip

    cells = [{"rate": 0.0, "runs": [run(1.0, None, [], 0)]},
             {"rate": 600.0, "runs": [run(4.0, 6.0, [2.0, 3.0]), run(2.0, 5.0, [])]}]  # fmt: skip
    g = group_measures(cells)
    assert g["critical_gap"] == pytest.approx(raff_critical_gap([6.0, 5.0], [2.0, 3.0]))
    assert (g["accepted"], g["rejected"], g["follow_up"], g["line_time_free"]) == (2, 2, 2.0, 1.0)
    row = g["cells"][1]
    assert row["q"] == pytest.approx(20 / 120)
    assert row["line_wait"] == pytest.approx(2.0)
    assert row["adams_delay"] == pytest.approx(adams_delay(20 / 120, g["critical_gap"]))


def test_without_a_rejected_gap_there_is_only_a_bound_and_no_adams_delay():
    run = {"entry": 1.0, "line_time": 1.0, "accepted_gap": 9.0, "rejected_gaps": [], "occupancy": 2.0,
           "passages": 3, "recorded_seconds": 30.0, "entry_wait": 0.0}  # fmt: skip
    g = group_measures([{"rate": 600.0, "runs": [run, {**run, "accepted_gap": 7.0}]}])
    assert g["critical_gap"] is None and g["critical_gap_at_most"] == 7.0
    assert "adams_delay" not in g["cells"][0] and "capacity_pcph" not in g["cells"][0]
