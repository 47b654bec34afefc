"""Gap acceptance at a roundabout's entries, measured from a run's files, and the traffic-engineering formulas.

A run's ``traffic.csv`` gives every other vehicle's centre at every step; the conflicting stream at
an entry is the sequence of times at which circulating vehicles cross its *conflict line*: the ray
from the centre along the leg's axis, between the ring roadway's inner and outer edges, crossed in the
circulation direction (``passages``). The truck's ``trajectory.csv`` gives its entry time (its front
bumper crosses the outer curb, ``entry_times``), the time it came within ``approach`` of the curb
(its arrival), and the time the rear of its last body crosses the curb (the entry cleared); SUMO's
vehicles' entries at their own legs come from their rows the same way (``other_entries``; in a queue
a driver is at the line once the vehicle ahead entered). The gaps a driver was offered (``offer``):
from its arrival, the lag to the next passage, then the stream's headways; the one containing its
entry is *accepted*, every earlier one *rejected*.

Estimators and formulas (q the conflicting flow in vehicles per second, t_c the critical gap, t_f
the follow-up time):

- Raff's critical gap (Raff & Hart 1950): the t at which the number of accepted gaps shorter than t
  equals the number of rejected gaps longer than t (``raff_critical_gap``; its standard error by
  resampling the drivers, ``raff_spread``);
- Troutbeck's maximum-likelihood critical gap (Troutbeck 1992): each consistent driver's critical
  gap lies between its longest rejected gap and its accepted one, the drivers' critical gaps
  log-normal (``mle_critical_gap``: the mean, its standard error, the drivers' spread);
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
from scipy import optimize, special

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


def passages(scenario: Scenario, traffic: Mapping[str, np.ndarray], leg: int | None = None) -> np.ndarray:
    """Sorted times at which vehicles cross the conflict line of an entry (the truck's by default).

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (its roundabout and route).
    traffic : mapping of str to numpy.ndarray
        The columns of ``traffic.csv`` (``t``, ``id``, ``x``, ``y``, ...): vehicle centres.
    leg : int, optional
        The entry's leg; default the truck's (``route.enter``).

    Returns
    -------
    numpy.ndarray
        Crossing times (s), linear between the steps.
    """
    ra = scenario.ocp.road.roundabout
    axis = ra.legs[scenario.ocp.road.route.enter if leg is None else leg].angle
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


@dataclass(frozen=True)
class Offer:
    """The gaps one driver was offered at an entry: the accepted one and those rejected before it (s).

    ``censored``: no vehicle passed after the entry before the run ended, so ``accepted`` is only a
    lower bound (the estimators leave such an offer out).
    """

    accepted: float
    rejected: tuple[float, ...]
    censored: bool

    @property
    def largest_rejected(self) -> float:
        """The longest rejected gap (0 without any): what a consistent driver's critical gap exceeds."""
        return max(self.rejected, default=0.0)


def offer(times: np.ndarray, arrival: float, entry: float, end: float) -> Offer:
    """The gaps offered to a driver at the line from ``arrival`` until it entered at ``entry``.

    The offered intervals start at the arrival: the first is the *lag* (arrival to the next passage),
    then the stream's headways. The one containing the entry is accepted, every earlier one rejected.

    Parameters
    ----------
    times : numpy.ndarray
        The entry's conflicting passages (``passages``), s.
    arrival, entry : float
        When the driver was first at the line (and the first of its queue) and when it entered, s.
    end : float
        The last time the run recorded: with no passage after the entry the accepted gap runs to
        ``end`` and is censored (a lower bound).

    Returns
    -------
    Offer

    Examples
    --------
    >>> offer(np.array([5.0, 11.0, 14.0, 18.0, 27.0]), 10.0, 20.0, 30.0)
    Offer(accepted=9.0, rejected=(1.0, 3.0, 4.0), censored=False)
    """
    times = np.asarray(times, float)
    waited = times[(times > arrival) & (times <= entry)]
    starts = np.concatenate([[arrival], waited])
    after = times[times > entry]
    stop = float(after[0]) if len(after) else float(end)
    return Offer(stop - float(starts[-1]), tuple(float(g) for g in np.diff(starts)), not len(after))


def offered_gaps(times: np.ndarray, entry: Entry, end: float) -> tuple[float, list[float]]:
    """The truck's accepted gap and rejected ones (``offer`` at its arrival and entry)."""
    got = offer(times, entry.arrival, entry.entry, end)
    return got.accepted, list(got.rejected)


def other_entries(scenario: Scenario, traffic: Mapping[str, np.ndarray], approach: float = APPROACH) -> list[dict]:
    """Every other vehicle's entry into the ring from its leg, from ``traffic.csv``.

    A vehicle enters when its front bumper (centre + length / 2 along its heading) crosses the outer
    curb from outside; its leg is the one whose axis is nearest to that point. It is *at the line*
    from when its front comes within ``approach`` of the curb or, if later, when the vehicle ahead of
    it from the same leg entered (before, it could not take a gap): the driver's ``arrival``. It is
    ``queued`` if it came within ``approach`` before the vehicle ahead entered (a follow-up entry).

    Returns
    -------
    list of dict
        ``id``, ``leg``, ``arrival``, ``entry``, ``queued``, sorted by leg and entry time.
    """
    ra = scenario.ocp.road.roundabout
    t, ids = np.asarray(traffic["t"], float), np.asarray(traffic["id"])
    heading, half = np.asarray(traffic["heading"], float), np.asarray(traffic["length"], float) / 2
    fx = np.asarray(traffic["x"], float) + half * np.cos(heading) - ra.center[0]  # names: traffic.csv columns
    fy = np.asarray(traffic["y"], float) + half * np.sin(heading) - ra.center[1]  # names: traffic.csv columns
    radius, angle = np.hypot(fx, fy), np.arctan2(fy, fx)
    axes = np.array([leg.angle for leg in ra.legs])
    found = []
    order = np.lexsort((t, ids))
    for vid in np.unique(ids):
        k = order[ids[order] == vid]
        inside = np.flatnonzero(radius[k] <= ra.outer_radius)
        if not len(inside) or inside[0] == 0:
            continue  # never entered, or already in at its first row
        i = int(inside[0])
        near = np.flatnonzero(radius[k][: i + 1] <= ra.outer_radius + approach)
        leg = int(np.argmin(np.abs(_wrap(angle[k][i] - axes))))
        found.append({"id": str(vid), "leg": leg, "near": float(t[k][near[0]]), "entry": float(t[k][i])})
    out = []
    for leg in sorted({f["leg"] for f in found}):
        ahead = -math.inf
        for f in sorted((f for f in found if f["leg"] == leg), key=lambda f: f["entry"]):
            out.append({"id": f["id"], "leg": leg, "arrival": max(f["near"], ahead), "entry": f["entry"],
                        "queued": f["near"] < ahead})  # fmt: skip
            ahead = f["entry"]
    return out


def follow_up_headways(entries: Sequence[Mapping], times: np.ndarray) -> list[float]:
    """Entry headways of queued vehicles that took the same gap as the vehicle ahead (s).

    ``entries``: one leg's ``other_entries`` in entry order; ``times``: that entry's passages. A
    headway counts when the follower was ``queued`` and no vehicle passed between the two entries.
    """
    times = np.asarray(times, float)
    out = []
    for lead, follow in zip(entries[:-1], entries[1:], strict=True):
        if follow["queued"] and not np.any((times > lead["entry"]) & (times < follow["entry"])):
            out.append(follow["entry"] - lead["entry"])
    return out


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
    diff = (np.searchsorted(acc, grid, "left") - (len(rej) - np.searchsorted(rej, grid, "right"))).astype(float)
    i = int(np.flatnonzero(diff >= 0)[0])
    if i == 0 or diff[i] == 0:
        return float(grid[i])
    return float(grid[i - 1] + (grid[i] - grid[i - 1]) * (-diff[i - 1]) / (diff[i] - diff[i - 1]))


def _lognormal_loglik(params: np.ndarray, log_a: np.ndarray, log_r: np.ndarray) -> float:
    mu, sigma = params[0], math.exp(params[1])
    upper = special.ndtr((log_a - mu) / sigma)
    lower = special.ndtr((log_r - mu) / sigma)  # log 0 = -inf: ndtr(-inf) = 0
    return float(np.sum(np.log(np.maximum(upper - lower, 1e-300))))


def _hessian(f, x: np.ndarray, h: float = 1e-4) -> np.ndarray:
    n = len(x)
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            ei, ej = np.eye(n)[i] * h, np.eye(n)[j] * h
            out[i, j] = (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4 * h * h)
    return out


def mle_critical_gap(accepted: Sequence[float], largest_rejected: Sequence[float]) -> dict | None:
    """Troutbeck's maximum-likelihood critical gap: the drivers' critical gaps log-normal.

    Driver i, consistent, accepted gap a_i and rejected none longer than r_i (0 if it rejected none):
    its critical gap lies in (r_i, a_i]; the log-likelihood is sum log(F(a_i) - F(r_i)) with F the
    log-normal distribution function of (mu, sigma) (Troutbeck 1992). Drivers with a_i <= r_i
    (inconsistent) are left out and counted.

    Parameters
    ----------
    accepted, largest_rejected : sequence of float
        Per driver, the accepted gap and the longest rejected one (0 without any), s.

    Returns
    -------
    dict or None
        ``mean`` (s, exp(mu + sigma^2 / 2), the estimate), ``se`` (s, its standard error from the
        likelihood's Hessian by the delta method; None if the Hessian is not positive definite),
        ``sd`` (s, the spread of the drivers' critical gaps), ``mu``, ``sigma``, ``drivers`` (used),
        ``inconsistent``; None without a driver who rejected a gap (the likelihood has no maximum).
    """
    a, r = np.asarray(accepted, float), np.asarray(largest_rejected, float)
    keep = a > r
    a, r = a[keep], r[keep]
    if not np.any(r > 0):
        return None
    log_a = np.log(a)
    with np.errstate(divide="ignore"):
        log_r = np.log(r)

    def nll(p: np.ndarray) -> float:
        return -_lognormal_loglik(p, log_a, log_r)

    start = np.array([math.log(raff_critical_gap(a, r[r > 0]) or float(np.median(a))), math.log(0.3)])
    res = optimize.minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-8, "fatol": 1e-10,
                                                                          "maxiter": 4000})  # fmt: skip
    mu, log_s = res.x
    sigma = math.exp(log_s)
    mean = math.exp(mu + sigma**2 / 2)
    se = None
    try:
        cov = np.linalg.inv(_hessian(nll, res.x))
        grad = np.array([mean, mean * sigma**2])  # d mean / d (mu, log sigma)
        var = float(grad @ cov @ grad)
        se = math.sqrt(var) if var > 0 and np.all(np.linalg.eigvalsh(cov) > 0) else None
    except np.linalg.LinAlgError:
        pass
    return {"mean": mean, "se": se, "sd": mean * math.sqrt(math.expm1(sigma**2)), "mu": float(mu), "sigma": sigma,
            "drivers": int(len(a)), "inconsistent": int(np.sum(~keep))}  # fmt: skip


def raff_spread(accepted: Sequence[float], rejected_by_driver: Sequence[Sequence[float]], draws: int = 200,
                seed: int = 0) -> float | None:  # fmt: skip
    """The standard error of Raff's critical gap: the drivers resampled with replacement ``draws`` times (s).

    None with fewer than two drivers or when no resample has an estimate.
    """
    n = len(accepted)
    if n < 2:
        return None
    rng = np.random.default_rng(seed)
    got = []
    for _ in range(draws):
        pick = rng.integers(0, n, n)
        rej = [g for i in pick for g in rejected_by_driver[i]]
        if rej:
            got.append(raff_critical_gap([accepted[i] for i in pick], rej))
    return float(np.std(got, ddof=1)) if len(got) > 1 else None


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


__all__ = ["APPROACH", "HCM_CRITICAL_GAP", "HCM_FOLLOW_UP", "PCE_HEAVY", "Entry", "Offer", "adams_delay", "entry_times",
           "follow_up_headways", "gap_capacity", "hcm_capacity", "mle_critical_gap", "offer", "offered_gaps",
           "other_entries", "passages", "raff_critical_gap", "raff_spread"]  # fmt: skip
