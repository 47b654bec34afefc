"""Named vehicle presets as data, each number with its source (SI units, radians).

A preset is what a scenario's ``[vehicle]`` table (with ``[vehicle.body]`` and
``[vehicle.trailer_body]``) and part of its ``[bounds]`` would hold:

- ``model``, ``wheelbase`` and, for ``"tractor-trailer"``, ``hitch_offset`` and ``trailer_wheelbase``;
- ``body`` and (articulated) ``trailer_body``: ``length``, ``width``, ``rear_overhang``;
- ``bounds``: only what the source gives (``phi``, ``u2`` the steering rate, ``u1`` the speed);
- ``source``: the reference; ``derived``: keys computed from its numbers; ``assumed``: keys it
  does not give, chosen here as typical values (``notes`` says how).

Sources
-------
AASHTO: A Policy on Geometric Design of Highways and Streets, 7th ed. (2018), "Design Vehicle
    Dimensions" (U.S. customary, Table 2-1a) and "Minimum Turning Radii of Design Vehicles"
    (Table 2-2a). Converted from feet with 1 ft = 0.3048 m. The steering limit is derived from
    the centerline turning radius CTR (path of the front axle centre at full lock) as
    phi_max = asin(WB1 / CTR); this reproduces the templates' 31.6 deg (P) and 28.4 deg (WB-62).
    Checked against secondary sources: overall length, width and overhangs of SU-30, WB-40, WB-62,
    WB-67 (a course page citing the 2018 edition, which numbers the table 2-4a); P and SU-30
    dimensions (2001 metric table, unchanged since); P's 14.4 ft and SU-30's 28 ft 4 in minimum
    inside radius (reproduced from CTR by tests/test_vehicles.py). Not confirmed: WB2 of WB-40
    (25.5, from the row's closure), WB1/WB2 of WB-62 (19.5/41.0) and WB-67 (19.5/45.5), and the
    CTR of WB-40 (36), WB-62 and WB-67 (41); WB-62's 19.5/41 agree with its 28.4 deg template.
EU: Council Directive 96/53/EC, Annex I, 1.1 (16.50 m articulated vehicle), 1.2 (2.55 m),
    1.5 (turning ring 12.50 m / 5.30 m), 1.6 (kingpin to rear of the semi-trailer <= 12.00 m,
    kingpin to any point of its front <= 2.04 m).
CommonRoad: Vehicle Models of the CommonRoad benchmarks (M. Althoff et al.), vehicle ID 4
    "semi-trailer truck", ``parameters_vehicle4`` of commonroad-vehicle-models (KST model, on-axle
    trailer); body placement as CommonRoad draws it: tractor front at l_total - l_hitch ahead of
    the hitch (= rear axle), trailer rear at l_hitch behind the hitch.

Operational limits
------------------
``operational_limits(name)`` gives each preset's ``OperationalLimits`` (docs/dynamics-format.md,
"Operational limits of the design vehicles"): longitudinal acceleration and comfortable braking,
jerk, the bound of the speed v, the steering rate, the static rollover threshold, the lateral
acceleration a designer allows and a crawl speed for design turns; ``sources`` names, per field,
the reference or "assumed: <reason>". The bound of v is the vehicle's top speed on the road class
these presets are used on, an urban road with a roundabout: 50 km/h for every preset (assumed, see
``URBAN_SPEED``), below each vehicle's own top speed; on the ring the lateral-acceleration bound,
not this one, limits v.
"""

from __future__ import annotations

import copy
import difflib
import math
from dataclasses import dataclass, field
from typing import Any

from model.errors import InputError

FT = 0.3048  # m per international foot

AASHTO = "AASHTO, A Policy on Geometric Design of Highways and Streets, 7th ed. (2018), Tables 2-1a and 2-2a"
EU = "Council Directive 96/53/EC, Annex I (maximum authorised dimensions), 16.50 m articulated vehicle"
COMMONROAD = "CommonRoad vehicle models, vehicle ID 4 (semi-trailer truck), parameters_vehicle4"


def _m(feet: float) -> float:
    return round(feet * FT, 6)


def _rect(length: float, width: float, rear_overhang: float) -> dict[str, float]:
    return {"length": length, "width": width, "rear_overhang": rear_overhang}


def _steer(wheelbase_ft: float, ctr_ft: float) -> tuple[float, float]:
    """AASHTO full lock: the front axle centre runs on the CTR circle, so sin(phi_max) = WB1 / CTR."""
    a = math.asin(wheelbase_ft / ctr_ft)
    return (-a, a)


def _aashto_truck(length: float, width: float, front: float, rear: float, wb: float, ctr: float) -> dict[str, Any]:
    """A single-unit AASHTO design vehicle from its Table 2-1a row (ft) and Table 2-2a CTR (ft)."""
    return {
        "model": "truck",
        "wheelbase": _m(wb),
        "body": _rect(_m(length), _m(width), _m(rear)),
        "bounds": {"phi": _steer(wb, ctr)},
        "source": AASHTO,
        "derived": ("bounds.phi",),
        "assumed": (),
        "notes": f"ft: L={length} W={width} front={front} rear={rear} WB={wb} CTR={ctr}; "
        "phi_max = asin(WB / CTR) is derived, not tabulated.",
    }


def _aashto_semi(
    length: float,
    width: float,
    front: float,
    rear: float,
    wb1: float,
    wb2: float,
    ctr: float,
    trailer: float,
    trailer_assumed: bool = False,
) -> dict[str, Any]:
    """An AASHTO tractor-semitrailer from its Table 2-1a row (ft), Table 2-2a CTR (ft) and trailer length (ft).

    The row closes (front + WB1 + WB2 + rear = length) with the kingpin over the tractor's
    effective rear axle, so hitch_offset = 0. The tractor's own rear end is not tabulated:
    2.0 ft behind its effective rear axle is assumed.
    """
    tractor_rear = 2.0
    return {
        "model": "tractor-trailer",
        "wheelbase": _m(wb1),
        "hitch_offset": 0.0,
        "trailer_wheelbase": _m(wb2),
        "body": _rect(_m(front + wb1 + tractor_rear), _m(width), _m(tractor_rear)),
        "trailer_body": _rect(_m(trailer), _m(width), _m(rear)),
        "bounds": {"phi": _steer(wb1, ctr)},
        "source": AASHTO,
        "derived": ("hitch_offset", "bounds.phi"),
        "assumed": ("body.length", "body.rear_overhang") + (("trailer_body.length",) if trailer_assumed else ()),
        "notes": f"ft: L={length} W={width} front={front} rear={rear} WB1={wb1} WB2={wb2} CTR={ctr} "
        f"trailer={trailer}; tractor rear overhang 2.0 ft assumed; hitch_offset 0 from the row's closure; "
        "rear overhang read from the trailer's effective (tandem-centre) axle; phi_max = asin(WB1 / CTR) derived.",
    }


def _eu_semitrailer() -> dict[str, Any]:
    """A typical 16.50 m tractor-semitrailer at the limits of 96/53/EC.

    Published limits used: overall length 16.50, width 2.55, kingpin to rear 12.00, front swing
    radius 2.04. Assumed (typical 4x2 tractor, tri-axle semitrailer): tractor wheelbase 3.70, fifth
    wheel 0.60 ahead of the drive axle, tractor rear overhang 1.00, trailer wheelbase (kingpin to
    the middle axle) 7.70, kingpin 1.59 behind the trailer front (swing radius
    hypot(1.59, 1.275) = 2.038 <= 2.04). Derived: tractor front overhang
    16.50 - 12.00 - (3.70 - 0.60) = 1.40, trailer length 12.00 + 1.59, rear overhang 12.00 - 7.70.
    With these the steady turn with the outer front corner on 12.50 m keeps the trailer's inner
    side at 5.35 m >= 5.30 m (Annex I 1.5).
    """
    width, kingpin_to_rear, kingpin_to_front = 2.55, 12.00, 1.59
    d, h, trailer_wb, tractor_rear = 3.70, 0.60, 7.70, 1.00
    front = 16.50 - kingpin_to_rear - (d - h)
    return {
        "model": "tractor-trailer",
        "wheelbase": d,
        "hitch_offset": h,
        "trailer_wheelbase": trailer_wb,
        "body": _rect(round(front + d + tractor_rear, 6), width, tractor_rear),
        "trailer_body": _rect(kingpin_to_rear + kingpin_to_front, width, round(kingpin_to_rear - trailer_wb, 6)),
        "bounds": {},
        "source": EU,
        "derived": ("body.length", "trailer_body.rear_overhang"),
        "assumed": ("wheelbase", "hitch_offset", "trailer_wheelbase", "body.rear_overhang", "trailer_body.length"),
        "notes": "limits used: length 16.50, width 2.55, kingpin-rear 12.00, front swing 2.04; "
        "d 3.70, h 0.60, L 7.70, tractor rear overhang 1.00, kingpin 1.59 behind trailer front assumed.",
    }


def _commonroad_4() -> dict[str, Any]:
    """CommonRoad vehicle 4: tractor l = 5.1, w = 2.55, a = b = 1.8; trailer l = 13.6, w = 2.55,
    l_hitch = 12.00, l_total = 16.5, l_wb = 8.1; on-axle hitch; steering +-0.55 rad, +-0.7103 rad/s;
    speed -2.78 .. 22.22 m/s."""
    l_total, l_hitch, l_wb = 16.5, 12.00, 8.1
    tractor_length = 5.1
    return {
        "model": "tractor-trailer",
        "wheelbase": 1.8 + 1.8,
        "hitch_offset": 0.0,
        "trailer_wheelbase": l_wb,
        "body": _rect(tractor_length, 2.55, round(tractor_length - (l_total - l_hitch), 6)),
        "trailer_body": _rect(13.6, 2.55, round(l_hitch - l_wb, 6)),
        "bounds": {"phi": (-0.55, 0.55), "u2": (-0.7103, 0.7103), "u1": (-2.78, 22.22)},
        "source": COMMONROAD,
        "derived": ("body.rear_overhang", "trailer_body.rear_overhang"),
        "assumed": (),
        "notes": "rear overhangs derived: tractor 5.1 - (16.5 - 12.0) = 0.6, trailer 12.0 - 8.1 = 3.9 "
        "(the placement CommonRoad uses to draw vehicle 4).",
    }


_PRESETS: dict[str, dict[str, Any]] = {
    # Table 2-1a rows (ft): length, width, front overhang, rear overhang, WB1 [, WB2]; Table 2-2a CTR (ft).
    "P": _aashto_truck(length=19.0, width=7.0, front=3.0, rear=5.0, wb=11.0, ctr=21.0),
    "SU-30": _aashto_truck(length=30.0, width=8.0, front=4.0, rear=6.0, wb=20.0, ctr=38.0),
    # trailer lengths: 33 ft (WB-40, assumed), 48 ft (WB-62) and 53 ft (WB-67) per the table's footnotes.
    "WB-40": _aashto_semi(
        length=45.5, width=8.0, front=3.0, rear=4.5, wb1=12.5, wb2=25.5, ctr=36.0, trailer=33.0, trailer_assumed=True
    ),
    "WB-62": _aashto_semi(length=69.0, width=8.5, front=4.0, rear=4.5, wb1=19.5, wb2=41.0, ctr=41.0, trailer=48.0),
    "WB-67": _aashto_semi(length=73.5, width=8.5, front=4.0, rear=4.5, wb1=19.5, wb2=45.5, ctr=41.0, trailer=53.0),
    "EU-semitrailer": _eu_semitrailer(),
    "CommonRoad-4": _commonroad_4(),
}

PRESETS: tuple[str, ...] = tuple(_PRESETS)
"""The preset names, in the order above."""


def preset(name: str) -> dict[str, Any]:
    """The named preset, a fresh copy (case-insensitive name).

    Parameters
    ----------
    name : str
        One of ``PRESETS``.

    Returns
    -------
    dict
        ``model``, ``wheelbase``, [``hitch_offset``, ``trailer_wheelbase``], ``body``,
        [``trailer_body``], ``bounds``, ``source``, ``derived``, ``assumed``, ``notes``; lengths in m, angles in rad.

    Raises
    ------
    InputError
        ``vehicle.preset``: unknown name, with the closest known one suggested.

    Examples
    --------
    >>> p = preset("WB-62")
    >>> p["model"], round(p["trailer_wheelbase"], 3)
    ('tractor-trailer', 12.497)
    """
    by_lower = {k.lower(): k for k in PRESETS}
    key = by_lower.get(str(name).lower())
    if key is None:
        raise InputError("vehicle.preset", _unknown(str(name), by_lower))
    return copy.deepcopy(_PRESETS[key])


def _unknown(name: str, by_lower: dict[str, str]) -> str:
    close = difflib.get_close_matches(name.lower(), list(by_lower), n=1, cutoff=0.5)
    if close:
        return f"unknown preset '{name}' (did you mean '{by_lower[close[0]]}'?)"
    return f"unknown preset '{name}' (known: {', '.join(PRESETS)})"


# -- operational limits ---------------------------------------------------------------------------

G = 9.80665  # m/s^2, standard gravity
KMH = 1.0 / 3.6  # m/s per km/h

SUMO = (
    "SUMO vClass defaults (sumo.dlr.de/docs/Vehicle_Type_Parameter_Defaults.html): passenger accel 2.6, "
    "decel 4.5, emergencyDecel 9.0 m/s^2, maxSpeed 200 km/h; truck accel 1.3, decel 4.0, emergencyDecel 7.0, "
    "maxSpeed 130 km/h; trailer accel 1.0, decel 4.0, emergencyDecel 7.0, maxSpeed 130 km/h"
)
AASHTO_SSD = (
    "AASHTO Green Book 2018 (7th ed.), stopping sight distance: deceleration 3.4 m/s^2 (11.2 ft/s^2), "
    "comfortable for most drivers"
)
JARVIS = (
    "Jarvis (1989), The in-service braking levels of Australian heavy vehicles, SAE 892505: heavy vehicles "
    "brake at 0.4-0.7 m/s^2 on average; 0.25 g is the accepted limit of comfortable passenger-car braking"
)
UMTRI = (
    "NHTSA/UMTRI: static rollover threshold of loaded tractor-semitrailers 0.25-0.40 g "
    "(Winkler & Ervin 1999, Rollover of Heavy Commercial Vehicles, UMTRI-99-19)"
)
GERTSCH = (
    "Gertsch & Eichelhard (2003), SAE 2003-01-3385: a tractor-semitrailer's dynamic rollover threshold "
    "is about 25 % below its static one"
)
CRAWL = (
    "AASHTO Green Book 2018 (7th ed.) Table 2-1/2-2 dimensions; design turns at <= 15 km/h (10 mph); 10 km/h "
    "chosen within it (assumed) so that a full-lock turn keeps within lateral_acceleration (at 15 km/h the rear "
    "axle's a_lat at full lock is P 3.18, WB-40 1.69, WB-62/67 1.58, CommonRoad-4 2.96 m/s^2, above their bounds); "
    "for EU-semitrailer and CommonRoad-4 applied by analogy (their sources name no turning speed)"
)
COMMONROAD_2 = (
    "CommonRoad vehicle models, parameters_vehicle2 (BMW 320i): steering velocity bound 0.4 rad/s; "
    "tracks 1.387 / 1.364 m, h_cg 0.575 m"
)
COMMONROAD_4_LIMITS = (
    "CommonRoad vehicle models, parameters_vehicle4 (semi-trailer truck): steering velocity +-0.7103 rad/s, "
    "v_max 22.22 m/s, a_max 11.5 m/s^2 (the car models' friction-level bound, not a truck's drive)"
)
URBAN_SPEED = (
    "assumed: the road class of these presets, an urban road with a roundabout: 50 km/h, the general urban "
    "limit for every motor vehicle (German StVO sec. 3(3) no. 1); each vehicle's own top speed is higher "
    "(SUMO truck/trailer maxSpeed 130 km/h, CommonRoad-4 v_max 22.22 m/s); on the ring the lateral-acceleration "
    "bound limits v"
)
JERK_TRUCK = (
    "assumed: ISO 2631 / comfort: jerk ~ 0.5-1 m/s^3 for heavy vehicles (no standard gives a jerk limit; "
    "the upper end taken)"
)
STEER_TRUCK = (
    "assumed: a steering wheel turned at 1-1.5 rev/s through a heavy truck's overall steering ratio of "
    "about 20:1 moves the road wheels 0.31-0.47 rad/s"
)


@dataclass(frozen=True)
class OperationalLimits:
    """How a design vehicle may accelerate, brake, steer and corner (SI units, radians).

    Parameters
    ----------
    acceleration : tuple of float
        (lo, hi), m/s^2: comfortable braking (lo < 0) and the longitudinal acceleration's upper bound.
    jerk : tuple of float
        (lo, hi), m/s^3, lo < 0 < hi.
    speed : float
        Upper bound of the speed v, m/s (the vehicle's top speed on the presets' road class).
    steering_rate : float
        Symmetric bound of the steering angle's rate, rad/s.
    rollover_threshold : float
        Static rollover threshold, m/s^2 (a vehicle that slides before it rolls: its friction limit).
    lateral_acceleration : float
        Symmetric bound of the lateral acceleration a designer allows, m/s^2, below ``rollover_threshold``.
    crawl_speed : float
        Speed of design turns, m/s.
    sources : dict of str to str
        Field name -> the reference of its number(s), or "assumed: <reason>".
    """

    acceleration: tuple[float, float]
    jerk: tuple[float, float]
    speed: float
    steering_rate: float
    rollover_threshold: float
    lateral_acceleration: float
    crawl_speed: float
    sources: dict[str, str] = field(default_factory=dict)


def _car_limits() -> OperationalLimits:
    """AASHTO P: a passenger car."""
    ssf = (1.38684 + 1.36398) / 2 / (2 * 0.57486895)  # CommonRoad vehicle 2: mean track / (2 h_cg), in g
    return OperationalLimits(
        acceleration=(-3.4, 2.6),
        jerk=(-2.0, 2.0),
        speed=50.0 * KMH,
        steering_rate=0.4,
        rollover_threshold=0.8 * G,
        lateral_acceleration=3.0,
        crawl_speed=10.0 * KMH,
        sources={
            "acceleration": f"lo: {AASHTO_SSD}; hi: {SUMO} (passenger accel)",
            "jerk": "assumed: a car's comfortable jerk, twice the heavy vehicles' 1 m/s^3 (no standard gives one)",
            "speed": URBAN_SPEED,
            "steering_rate": COMMONROAD_2,
            "rollover_threshold": "assumed: a car slides before it rolls: tyre-road friction ~0.8 g (dry) is below "
            f"its static stability factor T/(2 h_cg) = {ssf:.2f} g ({COMMONROAD_2})",
            "lateral_acceleration": "assumed: ~0.3 g, a comfortable car's cornering level, well below the 0.8 g "
            "friction limit",
            "crawl_speed": CRAWL,
        },
    )


def _rigid_truck_limits() -> OperationalLimits:
    """AASHTO SU-30: a loaded single-unit truck."""
    return OperationalLimits(
        acceleration=(-2.5, 1.3),
        jerk=(-1.0, 1.0),
        speed=50.0 * KMH,
        steering_rate=0.4,
        rollover_threshold=0.45 * G,
        lateral_acceleration=2.0,
        crawl_speed=10.0 * KMH,
        sources={
            "acceleration": f"lo: assumed: 0.25 g, the comfort limit of car braking ({JARVIS}), below SUMO's "
            f"'convenient' truck decel 4.0; hi: {SUMO} (truck accel)",
            "jerk": JERK_TRUCK,
            "speed": URBAN_SPEED,
            "steering_rate": STEER_TRUCK,
            "rollover_threshold": "assumed: 0.45 g for a loaded rigid truck, above the 0.25-0.40 g of loaded "
            f"tractor-semitrailers ({UMTRI}): a single unit with a lower load than a semitrailer's",
            "lateral_acceleration": "assumed: 2.0 m/s^2 (0.20 g), under half the rollover threshold "
            f"for the dynamic effects ({GERTSCH})",
            "crawl_speed": CRAWL,
        },
    )


def _semitrailer_limits(steering_rate: float = 0.4, steering_source: str = STEER_TRUCK) -> OperationalLimits:
    """A loaded tractor-semitrailer (AASHTO WB-40/62/67, EU 16.50 m, CommonRoad-4)."""
    return OperationalLimits(
        acceleration=(-2.0, 1.0),
        jerk=(-1.0, 1.0),
        speed=50.0 * KMH,
        steering_rate=steering_rate,
        rollover_threshold=0.35 * G,
        lateral_acceleration=1.5,
        crawl_speed=10.0 * KMH,
        sources={
            "acceleration": f"lo: assumed: 0.2 g for a loaded articulated truck, under the 0.25 g comfort limit "
            f"of car braking ({JARVIS}) and half SUMO's 'convenient' trailer decel 4.0; hi: {SUMO} (trailer accel)",
            "jerk": JERK_TRUCK,
            "speed": URBAN_SPEED,
            "steering_rate": steering_source,
            "rollover_threshold": f"assumed: 0.35 g, chosen inside the range of {UMTRI}",
            "lateral_acceleration": "assumed: 1.5 m/s^2 (0.15 g), under half the rollover threshold "
            f"for the dynamic effects ({GERTSCH}) and the trailer's rearward amplification",
            "crawl_speed": CRAWL,
        },
    )


_OPERATIONAL: dict[str, OperationalLimits] = {
    "P": _car_limits(),
    "SU-30": _rigid_truck_limits(),
    "WB-40": _semitrailer_limits(),
    "WB-62": _semitrailer_limits(),
    "WB-67": _semitrailer_limits(),
    "EU-semitrailer": _semitrailer_limits(),
    "CommonRoad-4": _semitrailer_limits(0.7103, COMMONROAD_4_LIMITS),
}


def operational_limits(name: str) -> OperationalLimits | None:
    """The named preset's operational limits, a fresh copy (case-insensitive name).

    Parameters
    ----------
    name : str
        One of ``PRESETS``.

    Returns
    -------
    OperationalLimits or None
        The limits, each with its source in ``sources``; None for a preset without limits.

    Raises
    ------
    InputError
        ``vehicle.preset``: unknown name, with the closest known one suggested.

    Examples
    --------
    >>> lim = operational_limits("EU-semitrailer")
    >>> lim.acceleration, round(lim.rollover_threshold, 3), lim.lateral_acceleration
    ((-2.0, 1.0), 3.432, 1.5)
    """
    by_lower = {k.lower(): k for k in PRESETS}
    key = by_lower.get(str(name).lower())
    if key is None:
        raise InputError("vehicle.preset", _unknown(str(name), by_lower))
    limits = _OPERATIONAL.get(key)
    return None if limits is None else copy.deepcopy(limits)
