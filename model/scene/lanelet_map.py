"""Real roads from CommonRoad lanelet maps: the network, a route, its corridor and poses (docs/map-format.md).

A map is a CommonRoad XML file read with ``commonroad-io`` (no XML parser of our own): a file,
or a dataset name such as ``"rounD/DEU_Kackertstrasse-1"`` for
``crdata/datasets/rounD/maps/DEU_Kackertstrasse-1.xml`` of the installed (data-only)
``commonroad-dataset-converter``. Nothing is downloaded.

A ``MapRoute`` through it gives, on shapely geometry in the map's coordinates:

- the route: the shortest chain of lanelets from ``from_lanelet`` to ``to_lanelet`` through
  successors by centre-line length (with ``lane_changes`` and no such chain, through adjacent
  lanelets of the same direction too), and its centre line as a polyline with arclength and heading;
- the corridor: every lanelet on some legal path from ``from_lanelet`` to ``to_lanelet``
  (reachable from the one and reaching the other), plus the apron lanelets for the bodies
  ``apron_use`` allows, as the union of the lanelet polygons;
- the start and goal poses (x, y, heading) from the offsets.

Only lanelets a motor vehicle may drive on take part in routes and corridors (``drivable``):
not sidewalks, crosswalks, borders, bicycle lanes, restricted areas, shoulders or parking, and
not lanelets whose road users exclude motor vehicles. Apron lanelets may be of any type.

Scene layer: knows no vehicle and no solver; bodies are checked against the corridor by the
problem layer (``model/problem/maps.py``).
"""

from __future__ import annotations

import dataclasses
import difflib
import heapq
import importlib.metadata
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from model.errors import InputError

DATASETS = ("commonroad-dataset-converter", "crdata/datasets")  # distribution, folder of the map data in it
NOT_DRIVABLE = frozenset(
    {"sidewalk", "crosswalk", "border", "bicycleLane", "restricted", "restricted_area", "shoulder", "parking"}
)
MOTOR_VEHICLES = frozenset({"vehicle", "car", "truck", "bus", "priorityVehicle", "taxi"})
APRON_USE = ("trailer", "all", "none")
BODIES = ("vehicle", "trailer")
HEADING_SPAN = 1.0  # m: the heading at s is that of the chord from s - 1 m to s + 1 m of the centre line
LANE_CHANGE = (0.25, 0.75)  # fractions of the centre lines at which the route's line leaves and joins
CRACK = 1e-3  # m: cracks between neighbouring lanelet polygons up to this width are closed in the union


# --------------------------------------------------------------------------- reading


def dataset_folder() -> Path | None:
    """``crdata/datasets`` of the installed map data, or None where it is not installed."""
    try:
        dist = importlib.metadata.distribution(DATASETS[0])
    except importlib.metadata.PackageNotFoundError:
        return None
    folder = Path(str(dist.locate_file(DATASETS[1])))
    return folder if folder.is_dir() else None


def dataset_names() -> list[str]:
    """Every map of the installed datasets as ``"<dataset>/<map>"``, sorted."""
    folder = dataset_folder()
    if folder is None:
        return []
    return sorted(f"{p.parent.parent.name}/{p.stem}" for p in folder.glob("*/maps/*.xml"))


def dataset_file(name: str, key: str = "map.dataset") -> Path:
    """The XML file of dataset map ``name`` ("rounD/DEU_Kackertstrasse-1").

    Raises
    ------
    InputError
        ``key``: the map data is not installed, or no map has that name (the closest name suggested).
    """
    folder = dataset_folder()
    if folder is None:
        raise InputError(key, f"the map data ({DATASETS[0]}) is not installed: run python tools/install_solver.py")
    names = dataset_names()
    if name not in names:
        hint = difflib.get_close_matches(name, names, n=1, cutoff=0.0)
        raise InputError(key, f"unknown dataset {name!r}" + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    dataset, stem = name.split("/")
    return folder / dataset / "maps" / f"{stem}.xml"


@dataclass(frozen=True, eq=False)
class LaneletMap:
    """A CommonRoad lanelet network as read from one file.

    Parameters
    ----------
    path : Path
        The file it was read from.
    scenario : commonroad.scenario.scenario.Scenario
        The file's scenario (kept whole for writing the manoeuvre back into it).
    """

    path: Path
    scenario: Any

    @property
    def network(self):
        """The ``commonroad`` LaneletNetwork."""
        return self.scenario.lanelet_network

    @cached_property
    def ids(self) -> frozenset[int]:
        """Every lanelet id of the map."""
        return frozenset(lanelet.lanelet_id for lanelet in self.network.lanelets)

    def lanelet(self, lanelet_id: int):
        """The ``commonroad`` Lanelet of that id."""
        return self.network.find_lanelet_by_id(lanelet_id)

    def drivable(self, lanelet_id: int) -> bool:
        """Whether a motor vehicle may drive on the lanelet (its types and road users)."""
        lanelet = self.lanelet(lanelet_id)
        if {t.value for t in lanelet.lanelet_type} & NOT_DRIVABLE:
            return False
        users = {u.value for u in (lanelet.user_one_way or set()) | (lanelet.user_bidirectional or set())}
        return not users or bool(users & MOTOR_VEHICLES)

    def kind(self, lanelet_id: int) -> str:
        """The lanelet's types, comma-separated (for messages)."""
        return ", ".join(sorted(t.value for t in self.lanelet(lanelet_id).lanelet_type)) or "untyped"

    @cached_property
    def lengths(self) -> dict[int, float]:
        """Centre-line length of each lanelet, m."""
        return {i: polyline_length(self.lanelet(i).center_vertices) for i in self.ids}

    def polygon(self, lanelet_id: int) -> shapely.Polygon:
        """The lanelet's area: its left bound followed by its reversed right bound (made valid)."""
        lanelet = self.lanelet(lanelet_id)
        ring = np.vstack([lanelet.left_vertices, lanelet.right_vertices[::-1]])
        return valid_polygon(shapely.Polygon(ring))

    def successors(self, lanelet_id: int) -> list[int]:
        return [i for i in self.lanelet(lanelet_id).successor if i in self.ids]

    def neighbours(self, lanelet_id: int) -> list[int]:
        """The adjacent lanelets of the same direction (left and right)."""
        lanelet, out = self.lanelet(lanelet_id), []
        for adj, same in ((lanelet.adj_left, lanelet.adj_left_same_direction),
                          (lanelet.adj_right, lanelet.adj_right_same_direction)):  # fmt: skip
            if adj is not None and same and adj in self.ids:
                out.append(adj)
        return out


def read_map(path: str | Path, key: str = "map.file") -> LaneletMap:
    """Read a CommonRoad XML file (scenario or bare lanelet network, format 2018b / 2020a).

    Raises
    ------
    InputError
        ``key``: the file is missing or unreadable, not CommonRoad XML, or has no lanelet.
    """
    from commonroad.common.file_reader import CommonRoadFileReader

    path = Path(path)
    if not path.is_file():
        raise InputError(key, f"{path}: no such file")
    try:
        scenario, _ = CommonRoadFileReader(str(path)).open()
    except OSError as err:
        raise InputError(key, f"{path}: cannot be read ({err.strerror or err})") from None
    except Exception as err:  # noqa: BLE001 - the reader raises ParseError, AssertionError, AttributeError, ...
        raise InputError(key, f"{path}: not a CommonRoad XML file ({type(err).__name__}: {first_line(err)})") from None
    if not scenario.lanelet_network.lanelets:
        raise InputError(key, f"{path}: the map has no lanelets")
    return LaneletMap(path=path, scenario=scenario)


def first_line(err: Exception) -> str:
    text = str(err).strip().splitlines()
    return text[0][:200] if text else "no message"


# --------------------------------------------------------------------------- geometry helpers


def polyline_length(points: NDArray[np.float64]) -> float:
    return float(np.sum(np.hypot(*np.diff(np.asarray(points, float), axis=0).T)))


def valid_polygon(poly: shapely.Polygon) -> shapely.Polygon | shapely.MultiPolygon:
    """``poly`` itself if valid, else its valid repair (a lanelet whose bounds cross once is two triangles)."""
    return poly if poly.is_valid else shapely.make_valid(poly, method="structure")


def union(polygons: Iterable) -> shapely.Polygon | shapely.MultiPolygon:
    """Union of lanelet polygons with cracks narrower than ``CRACK`` closed (no area added elsewhere)."""
    merged = shapely.union_all(list(polygons))
    return merged.buffer(CRACK / 2, join_style="mitre").buffer(-CRACK / 2, join_style="mitre")


@dataclass(frozen=True)
class CentreLine:
    """A route's centre line: a polyline with its arclength.

    Attributes
    ----------
    points : ndarray, shape (n, 2)
        Vertices in the map's coordinates, no two consecutive equal.
    s : ndarray, shape (n,)
        Arclength at each vertex from the first, m.
    """

    points: NDArray[np.float64]
    s: NDArray[np.float64] = field(init=False)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, float)
        keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
        pts = pts[keep]
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "s", np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))]))

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def point(self, s: float | NDArray[np.float64]) -> NDArray[np.float64]:
        """Point(s) at arclength s (clipped to the line), shape (..., 2)."""
        s = np.clip(s, 0.0, self.length)
        return np.stack([np.interp(s, self.s, self.points[:, 0]), np.interp(s, self.s, self.points[:, 1])], -1)

    def heading(self, s: float | NDArray[np.float64]) -> NDArray[np.float64] | float:
        """Direction (rad, in (-pi, pi]) of the chord from s - HEADING_SPAN to s + HEADING_SPAN."""
        a, b = self.point(np.asarray(s) - HEADING_SPAN), self.point(np.asarray(s) + HEADING_SPAN)
        d = b - a
        return np.arctan2(d[..., 1], d[..., 0])

    def project(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Arclength of the nearest point of the line to each point (..., 2)."""
        line = shapely.LineString(self.points)
        return np.asarray(shapely.line_locate_point(line, shapely.points(np.asarray(xy, float))))


# --------------------------------------------------------------------------- routes


@dataclass(frozen=True, eq=False)
class MapRoute:
    """A route through a lanelet map and everything that follows from it (docs/map-format.md).

    Parameters
    ----------
    map : LaneletMap
    from_lanelet, to_lanelet : int
        The vehicle starts on the one and ends on the other.
    start_offset : float
        m along the route's centre line from ``from_lanelet``'s start.
    goal_offset : float, optional
        m along ``to_lanelet``'s centre line from its start, < 0 from its end; None: its end.
    lane_changes : bool
        Adjacent lanelets of the same direction may be used too.
    apron_lanelets : tuple of int
        Lanelets that ``apron_use`` allows.
    apron_use : {"trailer", "all", "none"}
    apron_gap : float
        m: a strip narrower than this between the corridor's lanelets and the apron lanelets is paved (a
        mountable curb, a gutter the map leaves out): the apron region is A | (close(C | A, g) - close(C, g)),
        close(P, g) = P buffered out by g/2 and back in (docs/map-format.md); 0: the lanelets alone.
    loops : int
        How many more times the route's centre line goes round the first cycle it meets (a roundabout's
        ring; ``looped``): the same corridor, the goal heading turned 2 pi further per loop. Not a
        scenario key: the map search's last resort (``model.search.maps``).

    Raises
    ------
    InputError
        ``route.<key>`` for a lanelet not in the map (or not drivable), no path, an offset off the route.
    """

    map: LaneletMap
    from_lanelet: int
    to_lanelet: int
    start_offset: float = 0.0
    goal_offset: float | None = None
    lane_changes: bool = False
    apron_lanelets: tuple[int, ...] = ()
    apron_use: str = "trailer"
    apron_gap: float = 0.0
    loops: int = 0

    def __post_init__(self) -> None:
        for key in ("from_lanelet", "to_lanelet"):
            lanelet_id = getattr(self, key)
            self._known(lanelet_id, f"route.{key}")
            if not self.map.drivable(lanelet_id):
                raise InputError(f"route.{key}", f"lanelet {lanelet_id} ({self.map.kind(lanelet_id)}) is not a lane "
                                 "a motor vehicle may drive on")  # fmt: skip
        for lanelet_id in self.apron_lanelets:
            self._known(lanelet_id, "route.apron_lanelets")
        if self.apron_use not in APRON_USE:
            raise InputError("route.apron_use", f"must be one of {', '.join(APRON_USE)}, got {self.apron_use!r}")
        if not (math.isfinite(self.apron_gap) and self.apron_gap >= 0.0):
            raise InputError("route.apron_gap", f"must be a finite width >= 0 m, got {self.apron_gap!r}")
        if not self.lanelets:
            how = "successors or adjacent same-direction lanelets" if self.lane_changes else "successors"
            flag = str(self.lane_changes).lower()
            raise InputError("route.to_lanelet", f"no path from lanelet {self.from_lanelet} to lanelet "
                             f"{self.to_lanelet} through {how} (lane_changes = {flag})")  # fmt: skip
        self._check_offsets()

    def _known(self, lanelet_id: Any, key: str) -> None:
        if isinstance(lanelet_id, bool) or not isinstance(lanelet_id, int) or lanelet_id not in self.map.ids:
            near = sorted(self.map.ids, key=lambda i: abs(i - lanelet_id) if isinstance(lanelet_id, int) else i)[:3]
            raise InputError(key, f"lanelet {lanelet_id!r} is not in the map {self.map.path.name} "
                             f"(ids {min(self.map.ids)} to {max(self.map.ids)}; nearest {near})")  # fmt: skip

    def _check_offsets(self) -> None:
        length = self.map.lengths[self.to_lanelet]
        if self.goal_offset is not None and not -length <= self.goal_offset <= length:
            raise InputError("route.goal_offset", f"{self.goal_offset:g} m lies beyond lanelet {self.to_lanelet}, "
                             f"whose centre line is {length:.2f} m long")  # fmt: skip
        if not 0.0 <= self.start_offset <= self.goal_s:
            raise InputError("route.start_offset", f"{self.start_offset:g} m lies outside the route before the "
                             f"goal (0 to {self.goal_s:.2f} m; the route's centre line: {self.line.length:.2f} m)")

    # -- the route ------------------------------------------------------------
    @cached_property
    def steps(self) -> list[tuple[int, str]]:
        """The route's lanelets, each with how it is entered ("start", "successor" or "lane change")."""
        path = shortest_path(self.map, self.from_lanelet, self.to_lanelet, lane_changes=False)
        if path is None and self.lane_changes:
            path = shortest_path(self.map, self.from_lanelet, self.to_lanelet, lane_changes=True)
        for _ in range(self.loops if path else 0):
            path = looped(self.map, path) or path  # no cycle on the way: the path as it is (``looped()``: None)
        return path or []

    def looped(self) -> MapRoute | None:
        """The same route going once more round the first cycle of successors it meets (None: none)."""
        route = dataclasses.replace(self, loops=self.loops + 1)
        return route if len(route.steps) > len(self.steps) else None

    @property
    def lanelets(self) -> list[int]:
        """The route's lanelet ids in driving order."""
        return [i for i, _ in self.steps]

    @cached_property
    def line(self) -> CentreLine:
        """The route's centre line from ``from_lanelet``'s start to ``to_lanelet``'s end.

        Each lanelet contributes its centre line; across a lane change the line leaves the first
        lanelet a quarter of the way along its centre line and joins the second three quarters of
        the way along its own (``LANE_CHANGE``): a straight ramp over half a lanelet's length.
        """
        parts, steps = [], self.steps
        for k, (lanelet_id, how) in enumerate(steps):
            cv = np.asarray(self.map.lanelet(lanelet_id).center_vertices, float)
            enter = LANE_CHANGE[1] if how == "lane change" else 0.0
            leave = LANE_CHANGE[0] if k + 1 < len(steps) and steps[k + 1][1] == "lane change" else 1.0
            if enter > leave:  # entered and left by lane changes: one point
                enter = leave = (enter + leave) / 2
            parts.append(sub_polyline(cv, enter, leave))
        return CentreLine(np.vstack(parts))

    @cached_property
    def goal_s(self) -> float:
        """Arclength of the goal point on the route's centre line, m."""
        cv = np.asarray(self.map.lanelet(self.to_lanelet).center_vertices, float)
        return float(self.line.project(CentreLine(cv).point(self.goal_along))[()])

    @property
    def goal_along(self) -> float:
        """The goal's arclength along ``to_lanelet``'s own centre line, m."""
        length = self.map.lengths[self.to_lanelet]
        if self.goal_offset is None:
            return length
        return self.goal_offset if self.goal_offset >= 0 else length + self.goal_offset

    def start(self) -> tuple[float, float, float]:
        """(x, y, heading) of the start: on the centre line at ``start_offset``, heading along it."""
        x, y = self.line.point(self.start_offset)
        return float(x), float(y), float(self.line.heading(self.start_offset))

    def goal(self) -> tuple[float, float, float]:
        """(x, y, heading) of the goal: on ``to_lanelet``'s centre line at the goal offset, heading along it.

        The heading is not wrapped: it is the start's heading plus the turn of the route's centre
        line from the start to the goal (its value says how far the vehicle turns, as for roundabouts).
        """
        own = CentreLine(np.asarray(self.map.lanelet(self.to_lanelet).center_vertices, float))
        x, y = own.point(self.goal_along)
        along = self.start()[2] + self.turn()
        heading = float(own.heading(self.goal_along))
        return float(x), float(y), heading + 2 * math.pi * round((along - heading) / (2 * math.pi))

    def turn(self) -> float:
        """How far the route's centre line turns from the start to the goal, rad (> 0 left)."""
        s = np.linspace(self.start_offset, self.goal_s, max(int((self.goal_s - self.start_offset) / 0.5), 2))
        return float(np.diff(np.unwrap(self.line.heading(s))).sum())

    # -- the corridor ---------------------------------------------------------
    @cached_property
    def corridor_lanelets(self) -> list[int]:
        """Every drivable lanelet on some legal path from ``from_lanelet`` to ``to_lanelet``, sorted."""
        forward = reachable(self.map, [self.from_lanelet], self.lane_changes, backward=False)
        backward = reachable(self.map, [self.to_lanelet], self.lane_changes, backward=True)
        return sorted(forward & backward)

    def apron_allowed(self, body: str) -> bool:
        """Whether ``body`` ("vehicle" or "trailer") may cover the apron lanelets under ``apron_use``."""
        if body not in BODIES:
            raise ValueError(f"body must be one of {BODIES}, got {body!r}")
        return self.apron_use == "all" or (self.apron_use == "trailer" and body == "trailer")

    @cached_property
    def lanes(self) -> shapely.Polygon | shapely.MultiPolygon:
        """The union of the corridor lanelets' polygons."""
        return union(self.map.polygon(i) for i in self.corridor_lanelets)

    @cached_property
    def with_apron(self) -> shapely.Polygon | shapely.MultiPolygon:
        """The corridor lanelets and the apron region: the apron lanelets, and with ``apron_gap`` the strips
        narrower than it that closing the corridor and the apron together fills and closing the corridor alone
        does not."""
        ids = sorted(set(self.corridor_lanelets) | set(self.apron_lanelets))
        both = union(self.map.polygon(i) for i in ids)
        if self.apron_gap <= 0.0 or not self.apron_lanelets:
            return both
        half = self.apron_gap / 2.0
        closed = both.buffer(half).buffer(-half)
        return both.union(closed.difference(self.lanes.buffer(half).buffer(-half)))

    def corridor(self, body: str) -> shapely.Polygon | shapely.MultiPolygon:
        """The area body ``"vehicle"`` or ``"trailer"`` may cover (shapely, the map's coordinates)."""
        return self.with_apron if self.apron_lanelets and self.apron_allowed(body) else self.lanes

    def lanelets_touching(self, geometry) -> list[int]:
        """Ids of the map's lanelets whose polygon intersects ``geometry`` (a shapely geometry), sorted."""
        return sorted(i for i in self.map.ids if self.map.polygon(i).intersects(geometry))


def sub_polyline(points: NDArray[np.float64], start: float, stop: float) -> NDArray[np.float64]:
    """The part of a polyline between the fractions ``start`` <= ``stop`` of its length."""
    line = CentreLine(points)
    a, b = start * line.length, stop * line.length
    inner = line.points[(line.s > a) & (line.s < b)]
    return np.vstack([line.point(a)[None], inner, line.point(b)[None]])


def looped(lanelet_map: LaneletMap, path: list[tuple[int, str]]) -> list[tuple[int, str]] | None:
    """``path`` with a loop inserted: after the first lanelet of ``path`` (not its first or last) from whose
    successors a path of successors leads back to it (shortest), that cycle once. None: no such lanelet."""
    for k, (lanelet_id, _) in enumerate(path[1:-1], 1):
        ahead = [j for j in lanelet_map.successors(lanelet_id) if lanelet_map.drivable(j)]
        back = [b for j in ahead if (b := shortest_path(lanelet_map, j, lanelet_id, lane_changes=False))]
        if back:
            cycle = min(back, key=lambda b: sum(lanelet_map.lengths[i] for i, _ in b))
            return [*path[: k + 1], *((i, "successor") for i, _ in cycle), *path[k + 1 :]]
    return None


def _edges(lanelet_map: LaneletMap, lanelet_id: int, lane_changes: bool) -> list[tuple[int, str, float]]:
    """Drivable neighbours of a lanelet: (id, "successor" | "lane change", cost from middle to middle, m)."""
    length = lanelet_map.lengths
    out = [(j, "successor", (length[lanelet_id] + length[j]) / 2) for j in lanelet_map.successors(lanelet_id)]
    if lane_changes:
        here = lanelet_map.lanelet(lanelet_id).center_vertices
        for j in lanelet_map.neighbours(lanelet_id):
            there = lanelet_map.lanelet(j).center_vertices
            mid_a, mid_b = CentreLine(here).point(length[lanelet_id] / 2), CentreLine(there).point(length[j] / 2)
            out.append((j, "lane change", float(np.hypot(*(mid_b - mid_a)))))
    return [e for e in out if lanelet_map.drivable(e[0])]


def shortest_path(lanelet_map: LaneletMap, start: int, goal: int, lane_changes: bool) -> list[tuple[int, str]] | None:
    """Dijkstra from the middle of ``start`` to the middle of ``goal``: the lanelets and how each is entered.

    Through successors the cost is centre-line length; a lane change costs the distance between the
    middles of the two lanelets. None if ``goal`` cannot be reached.
    """
    best: dict[int, float] = {start: 0.0}
    came: dict[int, tuple[int, str] | None] = {start: None}
    queue = [(0.0, start)]
    while queue:
        cost, node = heapq.heappop(queue)
        if node == goal:
            break
        if cost > best[node]:
            continue
        for nxt, how, step in _edges(lanelet_map, node, lane_changes):
            if cost + step < best.get(nxt, math.inf):
                best[nxt], came[nxt] = cost + step, (node, how)
                heapq.heappush(queue, (cost + step, nxt))
    if goal not in came:
        return None
    path, node, how = [], goal, None
    while came[node] is not None:
        prev, how = came[node]
        path.append((node, how))
        node = prev
    return [(start, "start"), *reversed(path)]


def reachable(lanelet_map: LaneletMap, seeds: list[int], lane_changes: bool, backward: bool) -> set[int]:
    """Drivable lanelets reachable from ``seeds`` (following successors, or predecessors if ``backward``)."""
    ahead: dict[int, list[int]] = {i: [e[0] for e in _edges(lanelet_map, i, lane_changes)] for i in lanelet_map.ids}
    if backward:
        behind: dict[int, list[int]] = {i: [] for i in lanelet_map.ids}
        for i, nexts in ahead.items():
            for j in nexts:
                behind[j].append(i)
        ahead = behind
    seen, stack = set(seeds), list(seeds)
    while stack:
        for j in ahead[stack.pop()]:
            if j not in seen and lanelet_map.drivable(j):
                seen.add(j)
                stack.append(j)
    return seen
