"""The study "The truck in traffic": cells of vehicle x conflicting flow x driver, and what the paper reads.

A cell is a template scenario (a [traffic] scenario, workflows/scenarios/traffic/<vehicle>.toml) with
``rate`` vehicles per hour entering from every other leg (exit shares equal over the exits, no U-turns),
driven by ``driver`` for K seeded runs (``model.traffic.run.run_traffic``). Per run the files give
the contract's metrics (summary.json), the truck's gap acceptance at its entry and SUMO's cars' at
theirs (``model.traffic.gaps``; ``run_record``).

Per vehicle and driver, over all its cells' runs (``group_measures``): the truck's critical gap
(Raff's and the maximum-likelihood one, ``gap_estimates``), its entry occupancy, the conflicting flow
q of each cell (passages of the conflict line per second from half the warm-up, when the streams have
reached it, to the run's end, pooled over the runs) and its mean wait at the line against Adams'
delay E[W](q, t_c) and the HCM 6th edition's capacity 1380 exp(-1.02e-3 v_c). Over all cells
(``others_measures``): SUMO's cars' critical gap and follow-up time, and per rate and entry leg their
mean wait against Adams' delay and Siegloch's capacity c(q, t_c, t_f) against the HCM's.
"""

from __future__ import annotations

import copy
import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from model.analysis.bodies import body_corners
from model.problem.scenario import Scenario
from model.scene.roundabout import exit_order
from model.traffic.gaps import (
    CENTRE_COLUMNS,
    PCE_HEAVY,
    adams_delay,
    entry_times,
    follow_up_headways,
    gap_capacity,
    hcm_capacity,
    mle_critical_gap,
    offer,
    other_entries,
    passages,
    raff_critical_gap,
    raff_spread,
)

MLE_MIN_DRIVERS = 10  # fewer drivers give no maximum-likelihood estimate (Raff's only)
FORMULA_MIN_DRIVERS = 5  # fewer drivers give Raff's crossing but no t_c for Adams' delay and the capacity
RUN_KEYS = ("arrived", "ok", "delay", "travel_time", "free_flow_time", "entry_wait", "collisions", "min_distance",
            "min_clearance", "max_braking_caused", "max_braking_without_truck", "others_time_loss",
            "others_time_loss_without_truck", "realtime_factor", "road_violation", "management")  # fmt: skip


def cell_name(vehicle: str, rate: float, driver: str) -> str:
    """``truck_q600_autopilot``: the cell's name (a file stem)."""
    return f"{vehicle}_q{float(rate):g}_{driver}"


def parse_cell(name: str) -> tuple[str, float, str]:
    """The inverse of ``cell_name``."""
    vehicle, rate, driver = name.rsplit("_", 2)
    return vehicle, float(rate[1:]), driver


def cell_document(template: Mapping, rate: float, seed: int) -> dict:
    """The template scenario with ``rate`` veh/h entering from every leg but the truck's, seed ``seed``."""
    doc = copy.deepcopy(dict(template))
    legs = len(doc["roundabout"]["legs"])
    shares = [1.0 / (legs - 1)] * (legs - 1) + [0.0]
    enter = doc["route"]["enter"]
    doc["traffic"] = {k: v for k, v in doc["traffic"].items() if k != "flows"} | {"seed": int(seed)}
    if rate > 0:
        doc["traffic"]["flows"] = [{"leg": i, "vehicles_per_hour": float(rate), "exits": shares}
                                   for i in range(legs) if i != enter]  # fmt: skip
    return doc


def conflicting_demand(scenario: Scenario) -> float:
    """The flows' rate (veh/s) past the conflict line of the truck's entry: their exits beyond it.

    A vehicle from leg i taking its n-th exit passes the line if the truck's entry leg comes before
    that exit in its exit order (it leaves at the truck's own leg before the line: the exit lane is
    upstream of the entry). Poisson thinning: the passing stream is Poisson of this rate.
    """
    ra, enter = scenario.ocp.road.roundabout, scenario.ocp.road.route.enter
    rate = 0.0
    for flow in scenario.traffic.flows:
        order = exit_order(ra, flow.leg)
        where = order.index(enter)
        rate += flow.vehicles_per_hour / 3600 * sum(flow.exits[where + 1 :])
    return rate


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """A CSV file as columns (floats where every value is a number)."""
    with path.open() as f:
        rows = list(csv.reader(f))
    out = {}
    for j, name in enumerate(rows[0]):
        values = [r[j] for r in rows[1:]]
        try:
            out[name] = np.array(values, float)
        except ValueError:
            out[name] = np.array(values)
    return out


def truck_centres(scenario: Scenario, trajectory: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The truck as one more ``traffic.csv`` vehicle (``t``, ``id``, ``x``, ``y``): its last body's centre.

    It is part of the conflicting stream at the other legs' entries; its last body (the trailer of a
    semitrailer) marks when it has passed, one passage per truck.
    """
    corners = body_corners(scenario.ocp, {s: np.asarray(trajectory[s], float) for s in scenario.ocp.vehicle.states})
    centre = corners[list(corners)[-1]].mean(axis=1)
    t = np.asarray(trajectory["t"], float)
    return {"t": t, "id": np.array(["truck"] * len(t)), "x": centre[:, 0], "y": centre[:, 1]}  # names: traffic.csv


def merged(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray], keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Columns ``keys`` of two column sets, one after the other."""
    return {k: np.concatenate([np.asarray(a[k]), np.asarray(b[k])]) for k in keys}


def others_record(scenario: Scenario, traffic: Mapping[str, np.ndarray], stream: Mapping[str, np.ndarray],
                  end: float, settled: float) -> dict:  # fmt: skip
    """SUMO's vehicles' gap decisions at their entries (``other_entries``), per leg, in one run.

    ``stream``: the columns whose passages make each entry's conflicting stream (the others and the truck).
    Returns per leg (str keys) ``passages`` (counted from ``settled``), ``seconds``, ``follow_up``
    (headways, s) and ``offers`` (per driver ``arrival``, ``line_time``, ``accepted``, ``rejected``,
    ``censored``, ``queued``).
    """
    entries = other_entries(scenario, traffic)
    legs = {}
    for leg in sorted({e["leg"] for e in entries}):
        times = passages(scenario, stream, leg)
        mine = [e for e in entries if e["leg"] == leg]
        offers = []
        for e in mine:
            o = offer(times, e["arrival"], e["entry"], end)
            offers.append({"arrival": e["arrival"], "line_time": e["entry"] - e["arrival"], "accepted": o.accepted,
                           "rejected": list(o.rejected), "censored": o.censored, "queued": e["queued"]})  # fmt: skip
        legs[str(leg)] = {"passages": int(np.sum(times >= settled)), "seconds": max(end - settled, 0.0),
                          "follow_up": follow_up_headways(mine, times), "offers": offers}  # fmt: skip
    return legs


def run_record(scenario: Scenario, folder: Path) -> dict:
    """One run's metrics (summary.json), the truck's gap acceptance and the others' at their entries."""
    summary = json.loads((folder / "summary.json").read_text())
    record = {k: summary.get(k) for k in RUN_KEYS} | {"seed": summary.get("seed")}
    lateral = (summary.get("limits_driven") or {}).get("lateral_acceleration") or {}
    record["lateral_driven"] = max(abs(lateral["min"]), abs(lateral["max"])) if lateral else None  # m/s², every row
    record["lateral_bound"] = max(abs(b) for b in lateral["bound"]) if lateral.get("bound") else None
    traffic, trajectory = read_columns(folder / "traffic.csv"), read_columns(folder / "trajectory.csv")
    has_traffic, has_truck = len(traffic.get("t", [])) > 0, len(trajectory.get("t", [])) > 0
    times = passages(scenario, traffic) if has_traffic else np.array([])
    end = max([float(trajectory["t"][-1])] * has_truck + [float(traffic["t"][-1])] * has_traffic + [0.0])
    settled = scenario.traffic.warmup / 2  # the streams have reached the line (they depart at 0, 60 m out)
    counted = int(np.sum(times >= settled))
    record |= {"passages": counted, "recorded_seconds": max(end - settled, 0.0), "passage_times": times.tolist()}
    if has_traffic:
        keys = ("t", "id", *CENTRE_COLUMNS)
        stream = merged(traffic, truck_centres(scenario, trajectory), keys) if has_truck else traffic
        record["others"] = others_record(scenario, traffic, stream, end, settled)
    entry = entry_times(scenario, trajectory) if has_truck else None
    if entry is None:
        return record | {"entry": None}
    got = offer(times, entry.arrival, entry.entry, end)
    return record | {"entry": entry.entry, "arrival": entry.arrival, "cleared": entry.cleared,
                     "occupancy": entry.occupancy, "line_time": entry.entry - entry.arrival,
                     "accepted_gap": got.accepted, "rejected_gaps": list(got.rejected),
                     "accepted_censored": got.censored}  # fmt: skip


def gap_estimates(offers: Sequence[Mapping]) -> dict:
    """Raff's and the maximum-likelihood critical gap of drivers' offers, with their spreads.

    Parameters
    ----------
    offers : sequence of mapping
        Per driver ``accepted`` (s), ``rejected`` (list, s) and ``censored``; censored offers are left out.

    Returns
    -------
    dict
        ``drivers``, ``accepted`` and ``rejected`` (counts of gaps), ``raff`` (s; None without a rejected
        gap), ``raff_se`` (s, bootstrap over the drivers), ``raff_at_most`` (the shortest accepted gap when
        none was rejected), ``mle`` (s, Troutbeck's log-normal mean), ``mle_se`` (s, its standard error),
        ``mle_sd`` (s, the spread of the drivers' critical gaps; the MLE with ``MLE_MIN_DRIVERS`` drivers or
        more), ``critical_gap`` (the MLE, else Raff's with ``FORMULA_MIN_DRIVERS`` drivers or more, else None).
    """
    used = [o for o in offers if not o.get("censored")]
    accepted = [float(o["accepted"]) for o in used]
    rejected = [list(o["rejected"]) for o in used]
    flat = [g for r in rejected for g in r]
    raff = raff_critical_gap(accepted, flat) if flat else None
    enough = len(used) >= MLE_MIN_DRIVERS
    mle = mle_critical_gap(accepted, [max(r, default=0.0) for r in rejected]) if flat and enough else None
    out = {"drivers": len(used), "accepted": len(accepted), "rejected": len(flat), "raff": raff,
           "raff_se": raff_spread(accepted, rejected) if flat else None,
           "raff_at_most": None if flat else (min(accepted) if accepted else None),
           "mle": mle["mean"] if mle else None, "mle_se": mle["se"] if mle else None,
           "mle_sd": mle["sd"] if mle else None}  # fmt: skip
    fallback = raff if len(used) >= FORMULA_MIN_DRIVERS else None
    out["critical_gap"] = out["mle"] if out["mle"] is not None else fallback
    return out


def free_line_time(offers: Sequence[Mapping]) -> float | None:
    """The median line-to-entry time of drivers who took the first gap offered (s): the wait-free passage."""
    return _median([o["line_time"] for o in offers if not o["rejected"] and o.get("line_time") is not None])


def formula_row(q: float, tc: float | None, tf: float | None, pce: float) -> dict:
    """Adams' delay (s), Siegloch's capacity (pc/h, ``pce`` per vehicle) and the HCM's at ``q`` veh/s."""
    row = {"q": q, "vc_pcph": 3600 * q, "hcm_capacity_pcph": hcm_capacity(3600 * q)}
    if tc is not None:
        row["adams_delay"] = adams_delay(q, tc)
        if tf:
            row["capacity_pcph"] = pce * 3600 * gap_capacity(q, tc, tf)
    return row


def truck_offers(runs: Sequence[Mapping]) -> list[dict]:
    """The truck's offers of runs in which it entered (``run_record``'s keys as ``gap_estimates`` reads them)."""
    return [{"accepted": r["accepted_gap"], "rejected": r.get("rejected_gaps", []),
             "censored": r.get("accepted_censored", False), "line_time": r["line_time"]}
            for r in runs if r.get("entry") is not None and r.get("accepted_gap") is not None]  # fmt: skip


def group_measures(cells: Sequence[Mapping], reference_gap: float | None = None) -> dict:
    """The truck's critical gap, t_f and per cell q, its waits, Adams' delay, the HCM capacity: one vehicle, driver.

    Parameters
    ----------
    cells : sequence of mapping
        Cell records (``rate`` and ``runs``, each run a ``run_record``), one vehicle and driver.
    reference_gap : float, optional
        Another critical gap (s; the cars'): each cell also gets Adams' delay with it (``adams_reference``).

    Returns
    -------
    dict
        ``gap_estimates`` of the truck's offers pooled over the cells, ``follow_up`` (s, the mean entry
        occupancy), ``line_time_free`` (s, ``free_line_time``) and per cell ``q`` (veh/s at the truck's
        entry), the mean wait at the line beyond the free one, Adams' delay and the HCM's capacity (pc/h);
        no gap capacity: a queue of trucks' follow-up time is not measured (t_f is only a lower bound).
    """
    runs = [r for c in cells for r in c["runs"]]
    offers = truck_offers(runs)
    est = gap_estimates(offers)
    tf = _mean([r["occupancy"] for r in runs if r.get("entry") is not None
                and math.isfinite(r.get("occupancy") or math.nan)])  # fmt: skip
    free = free_line_time(offers)
    out = est | {"follow_up": tf, "line_time_free": free, "cells": []}
    for c in sorted(cells, key=lambda c: c["rate"]):
        seconds = sum(r["recorded_seconds"] for r in c["runs"])
        q = sum(r["passages"] for r in c["runs"]) / seconds if seconds > 0 else 0.0
        mine = truck_offers(c["runs"])
        wait = _mean([o["line_time"] - free for o in mine]) if free is not None else None
        row = {"rate": c["rate"], "line_wait": wait, "observed": len(mine),
               **formula_row(q, est["critical_gap"], None, PCE_HEAVY)}  # fmt: skip
        if reference_gap is not None:
            row["adams_reference"] = adams_delay(q, reference_gap)
        out["cells"].append(row)
    return out


def others_measures(cells: Sequence[Mapping]) -> dict:
    """SUMO's passenger cars at their entries, pooled over ``cells``: critical gap, t_f, per rate and leg waits.

    Returns
    -------
    dict
        ``gap_estimates`` over every car's offer, ``follow_up`` (s, the mean follow-up headway),
        ``follow_ups`` (their number), ``line_time_free`` (s) and ``cells``: per rate and leg the
        measured ``q`` (veh/s, the others and the truck), the mean wait at the line beyond the free
        one over the cars that did not follow one ahead in the same gap, Adams' delay and the
        capacities (pc/h, 1 pc per car).
    """
    legs: dict[tuple[float, str], list] = {}
    for c in cells:
        for r in c["runs"]:
            for leg, v in (r.get("others") or {}).items():
                legs.setdefault((c["rate"], leg), []).append(v)
    offers = [o for vs in legs.values() for v in vs for o in v["offers"]]
    est = gap_estimates(offers)
    follow = [h for vs in legs.values() for v in vs for h in v["follow_up"]]
    tf, free = _mean(follow), free_line_time(offers)
    out = est | {"follow_up": tf, "follow_ups": len(follow), "line_time_free": free, "cells": []}
    for (rate, leg), vs in sorted(legs.items()):
        seconds = sum(v["seconds"] for v in vs)
        q = sum(v["passages"] for v in vs) / seconds if seconds > 0 else 0.0
        mine = [o for v in vs for o in v["offers"] if not o["queued"]]
        wait = _mean([o["line_time"] - free for o in mine]) if free is not None else None
        row = {"rate": rate, "leg": int(leg), "line_wait": wait, "observed": len(mine),
               **formula_row(q, est["critical_gap"], tf, 1.0)}  # fmt: skip
        out["cells"].append(row)
    return out


def others_delay(run: Mapping) -> float | None:
    """Seconds the other vehicles lost because of the truck in one run (None if not measured).

    Their summed SUMO time loss (``others_time_loss``) less the same vehicles' loss in the same seed's
    traffic replayed without the truck to the same end (``others_time_loss_without_truck``); negative when
    they lost less with the truck (SUMO's drivers are random: the truck's insertion changes their draws).
    """
    loss, alone = run.get("others_time_loss"), run.get("others_time_loss_without_truck")
    return None if loss is None or alone is None else float(loss - alone)


def everyone_delay(run: Mapping) -> float | None:
    """Everyone's delay in one run, s: the truck's delay plus ``others_delay`` (None if either is missing)."""
    others = others_delay(run)
    return None if others is None or run.get("delay") is None else float(run["delay"] + others)


def _median(values: Sequence[float]) -> float | None:
    return float(np.median(values)) if len(values) else None


def _mean(values: Sequence[float]) -> float | None:
    return float(np.mean(values)) if len(values) else None


__all__ = ["FORMULA_MIN_DRIVERS", "MLE_MIN_DRIVERS", "RUN_KEYS", "cell_document", "cell_name", "conflicting_demand",
           "everyone_delay", "free_line_time", "gap_estimates", "group_measures", "merged", "others_delay",
           "others_measures", "others_record", "parse_cell", "read_columns", "run_record", "truck_centres",
           "truck_offers"]  # fmt: skip
