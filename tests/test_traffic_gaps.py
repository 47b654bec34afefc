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
    follow_up_headways,
    gap_capacity,
    hcm_capacity,
    mle_critical_gap,
    offer,
    offered_gaps,
    other_entries,
    passages,
    raff_critical_gap,
    raff_spread,
)
from model.traffic.study import (
    cell_document,
    cell_name,
    conflicting_demand,
    gap_estimates,
    group_measures,
    others_measures,
    parse_cell,
)

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


def test_offered_gaps_start_with_the_lag_accepted_contains_the_entry():
    e = Entry(arrival=10.0, entry=20.0, cleared=22.0)
    accepted, rejected = offered_gaps(np.array([5.0, 11.0, 14.0, 18.0, 27.0]), e, end=30.0)
    assert accepted == pytest.approx(9.0)
    assert rejected == pytest.approx([1.0, 3.0, 4.0])  # the lag 10 -> 11, then the headways 11 -> 14 -> 18
    censored = offer(np.array([5.0, 11.0]), 10.0, 20.0, 30.0)
    assert (censored.accepted, censored.rejected, censored.censored) == (19.0, (1.0,), True)  # cut by the end
    lag = offer(np.array([25.0]), 10.0, 20.0, 30.0)  # nobody passed before the entry: the lag was accepted
    assert (lag.accepted, lag.rejected, lag.censored, lag.largest_rejected) == (15.0, (), False, 0.0)


def test_raff_crossing_and_its_degenerate_cases():
    assert raff_critical_gap([4.0, 5.0, 6.0], [1.0, 2.0, 3.0, 4.5]) == pytest.approx(4.25)
    assert raff_critical_gap([7.0, 9.0], []) == 7.0
    assert raff_critical_gap([], [1.0]) is None


def test_adams_delay_limits_and_a_hand_computed_value():
    tc = 5.0
    assert adams_delay(0.0, tc) == 0.0
    assert adams_delay(1e-6, tc) == pytest.approx(1e-6 * tc**2 / 2, rel=1e-4)  # q t_c^2 / 2 for small q
    assert adams_delay(0.2, tc) == pytest.approx((math.exp(1.0) - 2.0) / 0.2)
    assert adams_delay(0.1, tc) == pytest.approx(1.4872127, abs=1e-6)  # (e^0.5 - 1.5) / 0.1 by hand


def test_siegloch_capacity_by_hand():
    # q = 0.1 veh/s, t_c = 5 s, t_f = 3 s: exp(-0.1 (5 - 1.5)) / 3 = 0.704688 / 3 = 0.234896 veh/s = 845.63 veh/h
    assert 3600 * gap_capacity(0.1, 5.0, 3.0) == pytest.approx(845.626, abs=1e-3)
    assert gap_capacity(0.0, 5.0, 3.0) == pytest.approx(1 / 3)


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


def synthetic_drivers(n: int, q: float, mean: float, sd: float, seed: int) -> list[dict]:
    """Consistent drivers with log-normal critical gaps (mean, sd) at a Poisson stream of q veh/s: their offers."""
    rng = np.random.default_rng(seed)
    s2 = math.log(1 + (sd / mean) ** 2)
    critical = np.exp(rng.normal(math.log(mean) - s2 / 2, math.sqrt(s2), n))
    times = np.cumsum(rng.exponential(1 / q, int(q * 80 * n) + 100))
    out, t = [], 10.0
    for tc in critical:
        t += rng.exponential(60.0)
        i = int(np.searchsorted(times, t))
        start, rejected = t, []
        while times[i] - start < tc:
            rejected.append(float(times[i] - start))
            start, i = float(times[i]), i + 1
        out.append({"accepted": float(times[i] - start), "rejected": rejected, "censored": False,
                    "line_time": float(start - t) + 1.0})  # fmt: skip
    return out


@pytest.mark.parametrize(("mean", "sd", "q", "seed"), [(4.0, 1.0, 0.25, 1), (3.0, 0.6, 0.15, 2), (5.5, 1.5, 0.3, 3)])
def test_mle_and_raff_recover_a_known_critical_gap(mean, sd, q, seed):
    offers = synthetic_drivers(400, q, mean, sd, seed)
    got = mle_critical_gap([o["accepted"] for o in offers], [max(o["rejected"], default=0.0) for o in offers])
    assert got["mean"] == pytest.approx(mean, abs=max(0.25, 3 * got["se"]))
    assert 0.02 < got["se"] < 0.3  # 400 drivers: a tenth of a second or so
    assert got["sd"] == pytest.approx(sd, rel=0.5)
    raff = raff_critical_gap([o["accepted"] for o in offers], [g for o in offers for g in o["rejected"]])
    assert raff == pytest.approx(mean, rel=0.15)  # Raff's is the median-like crossing, not the mean
    spread = raff_spread([o["accepted"] for o in offers], [o["rejected"] for o in offers])
    assert 0.01 < spread < 0.5


def test_mle_needs_a_rejected_gap_and_leaves_inconsistent_drivers_out():
    assert mle_critical_gap([3.0, 4.0], [0.0, 0.0]) is None
    got = mle_critical_gap([4.0, 5.0, 3.0, 6.0, 2.0], [2.0, 3.0, 1.0, 4.0, 2.5])
    assert got["inconsistent"] == 1 and got["drivers"] == 4
    assert 2.0 < got["mean"] < 6.0


def test_gap_estimates_leave_censored_offers_out_and_need_enough_drivers_for_the_mle():
    offers = synthetic_drivers(40, 0.25, 4.0, 1.0, 4)
    got = gap_estimates(offers + [{"accepted": 0.5, "rejected": [], "censored": True, "line_time": 1.0}])
    assert got["drivers"] == 40 and got["critical_gap"] == got["mle"]
    assert got["mle"] == pytest.approx(4.0, abs=1.0)
    few = gap_estimates(offers[:5])
    assert few["mle"] is None and few["critical_gap"] == few["raff"]


def test_other_entries_find_each_cars_leg_arrival_and_queue():
    sc = scenario(600.0)
    ra = sc.ocp.road.roundabout

    def approach(t0: float, leg: int, stop: float | None = None, speed: float = 5.0) -> dict:
        # a 5 m car driving in along the leg's axis to the centre (its front 2.5 m ahead of its centre)
        t = t0 + 0.1 * np.arange(200)
        front = 40.0 - speed * (t - t0) if stop is None else np.maximum(40.0 - speed * (t - t0), stop)
        axis = ra.legs[leg].angle
        centre = front + 2.5
        return {"t": t, "x": centre * np.cos(axis), "y": centre * np.sin(axis),
                "heading": np.full_like(t, axis + math.pi), "length": np.full_like(t, 5.0)}  # fmt: skip

    cars = {"a": approach(0.0, 1), "b": approach(0.5, 1, speed=4.0), "c": approach(1.0, 3)}
    cols = {k: np.concatenate([v[k] for v in cars.values()]) for k in ("t", "x", "y", "heading", "length")}
    cols["id"] = np.concatenate([[vid] * len(v["t"]) for vid, v in cars.items()])
    got = {e["id"]: e for e in other_entries(sc, cols)}
    assert (got["a"]["leg"], got["b"]["leg"], got["c"]["leg"]) == (1, 1, 3)
    assert got["a"]["entry"] == pytest.approx(20.0 / 5.0, abs=0.11)  # front from 40 m to the 20 m curb at 5 m/s
    assert got["a"]["arrival"] == pytest.approx(10.0 / 5.0, abs=0.11)  # within 10 m of the curb
    assert got["b"]["arrival"] == pytest.approx(max(0.5 + 10.0 / 4.0, got["a"]["entry"]), abs=0.11)
    assert got["b"]["queued"] is True and got["a"]["queued"] is False
    assert follow_up_headways([got["a"], got["b"]], np.array([])) == pytest.approx([got["b"]["entry"] - 4.0])
    assert follow_up_headways([got["a"], got["b"]], np.array([4.5])) == []  # someone passed between them


def test_group_measures_pool_the_truck_gaps_and_subtract_the_free_line_time():
    def run(line, accepted, rejected, passages=10, seconds=60.0):
        return {"entry": 1.0, "line_time": line, "accepted_gap": accepted, "rejected_gaps": rejected,
                "accepted_censored": False, "occupancy": 2.0, "passages": passages, "recorded_seconds": seconds,
                "entry_wait": 0.0}  # fmt: skip

    cells = [{"rate": 0.0, "runs": [run(1.0, 30.0, [], 0)]},
             {"rate": 600.0, "runs": [run(4.0, 6.0, [2.0, 3.0]), run(2.0, 5.0, [])]}]  # fmt: skip
    g = group_measures(cells, reference_gap=4.0)
    assert g["raff"] == pytest.approx(raff_critical_gap([30.0, 6.0, 5.0], [2.0, 3.0]))
    assert g["mle"] is None and g["critical_gap"] is None  # 3 entries: Raff's crossing, too few for the formulas
    assert (g["accepted"], g["rejected"], g["follow_up"], g["line_time_free"]) == (3, 2, 2.0, 1.5)
    row = g["cells"][1]
    assert row["q"] == pytest.approx(20 / 120)
    assert row["line_wait"] == pytest.approx(3.0 - 1.5)
    assert "adams_delay" not in row and row["adams_reference"] == pytest.approx(adams_delay(20 / 120, 4.0))
    cells[1]["runs"] += [run(3.0, 7.0, [2.5]), run(2.0, 4.5, [1.0])]  # 5 entries: Raff's t_c goes into Adams'
    g = group_measures(cells)
    assert g["critical_gap"] == g["raff"] is not None
    assert g["cells"][1]["adams_delay"] == pytest.approx(adams_delay(20 / 120, g["raff"]))
    assert "capacity_pcph" not in g["cells"][1]  # a queue of trucks' follow-up time is not measured


def test_without_a_rejected_gap_there_is_only_a_bound_and_no_adams_delay():
    run = {"entry": 1.0, "line_time": 1.0, "accepted_gap": 9.0, "rejected_gaps": [], "occupancy": 2.0,
           "passages": 3, "recorded_seconds": 30.0, "entry_wait": 0.0}  # fmt: skip
    g = group_measures([{"rate": 600.0, "runs": [run, {**run, "accepted_gap": 7.0}]}])
    assert g["critical_gap"] is None and g["raff_at_most"] == 7.0
    assert "adams_delay" not in g["cells"][0] and "capacity_pcph" not in g["cells"][0]


def test_others_measures_per_rate_and_leg_with_the_cars_gaps():
    offers = synthetic_drivers(60, 0.2, 4.0, 1.0, 5)
    for o in offers:
        o["queued"] = False
    leg = {"passages": 30, "seconds": 150.0, "follow_up": [2.0, 2.4], "offers": offers}
    g = others_measures([{"rate": 900.0, "runs": [{"others": {"2": leg}}]}])
    assert g["follow_up"] == pytest.approx(2.2) and g["drivers"] == 60
    (row,) = g["cells"]
    assert (row["rate"], row["leg"], row["q"]) == (900.0, 2, pytest.approx(0.2))
    assert row["adams_delay"] == pytest.approx(adams_delay(0.2, g["mle"]))
    assert row["capacity_pcph"] == pytest.approx(3600 * gap_capacity(0.2, g["mle"], 2.2))
