"""Connected vehicles that keep clear of the truck: the SUMO side of the cooperative mode.

The truck announces the windows of ``model.traffic.windows`` (plan time, turned into clock time by
the truck's progress: at its plan's pace from plan time ``s`` on, window [a, b] is
[now + a - s, now + b - s]). Every step, each other vehicle's path ahead (the rest of its lane and
the first lanes of the edges left on its route, from SUMO's lane shapes) is intersected with each
announced area (a vehicle already in an area the truck has still to pass is left alone: held there, it
would stand in the truck's way); where ``keep_clear_speed`` says it would meet the truck there, the vehicle gets
that speed (``traci.vehicle.setSpeed``, SUMO's own deceleration limits apply), the lowest over the
windows; a vehicle no window concerns any more is handed back to SUMO's driver (``setSpeed -1``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import shapely
from shapely.ops import substring

from model.problem.ocp import OCP
from model.traffic.windows import Window, conflict_areas, occupancy_windows

KEEP_CLEAR_MARGIN = 1.0  # s kept free before and after each of the truck's windows
REACH = 80.0  # m of a vehicle's path ahead that is looked at
HOLD_BUFFER = 1.5  # m: a held vehicle stops this far outside the area (safety_distance 1 m and 0.5 m more)
COMMIT_RATE = 0.5  # before its give-way line the truck announces only while it drives at least this x its pace


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
    """

    ocp: OCP
    plan_at: object
    duration: float
    step: float
    margin: float = KEEP_CLEAR_MARGIN
    buffer: float = HOLD_BUFFER
    windows: list[Window] = field(init=False)
    areas: dict[int, shapely.Polygon] = field(init=False)
    commanded: dict[str, float] = field(init=False, default_factory=dict)
    _shapes: dict[str, list] = field(init=False, default_factory=dict)

    def __post_init__(self):
        self.windows = occupancy_windows(self.ocp, self.plan_at, self.duration, self.step, grow=self.buffer)
        self.areas = {a.leg: a.polygon.buffer(self.buffer) for a in conflict_areas(self.ocp.road.roundabout)}

    def announced(self, now: float, s: float) -> list[Window]:
        """The windows still ahead of plan time ``s``, in clock time (the truck at its plan's pace from now)."""
        return [Window(w.leg, now + max(w.start - s, 0.0), now + w.end - s) for w in self.windows if w.end > s]

    def step_traffic(self, traci, now: float, s: float, truck: str = "truck",
                     announce: bool = True) -> dict[str, float]:  # fmt: skip
        """Set the speeds of the vehicles that would meet the truck in an area; release the others.

        ``announce`` False (the truck waiting at its line: ``committed``): no window, every vehicle released.
        Returns every ``setSpeed`` of this step (vehicle id -> m/s; -1 for a vehicle handed back to SUMO).
        """
        windows = self.announced(now, s) if announce else []
        ahead = shapely.union_all([self.areas[leg] for leg in {w.leg for w in windows}])
        speeds = {}
        for vid in traci.vehicle.getIDList():
            if vid == truck or ahead.contains(shapely.Point(traci.vehicle.getPosition(vid))):
                continue  # a vehicle in an area the truck has still to pass drives on (held, it would block it)
            path = path_ahead(traci, vid, shape=self._shape(traci))
            if path is None:
                continue
            speed, length = traci.vehicle.getSpeed(vid), traci.vehicle.getLength(vid)
            asks = [a for w in windows if (a := self._ask(path, w, speed, length, now, traci, vid)) is not None]
            if asks:
                speeds[vid] = min(asks)
        sent = speeds | {vid: -1.0 for vid in sorted(set(self.commanded) - set(speeds))}
        apply_commands(traci, sent)
        self.commanded = speeds
        return sent

    def _shape(self, traci):
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
        return keep_clear_speed(distance, through + length, speed, now, window, self.margin,
                                traci.vehicle.getAllowedSpeed(vid))  # fmt: skip


def committed(s: float, rate: float, give_way: float) -> bool:
    """Whether the truck announces: past its give-way line (plan time ``give_way``), or before it at a pace
    ``rate`` of at least ``COMMIT_RATE`` (a truck slowing to stop at its line, or standing, holds no one)."""
    return s >= give_way or rate >= COMMIT_RATE


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
