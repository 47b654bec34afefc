"""The traffic keys of a scenario (docs/traffic-format.md): ``[traffic]`` and ``[[traffic.flows]]``.

``parse_traffic`` reads both with one ``InputError`` per bad key, as ``closed_loop.py`` does for
``[disturbance]`` and ``[control]``. A ``[traffic]`` table needs the scenario's road (a
``[roundabout]`` and a ``[route]``): the flows' legs and exit shares are checked against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from model.errors import InputError
from model.problem.tables import array_of_tables, is_number, no_unknown, number, table_of
from model.scene.road import Road

TRAFFIC_KEYS = {"seed", "warmup", "time_limit", "step", "safety_distance", "flows", "speed_planner"}
FLOW_KEYS = {"leg", "vehicles_per_hour", "exits", "type"}
FLOW_TYPES = ("passenger", "truck", "bus", "motorcycle")
SPEED_PLANNERS = ("rules", "qp")  # the autopilot's speed along its plan: rule-based profiles, or the QP
SHARE_TOL = 1e-9  # the exit shares sum to 1 within this
DIVISOR_TOL = 1e-9  # relative: warmup / step within this of a whole number


@dataclass(frozen=True)
class Flow:
    """One entering stream: random departures at ``vehicles_per_hour`` from ``leg``, exits by shares.

    ``exits[n]`` is the share of vehicles that leave by the (n + 1)-th exit after the entry, counted
    as ``[route].exit`` counts them (the last one is the U-turn).
    """

    leg: int
    vehicles_per_hour: float
    exits: tuple[float, ...]
    type: str = "passenger"


@dataclass(frozen=True)
class TrafficSettings:
    """The ``[traffic]`` table: SUMO's seed and step, the warm-up, the time limit, the flows, the speed planner."""

    seed: int = 0
    warmup: float = 60.0
    time_limit: float = 240.0
    step: float = 0.1
    safety_distance: float = 1.0
    flows: tuple[Flow, ...] = ()
    speed_planner: str = "rules"

    @property
    def depart(self) -> float:
        """The truck's SUMO departure time, ``warmup - step`` (it appears at ``warmup``)."""
        return round(self.warmup - self.step, 9)


def parse_traffic(data: dict[str, Any], road: Road | None) -> TrafficSettings | None:
    """The scenario's ``[traffic]`` table, or None without one.

    Parameters
    ----------
    data : dict
        The whole TOML document.
    road : Road or None
        The scenario's road; a ``[traffic]`` table without a ``[roundabout]`` is refused.

    Raises
    ------
    InputError
        Naming the first bad key (``traffic.step``, ``traffic.flows[1].exits``, ...).
    """
    if "traffic" not in data:
        return None
    table = table_of(data, "traffic")
    if road is None or "roundabout" not in data:
        raise InputError("traffic", "needs a [roundabout] and a [route]")
    no_unknown(table, TRAFFIC_KEYS, "traffic.")
    step = _finite(table, "step", TrafficSettings.step)
    if step <= 0:
        raise InputError("traffic.step", f"must be > 0, got {step:g}")
    warmup = _finite(table, "warmup", TrafficSettings.warmup)
    ratio = warmup / step
    if warmup < step or abs(ratio - round(ratio)) > DIVISOR_TOL * max(1.0, ratio):
        raise InputError("traffic.step", f"must divide traffic.warmup = {warmup:g} s (and be at most it), got {step:g}")
    time_limit = _finite(table, "time_limit", TrafficSettings.time_limit)
    if time_limit <= 0:
        raise InputError("traffic.time_limit", f"must be > 0, got {time_limit:g}")
    safety = _finite(table, "safety_distance", TrafficSettings.safety_distance)
    if safety < 0:
        raise InputError("traffic.safety_distance", f"must be >= 0, got {safety:g}")
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**31:
        raise InputError("traffic.seed", f"must be a whole number 0 <= seed < 2^31, got {seed!r}")
    flows = tuple(
        _flow(item, where, road) for _, where, item in array_of_tables(table.get("flows", []), "traffic.flows")
    )
    planner = table.get("speed_planner", TrafficSettings.speed_planner)
    if planner not in SPEED_PLANNERS:
        raise InputError("traffic.speed_planner", f"must be one of {', '.join(SPEED_PLANNERS)}, got {planner!r}")
    return TrafficSettings(seed, warmup, time_limit, step, safety, flows, planner)


def _flow(item: dict[str, Any], where: str, road: Road) -> Flow:
    no_unknown(item, FLOW_KEYS, where)
    k = len(road.roundabout.legs)
    leg = item.get("leg")
    if isinstance(leg, bool) or not isinstance(leg, int) or not 0 <= leg < k:
        raise InputError(where + "leg", f"must be a leg index 0..{k - 1}, got {leg!r}")
    if "vehicles_per_hour" not in item:
        raise InputError(where + "vehicles_per_hour", "missing")
    rate = number(item, "vehicles_per_hour", where)
    if not (math.isfinite(rate) and rate >= 0):
        raise InputError(where + "vehicles_per_hour", f"must be a finite number >= 0, got {rate!r}")
    shares = item.get("exits", [1.0 / k] * k)
    if not (isinstance(shares, list) and all(is_number(s) and math.isfinite(s) for s in shares)):
        raise InputError(where + "exits", f"must be a list of {k} finite numbers, got {shares!r}")
    if len(shares) != k:
        raise InputError(where + "exits", f"must have one share per exit ({k}), got {len(shares)}")
    if any(s < 0 for s in shares) or abs(sum(shares) - 1.0) > SHARE_TOL:
        raise InputError(where + "exits", f"shares must be >= 0 and sum to 1, got {shares!r}")
    kind = item.get("type", "passenger")
    if kind not in FLOW_TYPES:
        raise InputError(where + "type", f"must be one of {', '.join(FLOW_TYPES)}, got {kind!r}")
    return Flow(leg, float(rate), tuple(float(s) for s in shares), kind)


def _finite(table: dict[str, Any], key: str, default: float) -> float:
    val = number(table, key, "traffic.", default)
    if not math.isfinite(val):
        raise InputError("traffic." + key, f"must be a finite number, got {val}")
    return val


__all__ = ["FLOW_TYPES", "SPEED_PLANNERS", "Flow", "TrafficSettings", "parse_traffic"]
