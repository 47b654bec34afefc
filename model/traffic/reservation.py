"""The ``reservation`` driver: first come, first served on the ring's conflict areas (Dresner and Stone's AIM).

After Dresner and Stone's autonomous intersection management (2008): each vehicle reserves the
conflict areas it will occupy, in the order of its arrival at its entry; a request that conflicts
with an earlier reservation is refused and the vehicle slows or waits. Here the truck and the
connected cars share the ring's conflict areas (``model.traffic.windows.conflict_areas``, each cut down
to the ground the truck covers in it, ``Cooperator(swept=True)``); a vehicle arrives when its front
comes within ``ARRIVAL_DISTANCE`` of the ring (the ring roadway grown by ``HOLD_BUFFER``, along its
path), the distance at which ``model.traffic.gaps`` puts a driver at its line; the truck's arrival
is the plan time at which its front bumper comes within that distance of the outer curb.

- A car that arrived before the truck holds its reservation: it is never held, and the truck's
  autopilot yields to it as it yields to any vehicle (its own checks, unchanged).
- From the truck's arrival on, its reservation is its windows at its actual progress
  (``clock_windows``), and every car arriving after it (ties: the car is the later) is refused where
  it would meet the truck in an area: it gets ``keep_clear_speed`` (``Cooperator``), until the
  truck's window in that area has closed.
- Conflicts between two cars are left to SUMO's own priority rule, as in the runs without the truck
  (the time they lose is measured against those runs: a manager among the cars alone would change
  that baseline).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from model.problem.ocp import OCP
from model.problem.scenario import Scenario
from model.traffic.cooperative import (
    STOP_DECEL,
    STOP_SPEED,
    Cooperator,
    PriorityRequest,
    Progress,
    area_entry,
    path_ahead,
)
from model.traffic.windows import conflict_areas

ARRIVAL_DISTANCE = 10.0  # m: a vehicle arrives at its entry when its front comes this near the ring


def arrival_time(ocp: OCP, plan_at, duration: float, front: float, distance: float = ARRIVAL_DISTANCE) -> float:
    """Plan time at which the truck's front bumper first comes within ``distance`` of the outer curb.

    Parameters
    ----------
    ocp : OCP
        The truck's problem (its roundabout, its states' roles).
    plan_at : callable
        Plan time(s) -> state columns (``Plan.at``).
    duration : float
        The plan's final time, s.
    front : float
        The front bumper's distance ahead of the reference point along the heading, m.
    distance : float
        Metres outside the outer curb.

    Returns
    -------
    float
        The first sampled plan time (2001 samples) within the distance; ``duration`` if none is.
    """
    ra, v = ocp.road.roundabout, ocp.vehicle
    s = np.linspace(0.0, duration, 2001)
    st = plan_at(s)
    px, py = v.position
    h = st[v.roles.heading]
    r = np.hypot(st[px] + front * np.cos(h) - ra.center[0], st[py] + front * np.sin(h) - ra.center[1])
    inside = np.flatnonzero(r <= ra.outer_radius + distance)
    return float(s[inside[0]]) if len(inside) else duration


@dataclass
class Reservation:
    """First come, first served between the truck and the connected cars.

    Parameters
    ----------
    cooperator : Cooperator
        The truck's windows and the speeds that keep a refused car clear of them.
    arrival : float
        Plan time of the truck's arrival at its entry (``arrival_time``).
    distance : float
        ``ARRIVAL_DISTANCE``.
    """

    cooperator: Cooperator
    arrival: float
    distance: float = ARRIVAL_DISTANCE
    arrived: dict[str, float] = field(default_factory=dict)  # car id -> clock time of its arrival
    truck_arrived: float | None = None
    ring: shapely.Geometry = field(init=False, repr=False)

    def __post_init__(self) -> None:
        coop = self.cooperator
        self.ring = shapely.union_all([a.polygon for a in conflict_areas(coop.ocp.road.roundabout)]).buffer(coop.buffer)

    def note_arrivals(self, traci, now: float, truck: str = "truck") -> None:
        """Record the clock time of each car's arrival: its front within ``distance`` of the ring along its path,
        or in it; the cars there when the truck appears arrived before it (``-inf``)."""
        first = not self.arrived and self.truck_arrived is None
        for vid in traci.vehicle.getIDList():
            if vid == truck or vid in self.arrived:
                continue
            if self.ring.contains(shapely.Point(traci.vehicle.getPosition(vid))):
                self.arrived[vid] = -math.inf if first else now
                continue
            path = path_ahead(traci, vid, shape=self.cooperator.shapes(traci))
            entry = area_entry(path, self.ring) if path is not None else None
            if entry is not None and entry[0] <= self.distance:
                self.arrived[vid] = -math.inf if first else now

    def later(self, vid: str) -> bool:
        """Whether car ``vid`` arrives after the truck (not yet arrived counts as later)."""
        return self.truck_arrived is not None and self.arrived.get(vid, math.inf) >= self.truck_arrived

    def step(self, traci, now: float, pilot: Progress, others: list | None = None,
             truck: str = "truck") -> dict[str, float]:  # fmt: skip
        """One step: note arrivals, and from the truck's on refuse the later cars that meet its windows
        (``others``, the autopilot's predictions, are not needed: the order of arrival decides).

        Returns every ``setSpeed`` of this step (``Cooperator.command``).
        """
        coop = self.cooperator
        self.note_arrivals(traci, now, truck)
        if self.truck_arrived is None and pilot.s >= self.arrival:
            self.truck_arrived = now
        windows = coop.announced(now, pilot.s, pilot.rate, pilot.rate_slope) if self.truck_arrived is not None else []
        return coop.command(traci, coop.asks(traci, now, windows, truck, self.later) if windows else {})


def traffic_manager(kind: str, scenario: Scenario, plan, front: float) -> PriorityRequest | Reservation:
    """The management of a managed driver: ``cooperative`` (``PriorityRequest``) or ``reservation``.

    Parameters
    ----------
    kind : str
        The driver's name.
    scenario : Scenario
        The run's scenario (its problem and its step).
    plan : Plan
        The autopilot's plan (``at``, ``duration``).
    front : float
        The truck's front bumper ahead of its reference point, m.

    Returns
    -------
    PriorityRequest or Reservation
        Its ``step(traci, now, pilot)`` sets the other vehicles' speeds each step.
    """
    ocp, step = scenario.ocp, scenario.traffic.step
    if kind == "reservation":
        coop = Cooperator(ocp, plan.at, plan.duration, step, swept=True, stop_speed=STOP_SPEED)
        return Reservation(coop, arrival_time(ocp, plan.at, plan.duration, front))
    if kind == "cooperative":  # held behind a waiting truck: stand, do not creep
        coop = Cooperator(ocp, plan.at, plan.duration, step, swept=True, stop_speed=STOP_SPEED, stop_decel=STOP_DECEL)
        return PriorityRequest(coop, ocp.road.route.enter)
    raise ValueError(f"no management for the driver {kind!r}")


__all__ = ["ARRIVAL_DISTANCE", "Reservation", "arrival_time", "traffic_manager"]
