"""The truck's announcement for a cooperative roundabout: when its bodies occupy each conflict area.

The ring roadway (between its inner edge and the outer curb) is divided into one conflict area per
leg (``conflict_areas``): the annular sector around the leg's axis, bounded by the bisectors
between the leg's axis and its neighbours' (the legs' junctions, where entering, circulating and
leaving vehicles meet, cover the ring). The truck's window in an area (``occupancy_windows``) is an
interval of plan time in which one of its bodies overlaps the area: the bodies are the exact
rectangles of the plan's states, sampled every ``step`` seconds of plan time, and each window is
widened by one step on either side so that the motion between two samples is inside it. A
connected vehicle told these windows (with the driver's progress turning plan time into clock
time) keeps out of an area while the truck is in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from model.analysis.bodies import body_corners
from model.problem.ocp import OCP
from model.scene.roundabout import Roundabout

ARC_POINTS_PER_RADIAN = 32  # the sectors' arcs as polygons: 0.5 mm of sagitta at R = 20 m


@dataclass(frozen=True)
class ConflictArea:
    """The part of the ring roadway around one leg: the sector from angle ``start`` to ``end`` (rad, ccw)."""

    leg: int
    start: float
    end: float
    polygon: shapely.Polygon


@dataclass(frozen=True)
class Window:
    """Plan times ``start`` to ``end`` (s) in which the truck's bodies overlap leg ``leg``'s conflict area."""

    leg: int
    start: float
    end: float


def _sector(center: np.ndarray, r_in: float, r_out: float, start: float, end: float) -> shapely.Polygon:
    """The annular sector between radii ``r_in`` and ``r_out`` from angle ``start`` counter-clockwise to ``end``."""
    count = max(2, math.ceil((end - start) * ARC_POINTS_PER_RADIAN) + 1)
    a = np.linspace(start, end, count)
    ring = np.column_stack([np.cos(a), np.sin(a)])
    return shapely.Polygon(np.vstack([center + r_out * ring, center + r_in * ring[::-1]]))


def conflict_areas(roundabout: Roundabout) -> list[ConflictArea]:
    """One conflict area per leg, in the order of the legs; together they cover the ring roadway.

    Parameters
    ----------
    roundabout : Roundabout
        Its legs' axes bound the areas (the bisectors between neighbouring axes).

    Returns
    -------
    list of ConflictArea
        Leg ``i``'s area is the ring roadway's sector from the bisector with the previous leg
        (counter-clockwise order) to the bisector with the next; a single leg's area is the whole ring.
    """
    legs = roundabout.legs
    angles = [leg.angle % (2 * math.pi) for leg in legs]
    order = sorted(range(len(legs)), key=lambda i: angles[i])
    center = np.asarray(roundabout.center, float)
    areas = {}
    for k, i in enumerate(order):
        before, after = angles[order[k - 1]], angles[order[(k + 1) % len(order)]]
        gap_before = (angles[i] - before) % (2 * math.pi) or 2 * math.pi
        gap_after = (after - angles[i]) % (2 * math.pi) or 2 * math.pi
        start, end = angles[i] - gap_before / 2, angles[i] + gap_after / 2
        if len(legs) == 1:
            start, end = angles[i] - math.pi, angles[i] + math.pi
        polygon = _sector(center, roundabout.inner_radius, roundabout.outer_radius, start, end)
        areas[i] = ConflictArea(i, start, end, polygon)
    return [areas[i] for i in range(len(legs))]


def occupancy_windows(ocp: OCP, plan_at, duration: float, step: float, grow: float = 0.0) -> list[Window]:
    """The plan-time windows in which the truck's exact rectangles overlap each conflict area.

    Parameters
    ----------
    ocp : OCP
        The truck's problem on a roundabout road (its bodies and its roundabout).
    plan_at : callable
        Plan time(s) -> dict of state columns (``Plan.at`` of the autopilot).
    duration : float
        The plan's final time Tf, s.
    step : float
        The sampling step of plan time, s (the co-simulation's step).
    grow : float
        Metres by which the rectangles are grown (``shapely.buffer``) before they are intersected.

    Returns
    -------
    list of Window
        Sorted by start; each maximal run of samples with an overlap, widened by ``step`` on either
        side and clipped to [0, ``duration``].
    """
    s = np.append(np.arange(0.0, duration, step), duration)
    states = plan_at(s)
    rectangles = [shapely.buffer(shapely.polygons(c), grow) if grow else shapely.polygons(c)
                  for c in body_corners(ocp, states).values()]  # fmt: skip
    windows = []
    for area in conflict_areas(ocp.road.roundabout):
        inside = np.any([shapely.intersects(r, area.polygon) for r in rectangles], axis=0)
        windows += [Window(area.leg, max(0.0, s[a] - step), min(duration, s[b - 1] + step)) for a, b in _runs(inside)]
    return sorted(windows, key=lambda w: (w.start, w.leg))


def footprint(ocp: OCP, plan_at, duration: float, step: float, grow: float = 0.0) -> shapely.Geometry:
    """The ground the truck's exact rectangles cover along its plan, grown by ``grow`` metres.

    Parameters
    ----------
    ocp : OCP
        The truck's problem (its bodies).
    plan_at : callable
        Plan time(s) -> dict of state columns.
    duration : float
        The plan's final time, s.
    step : float
        The sampling step of plan time, s.
    grow : float
        Metres by which each rectangle is grown (``shapely.buffer``).

    Returns
    -------
    shapely.Geometry
        The union of every body's rectangle at every sample (plan times 0, step, ..., ``duration``).
    """
    s = np.append(np.arange(0.0, duration, step), duration)
    rectangles = [shapely.polygons(c) for c in body_corners(ocp, plan_at(s)).values()]
    return shapely.union_all([shapely.buffer(r, grow) if grow else r for r in rectangles])


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """The maximal runs [a, b) of True in ``flags``."""
    edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def progress_time(ahead: float, rate: float, slope: float) -> float:
    """Seconds the truck needs for ``ahead`` seconds of plan time from its actual progress.

    Parameters
    ----------
    ahead : float
        Plan seconds still to go (<= 0: none).
    rate : float
        The truck's progress rate now (plan seconds per second, in [0, 1]).
    slope : float
        How fast the rate can rise, 1/s (``Autopilot.rate_slope``); inf: at the plan's pace at once.

    Returns
    -------
    float
        The time to cover ``ahead`` with the rate rising from ``rate`` at ``slope`` to 1 (the plan's pace)
        and staying there: the earliest the truck can get there from where it is.
    """
    if ahead <= 0.0:
        return 0.0
    rate = min(max(rate, 0.0), 1.0)
    if not math.isfinite(slope) or rate >= 1.0:
        return ahead / max(rate, 1.0)
    ramp = (1.0 - rate) / slope  # seconds to reach the plan's pace
    covered = rate * ramp + 0.5 * slope * ramp**2
    if ahead >= covered:
        return ramp + (ahead - covered)
    return (-rate + math.sqrt(rate * rate + 2.0 * slope * ahead)) / slope


def clock_windows(windows: list[Window], now: float, s: float, rate: float = 1.0,
                  slope: float = math.inf) -> list[Window]:  # fmt: skip
    """The plan-time ``windows`` still ahead of plan time ``s`` in clock time, from the truck's actual progress.

    Parameters
    ----------
    windows : list of Window
        Plan-time windows (``occupancy_windows``).
    now : float
        Clock time, s.
    s : float
        The truck's plan time now (where it is along its plan).
    rate, slope : float
        Its progress rate now and how fast that can rise (``progress_time``); the defaults announce at
        the plan's pace from ``s`` on.

    Returns
    -------
    list of Window
        Each window whose end is ahead of ``s``: [now + progress_time(start - s), now + progress_time(end - s)].
    """
    return [Window(w.leg, now + progress_time(w.start - s, rate, slope), now + progress_time(w.end - s, rate, slope))
            for w in windows if w.end > s]  # fmt: skip
