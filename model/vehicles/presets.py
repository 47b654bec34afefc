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
"""

from __future__ import annotations

import copy
import difflib
import math
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
