"""Connected vehicles that keep clear of the truck: the SUMO side of the roundabout management.

The truck announces the windows of ``model.traffic.windows`` (plan time, turned into clock time by
the truck's actual progress, ``clock_windows``: from its plan time ``s`` and progress rate now, the
rate rising at its slope to the plan's pace). Each step, each other vehicle's path ahead (the rest of
its lane and the first lanes of the edges left on its route, from SUMO's lane shapes) is intersected
with each announced area (a vehicle already in an area the truck has still to pass is left alone:
held there, it would stand in the truck's way); where ``keep_clear_speed`` says it would meet the
truck there, the vehicle gets that speed (``traci.vehicle.setSpeed``, SUMO's own deceleration limits
apply), the lowest over the windows; a vehicle no window concerns any more is handed back to SUMO's
driver (``setSpeed -1``). ``Cooperator`` does this for the vehicles a policy lets it hold.

The ``cooperative`` driver's policy (``PriorityRequest``, issue 45): the truck yields as the
autopilot does and asks for priority only when it would otherwise wait (slowing for or standing at
its line), only if every vehicle that keeps its plan's pace from being safe can be held (``blockers``:
one already in the entry's area cannot), and only once the time it has lost (its clock time since it
appeared less its plan time, plus what regaining its plan's pace from its rate now costs) is at least
what the request would cost the vehicles it holds (``hold_cost``: each held vehicle's later arrival
at the area, at its speed now): a rent-or-buy rule, which on that estimate never loses more than
twice the better of waiting and asking. A granted request holds only the vehicles whose paths meet
the truck in its entry leg's area, and each only until the truck's window there closes (the windows
at the truck's actual progress); with no request the run is the autopilot's, with no speed set. The
``reservation`` driver (``model.traffic.reservation``) is the first-come-first-served baseline on the
same mechanics.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import shapely
from shapely.ops import substring

from model.problem.ocp import OCP
from model.problem.scenario import Scenario
from model.scene.moving import MovingVehicle
from model.traffic.autopilot import FOLLOWER_DECEL, MARGIN_HORIZON, PREDICTION_MARGIN
from model.traffic.windows import Window, clock_windows, conflict_areas, footprint, occupancy_windows

KEEP_CLEAR_MARGIN = 1.0  # s kept free before and after each of the truck's windows
REACH = 80.0  # m of a vehicle's path ahead that is looked at
HOLD_BUFFER = 1.5  # m: a held vehicle stops this far outside the area (safety_distance 1 m and 0.5 m more)
SLOW_SPEED = 1.0  # m/s: a vehicle slower than this is taken to reach the area at this speed (``hold_cost``)
STOP_SPEED = 1.0  # m/s: a keep-clear speed below this is asked as 0 (held still, not creeping to the area)
STOP_DECEL = 2.0  # m/s^2: the cooperative driver asks a held vehicle that can stop braking this gently to stand


class Progress(Protocol):
    """What the management reads of the truck's driver (``model.traffic.autopilot.Autopilot``)."""

    s: float  # plan time the truck has reached
    rate: float  # its progress rate, plan seconds per second
    rate_slope: float  # how fast the rate can rise, 1/s
    give_way: float  # plan time of its give-way line
    scenario: Scenario  # its scenario (the safety distance)

    def instants(self, step: float) -> np.ndarray: ...  # the checked instants of a decision

    def near(self, others: list, tau: np.ndarray) -> list: ...  # the vehicles that can come near

    def predicted(self, others: list, tau: np.ndarray) -> np.ndarray: ...  # their predicted corners

    def clearances(self, s: np.ndarray, theirs: np.ndarray) -> np.ndarray: ...  # least distance per instant

    def net_gap(self, tau: np.ndarray, s: np.ndarray, gaps: np.ndarray) -> float: ...  # the distance less the margin

    def follower_braking(self, tau: np.ndarray, rates: np.ndarray, s: np.ndarray, theirs: np.ndarray) -> float: ...

    def junction_conflict(self, tau: np.ndarray, s: np.ndarray, theirs: np.ndarray) -> bool: ...


@dataclass
class Cooperator:
    """The announcement of one plan and the speeds it asks of the other vehicles.

    Parameters
    ----------
    ocp : OCP
        The truck's problem (bodies, roundabout).
    plan_at : callable
        Plan time(s) -> state columns (``Plan.at``).
    duration : float
        The plan's final time, s.
    step : float
        The co-simulation's step, s (the windows' sampling).
    margin : float
        ``KEEP_CLEAR_MARGIN``.
    buffer : float
        ``HOLD_BUFFER``: the areas a vehicle is held out of are the conflict areas grown by this (the truck's
        windows are its rectangles grown by it too), so that a held vehicle stands clear of the truck.
    stop_speed : float
        A keep-clear speed below this is asked as 0 (``STOP_SPEED`` for the managed drivers; 0 here: as
        asked). A car creeping toward the area stays a follower the truck's entry would make brake hard.
    stop_decel : float
        m/s^2; > 0: a vehicle that would be asked to keep clear and can stop before the area braking at
        most this hard is asked to stand (0: off, the keep-clear speed). ``STOP_DECEL`` for the cooperative
        driver: held behind a standing truck at the keep-clear speed a car creeps to the area, and the
        autopilot's follower check then refuses the entry (it would brake at 9 m/s^2).
    swept : bool
        Whether each area is cut down to the ground the truck's rectangles, grown by ``buffer``, cover along
        its plan (``footprint``): a vehicle is then held only out of the part of a leg's area the truck
        uses, and one in the rest of it (e.g. circulating toward the truck's entry) can still be held.
    """

    ocp: OCP
    plan_at: object
    duration: float
    step: float
    margin: float = KEEP_CLEAR_MARGIN
    buffer: float = HOLD_BUFFER
    swept: bool = False
    stop_speed: float = 0.0
    stop_decel: float = 0.0
    windows: list[Window] = field(init=False)
    areas: dict[int, shapely.Polygon] = field(init=False)
    commanded: dict[str, float] = field(init=False, default_factory=dict)
    _shapes: dict[str, list] = field(init=False, default_factory=dict)

    def __post_init__(self):
        self.windows = occupancy_windows(self.ocp, self.plan_at, self.duration, self.step, grow=self.buffer)
        self.areas = {a.leg: a.polygon.buffer(self.buffer) for a in conflict_areas(self.ocp.road.roundabout)}
        if self.swept:
            ground = footprint(self.ocp, self.plan_at, self.duration, self.step, grow=self.buffer)
            self.areas = {leg: area.intersection(ground) for leg, area in self.areas.items()}

    def announced(self, now: float, s: float, rate: float = 1.0, slope: float = math.inf) -> list[Window]:
        """The windows still ahead of plan time ``s`` in clock time, from the truck's progress (``clock_windows``;
        the defaults: at its plan's pace from now)."""
        return clock_windows(self.windows, now, s, rate, slope)

    def asks(self, traci, now: float, windows: list[Window], truck: str = "truck",
             holds: Callable[[str], bool] | None = None) -> dict[str, float]:  # fmt: skip
        """The speed each vehicle would be asked for (``keep_clear_speed``, the lowest over ``windows``).

        ``holds``: vehicle id -> whether it may be held (default: every vehicle); a vehicle already in an
        area of ``windows`` is not held (held there, it would stand in the truck's way), unless it was asked
        to stand (speed 0) the step before: it stopped at the area's edge (grown by ``buffer`` beyond the
        truck's ground) with its front a little past it, and released it would drive on into the truck's way.
        """
        ahead = shapely.union_all([self.areas[leg] for leg in {w.leg for w in windows}])
        speeds = {}
        for vid in traci.vehicle.getIDList():
            if vid == truck or (holds is not None and not holds(vid)):
                continue
            if ahead.contains(shapely.Point(traci.vehicle.getPosition(vid))):
                if self.commanded.get(vid) == 0.0:  # stopped at the area's edge, its front a little in: stays
                    speeds[vid] = 0.0
                continue
            path = path_ahead(traci, vid, shape=self.shapes(traci))
            if path is None:
                continue
            speed, length = traci.vehicle.getSpeed(vid), traci.vehicle.getLength(vid)
            asked = [a for w in windows if (a := self._ask(path, w, speed, length, now, traci, vid)) is not None]
            if asked:
                speeds[vid] = min(asked) if min(asked) >= self.stop_speed else 0.0
        return speeds

    def command(self, traci, speeds: dict[str, float]) -> dict[str, float]:
        """Set ``speeds`` and hand every vehicle held before and not now back to SUMO; every ``setSpeed`` sent."""
        sent = speeds | {vid: -1.0 for vid in sorted(set(self.commanded) - set(speeds))}
        apply_commands(traci, sent)
        self.commanded = dict(speeds)
        return sent

    def step_traffic(self, traci, now: float, s: float, truck: str = "truck", announce: bool = True,
                     rate: float = 1.0, slope: float = math.inf,
                     holds: Callable[[str], bool] | None = None) -> dict[str, float]:  # fmt: skip
        """Set the speeds of the vehicles that would meet the truck in an area; release the others.

        ``announce`` False: no window, every vehicle released. ``rate``, ``slope``: the truck's progress
        (``announced``); ``holds``: which vehicles may be held (``asks``). Returns every ``setSpeed`` of this
        step (vehicle id -> m/s; -1 for a vehicle handed back to SUMO).
        """
        windows = self.announced(now, s, rate, slope) if announce else []
        return self.command(traci, self.asks(traci, now, windows, truck, holds) if windows else {})

    def hold_cost(self, traci, now: float, speeds: dict[str, float], windows: list[Window]) -> float:
        """Seconds the vehicles asked for ``speeds`` would lose, out of the areas of ``windows`` (clock times).

        Per vehicle: its arrival at the first of those areas along its path at the speed asked (asked to
        stand: when the last window has closed, ``margin`` after it) less its arrival at its speed now (at
        least ``SLOW_SPEED``).
        """
        areas = [self.areas[leg] for leg in {w.leg for w in windows}]
        free = max((w.end for w in windows), default=now) + self.margin - now
        loss = 0.0
        for vid, asked in speeds.items():
            path = path_ahead(traci, vid, shape=self.shapes(traci))
            entries = [e[0] for a in areas if path is not None and (e := area_entry(path, a))]
            distance = min(entries, default=0.0)
            own = distance / max(traci.vehicle.getSpeed(vid), SLOW_SPEED)
            held = distance / asked if asked > 0.0 else free
            loss += max(held - own, 0.0)
        return loss

    def shapes(self, traci):
        """SUMO's lane shapes, asked once per lane (they do not change)."""

        def shape(lane: str) -> list:
            if lane not in self._shapes:
                self._shapes[lane] = list(traci.lane.getShape(lane))
            return self._shapes[lane]

        return shape

    def _ask(self, path, window: Window, speed: float, length: float, now: float, traci, vid: str) -> float | None:
        """``keep_clear_speed`` for one vehicle and one window (None if its path misses the area)."""
        entry = area_entry(path, self.areas[window.leg])
        if entry is None:
            return None
        distance, through = entry
        asked = keep_clear_speed(distance, through + length, speed, now, window, self.margin,
                                 traci.vehicle.getAllowedSpeed(vid))  # fmt: skip
        if asked is not None and self.stop_decel > 0.0 and speed * speed <= 2.0 * self.stop_decel * distance:
            return 0.0  # it can stop before the area braking gently: it waits there (no creeping follower)
        return asked


@dataclass
class PriorityRequest:
    """The ``cooperative`` driver's management: priority asked for only when waiting costs more than asking.

    Parameters
    ----------
    cooperator : Cooperator
        The announcement and the speeds it asks.
    enter : int
        The truck's entry leg: only the vehicles that would meet it in that leg's conflict area are held
        (the ones that make it wait at its line; on the rest of the ring SUMO's vehicles give way to the
        circulating truck or follow it by their own rules).
    appeared : float or None
        Clock time of the truck's appearance (set at the first step).
    granted : bool
        Whether the request stands (decided afresh each step before the line; past it, kept until the
        truck has left the entry's area).
    spent : float
        Vehicle-seconds of holding so far while the truck waited before its line: added to the hold's cost,
        so that a hold that does not get the truck going ends once it has cost what the truck lost.
    reasons : dict
        The steps in which the truck waited before its line, counted by the first rule that refused the
        request ("no vehicle to hold", "a blocker cannot be held", "holding would not clear the way": with
        the held vehicles standing where they are the plan's pace still fails the autopilot's checks,
        ``clears``; "the hold costs more than the time lost"), or "asked".
    """

    cooperator: Cooperator
    enter: int
    appeared: float | None = None
    granted: bool = False
    reasons: dict[str, int] = field(default_factory=dict)  # steps the truck waited, by what its request said
    spent: float = 0.0  # vehicle-seconds held while the truck waited before its line

    def lost(self, now: float, pilot: Progress) -> float:
        """Seconds the truck has lost and cannot but lose: clock time since it appeared less the plan time it has
        reached (``pilot.s`` is at the end of the step that starts at ``now``), plus what getting back to its
        plan's pace costs from its rate now, (1 - rate)^2 / (2 slope)."""
        if self.appeared is None:
            self.appeared = now
        restart = (1.0 - min(max(pilot.rate, 0.0), 1.0)) ** 2 / (2.0 * pilot.rate_slope)
        return now + self.cooperator.step - self.appeared - pilot.s + restart

    def step(self, traci, now: float, pilot: Progress, others: list | None = None,
             truck: str = "truck") -> dict[str, float]:  # fmt: skip
        """One step: request priority if it is time to, hold the vehicles a granted request concerns.

        Before the truck's give-way line (or standing at it) the request is decided afresh each step: the
        truck is slowing or standing, every vehicle that keeps its plan's pace from being safe
        (``blockers`` of the predicted ``others``) is one that can be held, and the time lost so far is at
        least ``Cooperator.hold_cost`` of the hold. Past the line the decision at the line stays until the
        truck has left the entry's area. Returns every ``setSpeed`` of this step (``Cooperator.command``).
        """
        coop = self.cooperator
        windows = [w for w in coop.announced(now, pilot.s, pilot.rate, pilot.rate_slope) if w.leg == self.enter]
        lost = self.lost(now, pilot)
        if not windows:
            return coop.command(traci, {})
        speeds = coop.asks(traci, now, windows, truck)
        if pilot.s <= pilot.give_way + 1e-9:  # slowing for, or standing at, its line
            self.granted = pilot.rate < 1.0 and self.decide(traci, now, pilot, others or [], speeds, lost, windows)
            self.spent += coop.step * len(speeds) if self.granted else 0.0
        return coop.command(traci, speeds if self.granted else {})

    def decide(self, traci, now: float, pilot: Progress, others: list, speeds: dict[str, float], lost: float,
               windows: list[Window]) -> bool:  # fmt: skip
        """Whether a waiting truck asks now; the step counted in ``reasons`` under the first rule that says no."""
        if not speeds:
            reason = "no vehicle to hold"
        elif not blockers(pilot, others, self.cooperator.step) <= set(speeds):
            reason = "a blocker cannot be held"
        elif not clears(pilot, [standing(o) if sumo_id(o) in speeds else o for o in others], self.cooperator.step):
            reason = "holding would not clear the way"
        elif lost < self.cooperator.hold_cost(traci, now, speeds, windows) + self.spent:
            reason = "the hold costs more than the time lost"
        else:
            reason = "asked"
        self.reasons[reason] = self.reasons.get(reason, 0) + 1
        return reason == "asked"


def sumo_id(other: MovingVehicle) -> str:
    """SUMO's id of a predicted vehicle (its key is ``traffic <id>``)."""
    return str(other.key).removeprefix("traffic ")


def standing(other: MovingVehicle) -> MovingVehicle:
    """``other`` held still where it is now (a vehicle given only a path keeps it)."""
    if other.start is None:
        return other
    return MovingVehicle(other.length, other.width, start=other.start, speed=0.0, yaw_rate=0.0, key=other.key)


def pace_profile(pilot: Progress, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The autopilot's ``rate 1`` profile at ``tau``: the rate rising at its slope to 1, and the plan times."""
    rate = np.clip(1.0, pilot.rate - pilot.rate_slope * tau, pilot.rate + pilot.rate_slope * tau)
    return rate, pilot.s + np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tau))])


def clears(pilot: Progress, others: list, step: float) -> bool:
    """Whether the plan's pace would pass the autopilot's own checks among ``others`` (the held ones standing):
    the distance with its margin (``Autopilot.net_gap``), no circulating follower braking above
    ``FOLLOWER_DECEL`` and, with the junction rule on, no junction conflict."""
    tau = pilot.instants(step)
    rate, s = pace_profile(pilot, tau)
    theirs = pilot.predicted(others, tau)
    if pilot.net_gap(tau, s, pilot.clearances(s, theirs)) < pilot.scenario.traffic.safety_distance:
        return False
    return pilot.follower_braking(tau, rate, s, theirs) <= FOLLOWER_DECEL and not pilot.junction_conflict(
        tau, s, theirs
    )


def blockers(pilot: Progress, others: list, step: float) -> set[str]:
    """The vehicles that keep the truck's plan pace from being safe now: SUMO ids of the predicted ``others``.

    The profile is the autopilot's ``rate 1`` (the rate rising at its slope to the plan's pace); a
    vehicle blocks it if its predicted rectangle comes nearer the truck's bodies than the safety distance
    plus the prediction margin at an instant after now (``Autopilot.net_gap``'s measure, per vehicle).
    """
    tau = pilot.instants(step)
    near = pilot.near(others, tau)
    if not near:
        return set()
    theirs = pilot.predicted(near, tau)
    _, s = pace_profile(pilot, tau)
    need = pilot.scenario.traffic.safety_distance + PREDICTION_MARGIN * np.minimum(tau[1:], MARGIN_HORIZON)
    return {sumo_id(o) for k, o in enumerate(near)
            if np.any(pilot.clearances(s, theirs[k : k + 1])[1:] < need)}  # fmt: skip


def path_ahead(traci, vid: str, reach: float = REACH, shape=None) -> shapely.LineString | None:
    """The vehicle's path ahead of its front: the rest of its lane, then the first lane of each edge left on its
    route, up to ``reach`` metres (None if SUMO gives no shape); ``shape``: lane id -> its points (default:
    ``traci.lane.getShape``)."""
    shape = shape or (lambda lane: list(traci.lane.getShape(lane)))
    lane, pos = traci.vehicle.getLaneID(vid), traci.vehicle.getLanePosition(vid)
    points = shape(lane) if lane else []
    if len(points) < 2:
        return None
    here = shapely.LineString(points)
    coords = list(substring(here, min(pos, here.length), here.length).coords)
    total = here.length - min(pos, here.length)
    route, index = traci.vehicle.getRoute(vid), traci.vehicle.getRouteIndex(vid)
    for edge in route[max(index, 0) + 1 :]:
        if total >= reach:
            break
        more = shape(f"{edge}_0")
        coords += more
        total += shapely.LineString(more).length if len(more) > 1 else 0.0
    return shapely.LineString(coords) if len(coords) > 1 else None


def area_entry(path: shapely.LineString, area: shapely.Polygon) -> tuple[float, float] | None:
    """Where ``path`` first enters ``area`` (its length before, m; 0 if it starts inside) and its length inside
    (None if it misses the area)."""
    inside = path.intersection(area)
    if inside.is_empty or inside.length == 0.0:
        return None
    parts = getattr(inside, "geoms", [inside])
    first = min(path.project(shapely.Point(p.coords[0])) for p in parts if p.length > 0)
    return first, inside.length


def apply_commands(traci, speeds: dict[str, float]) -> None:
    """``traci.vehicle.setSpeed`` for each vehicle still in the simulation (-1: back to SUMO's driver)."""
    alive = set(traci.vehicle.getIDList()) if speeds else set()
    for vid, speed in speeds.items():
        if vid in alive:
            traci.vehicle.setSpeed(vid, speed)


def commands_text(commands: dict[float, dict[str, float]]) -> str:
    """``commands.csv`` of a cooperative run: t, id, speed (m/s; -1 hands the vehicle back to SUMO).

    The speeds in repr precision: the replay must set the very speeds the run set (rounded to 1e-6 m/s
    they moved a car 1e-6 m off its recorded row within 7 s).
    """
    lines = ["t,id,speed"] + [f"{t:g},{vid},{float(v)!r}" for t in sorted(commands) for vid, v in commands[t].items()]
    return "\n".join(lines) + "\n"


def keep_clear_speed(distance: float, length: float, speed: float, now: float, window: Window, margin: float,
                     max_speed: float) -> float | None:  # fmt: skip
    """The speed that keeps a connected vehicle out of a conflict area while the truck occupies it.

    Parameters
    ----------
    distance : float
        Along its lane to where it enters the area, m (<= 0: it is in it or past it).
    length : float
        How far it drives from entering the area to having left it (its path through the area plus its
        own length), m.
    speed : float
        Its speed now, m/s.
    now : float
        Clock time, s; ``window`` is in the same clock.
    window : Window
        When the truck occupies the area (clock times).
    margin : float
        Seconds kept free before and after the window.
    max_speed : float
        Its speed limit, m/s.

    Returns
    -------
    float or None
        None if it may keep its own speed (it leaves the area ``margin`` before the window opens, or
        reaches it after the window closes, or is already inside: it drives on); else the speed that
        brings it to the area ``margin`` after the window closes (0 if it should stop before it).
    """
    if distance <= 0.0:
        return None
    opens, closes = window.start - margin, window.end + margin
    if closes <= now:
        return None
    if speed > 0.0 and now + (distance + length) / speed <= opens:  # through before the truck comes
        return None
    if speed > 0.0 and now + distance / speed >= closes:  # it arrives after the truck has left
        return None
    return min(max_speed, distance / (closes - now))
