"""Gap acceptance at the truck's entry, measured from a run's files, and the traffic-engineering formulas.

A run's ``traffic.csv`` gives every other vehicle's centre at every step; the conflicting stream at
the truck's entry is the sequence of times at which circulating vehicles cross the *conflict line*:
the ray from the centre along the entry leg's axis, between the ring roadway's inner and outer edges,
crossed in the circulation direction (``passages``). The truck's ``trajectory.csv`` gives its entry
time (its front bumper crosses the outer curb, ``entry_times``), the time it came within
``approach`` of the curb (its arrival), and the time the rear of its last body crosses the curb (the
entry cleared). The gaps it was offered (``offered_gaps``): the headway of the stream that contains
its entry time is *accepted*; every complete headway between its arrival and its entry is *rejected*.

Formulas (q the conflicting flow in vehicles per second, t_c the critical gap, t_f the follow-up time):

- Raff's critical gap (Raff & Hart 1950): the t at which the number of accepted gaps shorter than t
  equals the number of rejected gaps longer than t (``raff_critical_gap``);
- Adams' delay (Adams 1936), the mean wait of a vehicle arriving at random at a random (Poisson)
  stream with gap acceptance t_c: E[W] = (exp(q t_c) - 1 - q t_c) / q (``adams_delay``);
- the entry capacity of a gap-accepting stream on a Poisson conflicting stream, Siegloch's form
  (Siegloch 1973): c = exp(-q (t_c - t_f / 2)) / t_f (``gap_capacity``), the form the HCM's is
  fitted in;
- the HCM 6th edition single-lane roundabout entry capacity c = 1380 exp(-1.02e-3 v_c), both in
  passenger cars per hour (``hcm_capacity``): Siegloch's with t_f = 3600 / 1380 = 2.61 s and
  t_c = 2.61 / 2 + 3.67 = 4.98 s (``HCM_CRITICAL_GAP``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from model.analysis.bodies import body_corners
from model.problem.scenario import Scenario

APPROACH = 10.0  # m before the outer curb from which the truck is "at the line" and judges the gaps
HCM_BASE, HCM_SLOPE = 1380.0, 1.02e-3  # HCM 6th ed., Exhibit 22-12: single-lane entry, one conflicting lane
HCM_FOLLOW_UP = 3600.0 / HCM_BASE  # s: the t_f and t_c of Siegloch's form that the HCM's formula is
HCM_CRITICAL_GAP = HCM_FOLLOW_UP / 2 + 3600.0 * HCM_SLOPE  # s: 4.98
CENTRE_COLUMNS = ("x", "y")  # names: traffic.csv's columns of another vehicle's centre (the contract's)
PCE_HEAVY = 2.0  # passenger car equivalents of a heavy vehicle (HCM 6th ed., Exhibit 22-11)


@dataclass(frozen=True)
class Entry:
    """The truck's entry in one run: arrival at the line, entry, entry cleared (s of simulation time)."""

    arrival: float
    entry: float
    cleared: float

    @property
    def occupancy(self) -> float:
        """Seconds from the front bumper crossing the outer curb to the last body's rear crossing it."""
        return self.cleared - self.entry


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + math.pi) % (2 * math.pi) - math.pi


def passages(scenario: Scenario, traffic: Mapping[str, np.ndarray]) -> np.ndarray:
    """Sorted times at which other vehicles cross the conflict line of the truck's entry.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (its roundabout and route).
    traffic : mapping of str to numpy.ndarray
        The columns of ``traffic.csv`` (``t``, ``id``, ``x``, ``y``, ...).

    Returns
    -------
    numpy.ndarray
        Crossing times (s), linear between the steps.
    """
    ra = scenario.ocp.road.roundabout
    axis = ra.legs[scenario.ocp.road.route.enter].angle
    t, ids = np.asarray(traffic["t"], float), np.asarray(traffic["id"])
    cx, cy = (np.asarray(traffic[c], float) for c in CENTRE_COLUMNS)
    dx, dy = cx - ra.center[0], cy - ra.center[1]
    ahead = ra.circulation * _wrap(np.arctan2(dy, dx) - axis)  # > 0 once past the line
    on_ring = (np.hypot(dx, dy) >= ra.inner_radius) & (np.hypot(dx, dy) <= ra.outer_radius)
    out = []
    order = np.lexsort((t, ids))
    for vid in np.unique(ids):
        k = order[ids[order] == vid]
        a, ring, tt = ahead[k], on_ring[k], t[k]
        cross = np.flatnonzero((a[:-1] <= 0) & (a[1:] > 0) & (a[1:] - a[:-1] < 1.0) & (ring[:-1] | ring[1:]))
        for i in cross:
            out.append(tt[i] + (tt[i + 1] - tt[i]) * (-a[i]) / (a[i + 1] - a[i]))
    return np.sort(np.array(out, float))


def entry_times(scenario: Scenario, columns: Mapping[str, np.ndarray], approach: float = APPROACH) -> Entry | None:
    """The truck's arrival within ``approach`` of the outer curb, its entry and its entry cleared.

    None if the front bumper never crossed the outer curb. The front bumper is the middle of the
    first body's front edge, the rear the middle of the last body's rear edge (exact rectangles).
    """
    ocp = scenario.ocp
    ra = ocp.road.roundabout
    corners = body_corners(ocp, {s: np.asarray(columns[s], float) for s in ocp.vehicle.states})
    first, last = corners[next(iter(corners))], corners[list(corners)[-1]]
    t = np.asarray(columns["t"], float)

    def radius(p: np.ndarray) -> np.ndarray:
        return np.hypot(p[:, 0] - ra.center[0], p[:, 1] - ra.center[1])

    front = radius((first[:, 1] + first[:, 2]) / 2)
    rear = radius((last[:, 0] + last[:, 3]) / 2)
    inside = np.flatnonzero(front <= ra.outer_radius)
    if not len(inside):
        return None
    k = int(inside[0])
    near = np.flatnonzero(front[: k + 1] <= ra.outer_radius + approach)
    cleared = np.flatnonzero(rear[k:] <= ra.outer_radius)
    return Entry(float(t[near[0]]), float(t[k]), float(t[k + int(cleared[0])]) if len(cleared) else math.nan)


def offered_gaps(times: np.ndarray, entry: Entry, end: float) -> tuple[float | None, list[float]]:
    """The accepted gap and the rejected ones at the truck's entry.

    Parameters
    ----------
    times : numpy.ndarray
        The stream's passages (``passages``), s.
    entry : Entry
        The truck's arrival and entry.
    end : float
        The last time the run recorded: with no passage after the entry the accepted gap is taken
        as ``end`` minus the last passage before it (a lower bound: the run ends at the arrival).

    Returns
    -------
    tuple
        The accepted gap (the stream's headway containing the entry; None if no vehicle passed
        before the entry) and the rejected ones (complete headways between the arrival and the entry).
    """
    times = np.asarray(times, float)
    before, after = times[times <= entry.entry], times[times > entry.entry]
    accepted = float((after[0] if len(after) else end) - before[-1]) if len(before) else None
    waited = times[(times >= entry.arrival) & (times <= entry.entry)]
    return accepted, [float(b - a) for a, b in zip(waited[:-1], waited[1:], strict=True)]


def raff_critical_gap(accepted: Sequence[float], rejected: Sequence[float]) -> float | None:
    """Raff's critical gap: where #accepted shorter than t equals #rejected longer than t.

    Parameters
    ----------
    accepted, rejected : sequence of float
        Accepted and rejected gaps, s.

    Returns
    -------
    float or None
        The crossing, linear between the gaps' values; None without any accepted gap. With no
        rejected gap it is the shortest accepted one (an upper bound of the critical gap).

    Examples
    --------
    >>> raff_critical_gap([4.0, 5.0, 6.0], [1.0, 2.0, 3.0, 4.5])
    4.25
    """
    acc, rej = np.sort(np.asarray(accepted, float)), np.sort(np.asarray(rejected, float))
    if not len(acc):
        return None
    grid = np.unique(np.concatenate([acc, rej]))
    diff = np.array([np.sum(acc < g) - np.sum(rej > g) for g in grid], float)
    up = np.flatnonzero(diff >= 0)
    i = int(up[0])
    if i == 0 or diff[i] == 0:
        return float(grid[i])
    return float(grid[i - 1] + (grid[i] - grid[i - 1]) * (-diff[i - 1]) / (diff[i] - diff[i - 1]))


def adams_delay(q: float, tc: float) -> float:
    """Adams' mean wait (s) for a random arrival at a Poisson stream of ``q`` veh/s, critical gap ``tc`` s."""
    if q <= 0:
        return 0.0
    return (math.exp(q * tc) - 1 - q * tc) / q


def gap_capacity(q: float, tc: float, tf: float) -> float:
    """Siegloch's entry capacity (veh/s) on a Poisson stream of ``q`` veh/s: exp(-q (tc - tf / 2)) / tf."""
    return math.exp(-max(q, 0.0) * (tc - tf / 2)) / tf


def hcm_capacity(vc: float) -> float:
    """HCM 6th edition single-lane entry capacity (pc/h) against a conflicting flow ``vc`` (pc/h)."""
    return HCM_BASE * math.exp(-HCM_SLOPE * vc)


__all__ = ["APPROACH", "HCM_CRITICAL_GAP", "HCM_FOLLOW_UP", "PCE_HEAVY", "Entry", "adams_delay", "entry_times",
           "gap_capacity", "hcm_capacity", "offered_gaps", "passages", "raff_critical_gap"]  # fmt: skip
