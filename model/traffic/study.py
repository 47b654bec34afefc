"""The study "The truck in traffic": cells of vehicle x conflicting flow x driver, and what the paper reads.

A cell is a template scenario (a [traffic] scenario, workflows/scenarios/traffic/<vehicle>.toml) with
``rate`` vehicles per hour entering from every other leg (exit shares equal over the exits, no U-turns),
driven by ``driver`` for K seeded runs (``model.traffic.run.run_traffic``). Per run the files give
the contract's metrics (summary.json) and the truck's gap acceptance (``model.traffic.gaps``).

Per vehicle and driver, over all its cells' runs: the effective critical gap t_c (Raff's method on
the accepted and rejected gaps), the follow-up time t_f (the mean entry occupancy: front bumper in to
the last body's rear in), the conflicting flow q of each cell (passages of the conflict line per second
from half the warm-up, when the streams have reached it, to the run's end, pooled over the runs),
and the comparisons: the mean wait at the line against
Adams' delay E[W](q, t_c), Siegloch's entry capacity c(q, t_c, t_f) in pc/h (the truck 2 pc) against the
HCM 6th edition's 1380 exp(-1.02e-3 v_c).
"""

from __future__ import annotations

import copy
import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from model.problem.scenario import Scenario
from model.scene.roundabout import exit_order
from model.traffic.gaps import (
    PCE_HEAVY,
    adams_delay,
    entry_times,
    gap_capacity,
    hcm_capacity,
    offered_gaps,
    passages,
    raff_critical_gap,
)

RUN_KEYS = ("arrived", "ok", "delay", "travel_time", "free_flow_time", "entry_wait", "collisions", "min_distance",
            "min_clearance", "max_braking_caused", "max_braking_without_truck", "others_time_loss",
            "others_time_loss_without_truck", "realtime_factor", "road_violation")  # fmt: skip


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


def run_record(scenario: Scenario, folder: Path) -> dict:
    """One run's metrics (summary.json) and its gap acceptance, from the run's files in ``folder``."""
    summary = json.loads((folder / "summary.json").read_text())
    record = {k: summary.get(k) for k in RUN_KEYS} | {"seed": summary.get("seed")}
    traffic, trajectory = read_columns(folder / "traffic.csv"), read_columns(folder / "trajectory.csv")
    times = passages(scenario, traffic) if len(traffic.get("t", [])) else np.array([])
    end = float(trajectory["t"][-1]) if len(trajectory.get("t", [])) else 0.0
    settled = scenario.traffic.warmup / 2  # the streams have reached the line (they depart at 0, 60 m out)
    counted = int(np.sum(times >= settled))
    record |= {"passages": counted, "recorded_seconds": max(end - settled, 0.0), "passage_times": times.tolist()}
    entry = entry_times(scenario, trajectory) if len(trajectory.get("t", [])) else None
    if entry is None:
        return record | {"entry": None}
    accepted, rejected = offered_gaps(times, entry, end)
    return record | {"entry": entry.entry, "arrival": entry.arrival, "cleared": entry.cleared,
                     "occupancy": entry.occupancy, "line_time": entry.entry - entry.arrival,
                     "accepted_gap": accepted, "rejected_gaps": rejected}  # fmt: skip


def group_measures(cells: Sequence[Mapping]) -> dict:
    """t_c, t_f and per cell q, the waits and both capacities, for the cells of one vehicle and driver.

    Parameters
    ----------
    cells : sequence of mapping
        Cell records (``rate`` and ``runs``, each run a ``run_record``), one vehicle and driver.

    Returns
    -------
    dict
        ``critical_gap`` (Raff, s; None without an accepted or a rejected gap), ``critical_gap_at_most``
        (the shortest accepted gap when none was rejected: an upper bound), the counts, ``follow_up`` (s),
        ``line_time_free`` (s, the mean time from the line to the entry at rate 0) and per cell
        ``q`` (veh/s), the mean wait at the line beyond the free one, Adams' delay, capacities.
    """
    runs = [r for c in cells for r in c["runs"] if r.get("entry") is not None]
    accepted = [r["accepted_gap"] for r in runs if r.get("accepted_gap") is not None]
    rejected = [g for r in runs for g in r.get("rejected_gaps", [])]
    # Raff's crossing needs rejected gaps: without any it is only an upper bound (the shortest accepted one)
    bound = raff_critical_gap(accepted, rejected)
    tc = bound if rejected else None
    tf = _mean([r["occupancy"] for r in runs if math.isfinite(r.get("occupancy") or math.nan)])
    free = [r["line_time"] for c in cells if c["rate"] == 0 for r in c["runs"] if r.get("entry") is not None]
    line_free = _mean(free)
    out = {"critical_gap": tc, "critical_gap_at_most": bound, "accepted": len(accepted), "rejected": len(rejected),
           "follow_up": tf,
           "line_time_free": line_free, "cells": []}  # fmt: skip
    for c in sorted(cells, key=lambda c: c["rate"]):
        seconds = sum(r["recorded_seconds"] for r in c["runs"])
        q = sum(r["passages"] for r in c["runs"]) / seconds if seconds > 0 else 0.0
        done = [r for r in c["runs"] if r.get("entry") is not None]
        wait = _mean([r["line_time"] - line_free for r in done]) if line_free is not None else None
        row = {"rate": c["rate"], "q": q, "vc_pcph": 3600 * q, "line_wait": wait,
               "entry_wait": _mean([r["entry_wait"] for r in done if r.get("entry_wait") is not None]),
               "hcm_capacity_pcph": hcm_capacity(3600 * q)}  # fmt: skip
        if tc is not None:
            row["adams_delay"] = adams_delay(q, tc)
            if tf:
                row["capacity_pcph"] = PCE_HEAVY * 3600 * gap_capacity(q, tc, tf)
        out["cells"].append(row)
    return out


def _mean(values: Sequence[float]) -> float | None:
    return float(np.mean(values)) if len(values) else None


__all__ = ["RUN_KEYS", "cell_document", "cell_name", "conflicting_demand", "group_measures", "parse_cell",
           "read_columns", "run_record"]  # fmt: skip
