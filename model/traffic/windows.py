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


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """The maximal runs [a, b) of True in ``flags``."""
    edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))
