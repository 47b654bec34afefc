"""Road studies (issue 11, item 8): the EU turning circle, design vehicles x roundabout sizes, road trade-offs.

Turning circle (Directive 96/53/EC, Annex I 1.5: a vehicle must turn a full circle within an
outer radius of 12.50 m and an inner radius of 5.30 m). ``steady_turn`` places the vehicle in
the steady state of a constant steering angle: the tractor's rear axle on a circle of radius
R = d / tan(phi), the trailer axle on R_t = sqrt(R^2 + h^2 - L^2) (off-axle hitch h, trailer
wheelbase L), each body a rectangle at its pose. The outer swept radius is the largest distance
of any corner from the centre, the inner one the least distance of any rectangle (a side, not
only a corner) from it. ``eu_steering`` finds the steering angle whose outer radius is exactly
12.50 m (bisection: the outer radius falls as phi grows); ``transient_turn`` integrates the
model (scipy, tight tolerances) from straight driving (trailer aligned) through a full turn at
that angle and measures the swept annulus of the exact rectangles over the run.

Design-vehicle table. ``cell_document`` makes one cell's scenario document from a template
(a TOML dictionary): the preset, the inscribed diameter, the apron; ``apron_use`` is "trailer" for
an articulated vehicle (the tractor stays on the roadway), "all" for a single-unit truck and
"none" for the passenger car P (a truck apron is not for cars).
``cell_measures`` reads what a designer wants from a solved trajectory: the apron used (the
deepest encroachment of any allowed body inside the ring roadway's inner edge, from the exact
rectangles) and the swept width (the radial extent of the swept area on rays through the ring).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from model.problem.ocp import OCP
from model.vehicles import Body, Vehicle

EU_OUTER = 12.50  # m, Annex I 1.5
EU_INNER = 5.30  # m


# --------------------------------------------------------------------------- steady state


def preset_vehicle(name: str) -> tuple[Vehicle, dict[str, Body], float | None]:
    """The named preset's vehicle, its bodies and its steering limit (None if the preset gives none)."""
    from model.vehicles import VEHICLES, preset

    data = preset(name)
    cls = VEHICLES[data["model"]]
    keys = {"wheelbase", "hitch_offset", "trailer_wheelbase"}
    vehicle = cls(**{k: v for k, v in data.items() if k in keys})
    bodies = {"vehicle": Body(**data["body"])}
    if data.get("trailer_body"):
        bodies["trailer"] = Body(**data["trailer_body"], key="vehicle.trailer_body")
    phi = data.get("bounds", {}).get(vehicle.roles.steering)
    return vehicle, bodies, (float(phi[1]) if phi else None)


def trailer_radius(R: float, h: float, L: float) -> float:
    """Steady-state radius of the trailer axle: R_t = sqrt(R^2 + h^2 - L^2) (R: tractor rear axle)."""
    return math.sqrt(R * R + h * h - L * L)


def steady_poses(vehicle: Vehicle, phi: float) -> dict[str, float]:
    """The state of the steady left turn at steering ``phi`` > 0, centre at the origin, tractor heading +y.

    The tractor's rear axle is at (R, 0); the trailer heading follows from its axle lying on the
    circle R_t with its velocity tangent: the hitch (R, h) and the axle differ by L along theta1
    (the state names are the vehicle's ``roles``; one trailer at most).
    """
    p, r = vehicle.parameter_values(), vehicle.roles
    d = p["wheelbase"]
    R = d / math.tan(phi)
    state = {r.x: R, r.y: 0.0, r.heading: math.pi / 2, r.steering: phi}
    for trailer in r.trailers:
        h, L = p["hitch_offset"], p["trailer_wheelbase"]
        rt = trailer_radius(R, h, L)
        # trailer axle at angle -beta from the hitch ray: hitch (R, h); axle at radius rt, tangent ccw
        hitch = np.array([R, h])
        # the axle point a with |a| = rt, (hitch - a) . a = 0 (heading along the tangent, perpendicular to a)
        ang_h = math.atan2(h, R)
        ang_a = ang_h - math.acos(rt / math.hypot(R, h))
        a = rt * np.array([math.cos(ang_a), math.sin(ang_a)])
        diff = hitch - a
        state[trailer] = math.atan2(diff[1], diff[0])
    return state


def _arrays(state: Mapping[str, float | np.ndarray]) -> dict[str, np.ndarray]:
    return {k: np.atleast_1d(np.asarray(v, float)) for k, v in state.items()}


def corners(vehicle: Vehicle, bodies: Mapping[str, Body], states: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Corners (n, 4, 2) of each body (as ``model.analysis.bodies.body_corners``, without a full OCP)."""
    from model.analysis.bodies import body_corners

    return body_corners(SimpleNamespace(vehicle=vehicle, bodies=bodies), _arrays(states))


def rectangle_distance(corners_: np.ndarray, point=(0.0, 0.0)) -> np.ndarray:
    """Least distance from ``point`` to each rectangle (…, 4, 2), 0 if inside: sides, not only corners."""
    p = np.asarray(point, float)
    a = corners_
    b = np.roll(corners_, -1, axis=-2)
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
    foot = a + t[..., None] * ab
    dist = np.min(np.linalg.norm(foot - p, axis=-1), axis=-1)
    # inside: the point is left of every counter-clockwise side
    cross = ab[..., 0] * (p[1] - a[..., 1]) - ab[..., 1] * (p[0] - a[..., 0])
    inside = np.all(cross >= 0, axis=-1)
    return np.where(inside, 0.0, dist)


def swept_radii(vehicle: Vehicle, bodies: Mapping[str, Body], states: Mapping[str, np.ndarray]) -> dict:
    """Outer (largest corner distance) and inner (least rectangle distance) radii about the origin, per body."""
    out = {}
    for name, c in corners(vehicle, bodies, states).items():
        out[name] = {"outer": float(np.max(np.linalg.norm(c, axis=-1))), "inner": float(np.min(rectangle_distance(c)))}
    return out


def steady_turn(vehicle: Vehicle, bodies: Mapping[str, Body], phi: float) -> dict:
    """The steady circle at steering ``phi``: radii of the axles and the swept outer/inner radii."""
    state = steady_poses(vehicle, phi)
    radii = swept_radii(vehicle, bodies, state)
    p, r = vehicle.parameter_values(), vehicle.roles
    R = state[r.x]
    out = {
        "phi": phi,  # names: a result key (the steering angle), not a state looked up
        "R": R,
        "front_axle_radius": math.hypot(R, p["wheelbase"]),
        "outer": max(r["outer"] for r in radii.values()),
        "inner": min(r["inner"] for r in radii.values()),
        "outer_body": max(radii, key=lambda b: radii[b]["outer"]),
        "inner_body": min(radii, key=lambda b: radii[b]["inner"]),
        "bodies": radii,
    }
    for trailer in r.trailers:
        out["trailer_axle_radius"] = trailer_radius(R, p["hitch_offset"], p["trailer_wheelbase"])
        out["articulation"] = state[r.heading] - state[trailer]
    return out


def _steering_limit(vehicle: Vehicle) -> float:
    """The largest steering angle of a steady circle: below pi / 2, and with a trailer where its axle
    radius stays real (R^2 + h^2 >= L^2)."""
    p = vehicle.parameter_values()
    hi = math.pi / 2 - 1e-4
    if "trailer_wheelbase" in p:
        L, h = p["trailer_wheelbase"], p["hitch_offset"]
        hi = min(hi, math.atan(p["wheelbase"] / math.sqrt(max(L**2 - h**2, 0.0) + 1e-9)))
    return hi


def eu_steering(vehicle: Vehicle, bodies: Mapping[str, Body], outer: float = EU_OUTER, tol: float = 1e-12) -> float:
    """The steering angle whose steady circle has the outer swept radius ``outer`` (bisection)."""
    lo, hi = 1e-4, _steering_limit(vehicle)
    if steady_turn(vehicle, bodies, hi)["outer"] > outer:
        raise ValueError(f"no steering angle brings the outer swept radius down to {outer} m")
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if steady_turn(vehicle, bodies, mid)["outer"] > outer:
            lo = mid
        else:
            hi = mid
    return hi


# --------------------------------------------------------------------------- integrated turn


def integrate(vehicle: Vehicle, state0: Mapping[str, float], u1: float, u2: float, t_end: float,
              samples: int = 2001, rtol: float = 1e-11, atol: float = 1e-12) -> dict[str, np.ndarray]:  # fmt: skip
    """The model integrated with constant controls (scipy's DOP853): t and the states at ``samples`` times.

    ``u1`` is the speed control's value (``roles.speed``), ``u2`` the steering (or turn) rate's
    (``roles.turning``); any other control is 0.
    """
    import sympy as sp
    from scipy.integrate import solve_ivp

    from model.vehicles.base import sym

    xs, us = vehicle.state_symbols(), [sym(c) for c in vehicle.controls]
    f = sp.lambdify([xs, us], vehicle.rhs(numeric=True), "numpy")
    held = {vehicle.roles.speed: u1, vehicle.roles.turning: u2}
    u = [held.get(c, 0.0) for c in vehicle.controls]
    t = np.linspace(0.0, t_end, samples)
    sol = solve_ivp(lambda _t, x: np.asarray(f(x, u), float), (0.0, t_end),
                    [state0[s] for s in vehicle.states], method="DOP853", t_eval=t, rtol=rtol, atol=atol)  # fmt: skip
    if not sol.success:
        raise RuntimeError(sol.message)
    return {"t": sol.t, **{s: sol.y[i] for i, s in enumerate(vehicle.states)}}


def transient_turn(vehicle: Vehicle, bodies: Mapping[str, Body], phi: float, turns: int = 2,
                   per_turn: int = 1800) -> dict:  # fmt: skip
    """``turns`` full turns of the tractor's heading at steering ``phi``, from straight driving.

    The tractor starts on its steady circle (centre at the origin, heading +y, the steering
    already at ``phi`` as after setting it at standstill) with the trailer aligned behind it, as
    after driving straight; the trailer's off-tracking builds up over the run. Per turn and body:
    the outer (largest corner distance) and inner (least rectangle distance) radii over the
    samples, and the same radii of the exact swept polygon (shapely union of the rectangles);
    ``swing_out``: how far any corner moves beyond the straight vehicle's outer side (the line
    x = max corner x at t = 0) during the first half turn; ``trailer_axle_radius``: at each turn's end.
    """
    import shapely

    d, r = vehicle.parameter_values()["wheelbase"], vehicle.roles
    R = d / math.tan(phi)
    state0 = {r.x: R, r.y: 0.0, r.heading: math.pi / 2, r.steering: phi, **dict.fromkeys(r.trailers, math.pi / 2)}
    t_turn = 2 * math.pi * R  # u1 = 1 m/s: theta' = tan(phi) / d = 1 / R
    run = integrate(vehicle, state0, 1.0, 0.0, turns * t_turn, turns * per_turn + 1)
    body_corners_ = corners(vehicle, bodies, run)
    origin = shapely.Point(0.0, 0.0)
    per = []
    for k in range(turns):
        pick = slice(k * per_turn, (k + 1) * per_turn + 1)
        bodies_k = {}
        for name, c in body_corners_.items():
            ck = c[pick]
            poly = shapely.union_all(shapely.polygons(ck)).buffer(0)
            bodies_k[name] = {
                "outer": float(np.max(np.linalg.norm(ck, axis=-1))),
                "inner": float(np.min(rectangle_distance(ck))),
                "outer_polygon": _farthest(poly),
                "inner_polygon": float(poly.distance(origin)),
                "outside_annulus_m2": float(poly.difference(_annulus()).area),
            }
        per.append({
            "turn": k + 1,
            "outer": max(b["outer"] for b in bodies_k.values()),
            "inner": min(b["inner"] for b in bodies_k.values()),
            "outside_annulus_m2": sum(b["outside_annulus_m2"] for b in bodies_k.values()),
            "bodies": bodies_k,
        })  # fmt: skip
    x0 = max(float(np.max(c[0, :, 0])) for c in body_corners_.values())
    half = slice(0, per_turn // 2 + 1)
    out = {
        "phi": phi,  # names: a result key
        "R": R,
        "turns": per,
        "swing_out": max(float(np.max(c[half, :, 0])) for c in body_corners_.values()) - x0,
        "run": run,
    }
    for trailer in r.trailers:
        p = vehicle.parameter_values()
        h, L = p["hitch_offset"], p["trailer_wheelbase"]
        ax = run[r.x] + h * np.cos(run[r.heading]) - L * np.cos(run[trailer])
        ay = run[r.y] + h * np.sin(run[r.heading]) - L * np.sin(run[trailer])
        radius = np.hypot(ax, ay)
        out["trailer_axle_radius"] = [float(radius[(k + 1) * per_turn]) for k in range(turns)]
        run["trailer_axle_radius"] = radius
    return out


def _annulus(outer: float = EU_OUTER, inner: float = EU_INNER):
    import shapely

    return shapely.Point(0.0, 0.0).buffer(outer, 4096).difference(shapely.Point(0.0, 0.0).buffer(inner, 4096))


def _farthest(poly) -> float:
    """The largest distance of a (Multi)Polygon's vertices from the origin (its farthest point)."""
    import shapely

    xy = shapely.get_coordinates(poly)
    return float(np.max(np.hypot(xy[:, 0], xy[:, 1])))


def least_outer(vehicle: Vehicle, bodies: Mapping[str, Body], phi_limit: float | None) -> dict:
    """The steady circle at the largest steering allowed (the limit, or where the trailer axle radius vanishes)."""
    hi = _steering_limit(vehicle)
    if phi_limit is not None:
        hi = min(hi, phi_limit)
    return steady_turn(vehicle, bodies, hi)


def eu_turning_circle(vehicle: Vehicle, bodies: Mapping[str, Body], phi_limit: float | None = None,
                      transient: bool = True) -> dict:  # fmt: skip
    """The 96/53/EC test: the steering for a 12.50 m outer radius, steady and integrated radii, margins.

    ``passes`` needs: a steering angle within the limit whose steady outer swept radius is 12.50 m,
    an inner swept radius >= 5.30 m in the steady state and over the integrated turns, and the
    exact swept polygon of the last integrated turn inside the annulus. Without such an angle,
    ``least_outer`` is the steady circle at the largest steering allowed (its outer radius > 12.50 m).
    """
    try:
        phi = eu_steering(vehicle, bodies)
    except ValueError:
        return {"phi": None, "phi_limit": phi_limit, "passes": False,  # names: result keys
                "least_outer": least_outer(vehicle, bodies, phi_limit)}  # fmt: skip
    steady = steady_turn(vehicle, bodies, phi)
    out = {
        "phi": phi,  # names: a result key
        "phi_deg": math.degrees(phi),
        "phi_limit": phi_limit,
        "within_limit": phi_limit is None or phi <= phi_limit,
        "steady": steady,
        "outer_margin": EU_OUTER - steady["outer"],
        "inner_margin": steady["inner"] - EU_INNER,
    }
    if not out["within_limit"]:
        out["least_outer"] = least_outer(vehicle, bodies, phi_limit)
    inner = steady["inner"]
    if transient:
        run = transient_turn(vehicle, bodies, phi)
        out["transient"] = run
        inner = min(inner, *(t["inner"] for t in run["turns"]))
        out["transient_inner_margin"] = min(t["inner"] for t in run["turns"]) - EU_INNER
        out["last_turn_outer_margin"] = EU_OUTER - run["turns"][-1]["outer"]
        out["last_turn_outside_m2"] = run["turns"][-1]["outside_annulus_m2"]
    out["passes"] = bool(out["within_limit"] and inner >= EU_INNER and steady["outer"] <= EU_OUTER + 1e-9
                         and (not transient or out["last_turn_outside_m2"] < 1e-6))  # fmt: skip
    return out


# --------------------------------------------------------------------------- the design-vehicle table


def operational_document(doc: dict, preset_name: str) -> dict:
    """``doc`` (a cell's scenario document, changed in place and returned) at the preset's operational limits.

    ``[vehicle] operational = true`` (docs/dynamics-format.md: the preset's acceleration, jerk, steering-rate
    and lateral-acceleration bounds, the speed the state ``v``); the template's bound of the speed control
    becomes the bound of ``v`` (so a template's design speed or forward-only rule still holds), its bound of
    the steering rate gives way to the preset's. The vehicle enters at the preset's crawl speed (``[initial]
    v``, the speed of AASHTO's design turns) and leaves at any speed: a start speed left free would let the
    minimum time choose how fast the vehicle arrives, and a start from rest would measure the start, not the turn.

    Parameters
    ----------
    doc : dict
        The cell's document, with ``vehicle.preset`` = ``preset_name`` set.
    preset_name : str
        A preset with operational limits (``model.vehicles.operational_limits``).

    Returns
    -------
    dict
        ``doc``.
    """
    from model.vehicles import VEHICLES, operational_limits, preset

    roles = VEHICLES[preset(preset_name)["model"]].roles
    limits = operational_limits(preset_name)
    doc["vehicle"]["operational"] = True
    bounds = doc.setdefault("bounds", {})
    speed = bounds.pop(roles.speed, None)
    bounds.pop(roles.steering_rate, None)
    if speed is not None:
        bounds["v"] = [max(0.0, float(speed[0])), min(float(speed[1]), limits.speed)]
    doc["initial"] = {**doc.get("initial", {}), "v": limits.crawl_speed}
    return doc


def operational_text(preset_name: str) -> str:
    """The preset's operational limits in words, every number read from ``operational_limits``."""
    from model.vehicles import operational_limits

    lim = operational_limits(preset_name)
    return (f"{preset_name}: a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}] m/s^2, jerk in "
            f"[{lim.jerk[0]:g}, {lim.jerk[1]:g}] m/s^3, lateral acceleration at most {lim.lateral_acceleration:g} "
            f"m/s^2, steering rate at most {lim.steering_rate:g} rad/s, v at most {lim.speed:.2f} m/s, entering at "
            f"{lim.crawl_speed:.2f} m/s")  # fmt: skip


def limits_note(preset_name: str, operational: bool, max_lateral: float | None,
                acceleration: tuple[float | None, float | None] | None = None) -> str:  # fmt: skip
    """What a run's row says next to it about the vehicle's limits, every number read, none typed.

    Parameters
    ----------
    preset_name : str
        The preset whose operational limits (``model.vehicles.operational_limits``) the run is held to or
        compared with.
    operational : bool
        Whether the run was solved at those limits.
    max_lateral : float or None
        The run's largest |lateral acceleration| at the nodes, m/s^2 (its summary's), None if not measured.
    acceleration : tuple or None
        The run's (least, largest) acceleration at the nodes, m/s^2, None where the speed is a control.

    Returns
    -------
    str
        "operational limits of the <preset>: ..." with what the run reached, or "kinematic model without
        operational limits: max lateral acceleration X m/s^2 (above (or within) the <preset>'s allowed Y
        m/s^2); ...". No "|": the note goes into Markdown tables.
    """
    from model.vehicles import operational_limits

    lim = operational_limits(preset_name)
    allowed = lim.lateral_acceleration
    lat = ("max lateral acceleration not measured" if max_lateral is None
           else f"max lateral acceleration {max_lateral:.2f} m/s^2")  # fmt: skip
    if operational:
        reached = f"; reached: {lat}" + (f", a in [{acceleration[0]:.2f}, {acceleration[1]:.2f}] m/s^2"
                                         if acceleration and None not in acceleration else "")  # fmt: skip
        return (
            f"operational limits of the {preset_name}: a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}]"
            f" m/s^2, jerk in [{lim.jerk[0]:g}, {lim.jerk[1]:g}] m/s^3, lateral acceleration at most {allowed:g}"
            f" m/s^2{reached}"
        )
    side = "" if max_lateral is None else (" (above" if max_lateral > allowed * (1 + 1e-6) else " (within")
    side = side and f"{side} the {preset_name}'s allowed {allowed:g} m/s^2)"
    return (
        f"kinematic model without operational limits: {lat}{side}; the speed a control, its changes "
        f"unbounded (the {preset_name} allows a in [{lim.acceleration[0]:g}, {lim.acceleration[1]:g}] m/s^2)"
    )


def limits_cell(preset_name: str, operational: bool, max_lateral: float | None,
                acceleration: tuple[float | None, float | None] | None = None) -> str:  # fmt: skip
    """``limits_note`` short enough for a table cell (its header gives the unit, m/s^2).

    "held: a_lat 1.50, a -1.27 to 1.00" for a run at the preset's operational limits (what it reached), "none:
    a_lat 9.38 > 1.5" for the kinematic model without them (its largest lateral acceleration against the
    preset's allowed one); the section states each preset's limits once, beside the table.
    """
    from model.vehicles import operational_limits

    lat = "a_lat -" if max_lateral is None else f"a_lat {max_lateral:.2f}"
    if operational:
        accel = (f", a {acceleration[0]:.2f} to {acceleration[1]:.2f}"
                 if acceleration and None not in acceleration else "")  # fmt: skip
        return f"held: {lat}{accel}"
    allowed = operational_limits(preset_name).lateral_acceleration
    if max_lateral is None:
        return f"none ({preset_name} allows a_lat {allowed:g})"
    return f"none: {lat} {'>' if max_lateral > allowed * (1 + 1e-6) else '<='} {allowed:g}"


# the start of a preset's source -> its citation (written out, so tests/test_paper_structure.py checks the keys)
SOURCE_CITATIONS = {
    "AASHTO": "[@aashto2018]",
    "Council Directive 96/53/EC": "[@directive9653]",
    "CommonRoad": "[@commonroadvehicles]",
}


def source_citation(source: str) -> str:
    """The ``[@key]`` of a preset's source after a space, or the empty string for a source the bibliography lacks."""
    cite = next((c for start, c in SOURCE_CITATIONS.items() if source.startswith(start)), None)
    return f" {cite}" if cite else ""


def preset_citation(name: str) -> str:
    """The preset ``name`` and the citation of the source of its dimensions ("SU-30 [@aashto2018]")."""
    from model.vehicles import preset

    return name + source_citation(preset(name)["source"])


def presets_cited(names: list[str]) -> str:
    """Presets with their sources' citations, each citation once after its group: "P, SU-30 [@aashto2018] and
    EU-semitrailer [@directive9653]" (the groups in the order of their first preset)."""
    from model.vehicles import preset

    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(source_citation(preset(name)["source"]), []).append(name)
    parts = [", ".join(group) + cite for cite, group in groups.items()]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


OPERATIONAL_SUFFIX = "-operational"  # a road <name>-operational.toml: the route <name> at a preset's limits
DESIGN_SUFFIX = "-design"  # a road <name>-design.toml: the route <name> at a design speed


def reference_preset(scenario: Path) -> tuple[str | None, bool, str | None]:
    """The preset whose limits a road scenario is held to or compared with.

    Parameters
    ----------
    scenario : Path
        A road scenario file ``<name>[-design|-operational].toml``.

    Returns
    -------
    tuple
        (preset, operational, via): the scenario's own ``vehicle.preset`` and ``vehicle.operational``; for
        a vehicle without a preset the preset of ``<name>-operational.toml`` beside it (``via`` its stem,
        ``operational`` False); (None, False, None) where neither names one.
    """
    import tomllib

    vehicle = tomllib.loads(scenario.read_text()).get("vehicle", {})
    if vehicle.get("preset"):
        return str(vehicle["preset"]), bool(vehicle.get("operational", False)), None
    base = scenario.stem.removesuffix(DESIGN_SUFFIX).removesuffix(OPERATIONAL_SUFFIX)
    sibling = scenario.parent / f"{base}{OPERATIONAL_SUFFIX}.toml"
    if sibling.exists():
        other = tomllib.loads(sibling.read_text()).get("vehicle", {}).get("preset")
        if other:
            return str(other), False, sibling.stem
    return None, False, None


def road_limits_note(scenario: Path, summary: Mapping) -> str:
    """``limits_note`` of a solved road scenario, its numbers read from its ``summary.json`` and the preset.

    A vehicle without a preset is compared with the preset of its ``-operational`` sibling, and the note
    says so; without either it gives the largest lateral acceleration only.
    """
    lateral, longitudinal = summary.get("lateral_acceleration") or {}, summary.get("longitudinal") or {}
    valid = bool(summary.get("valid"))
    max_lat = lateral.get("max_abs_nodes") if valid else None
    accel = (longitudinal.get("min_acceleration"), longitudinal.get("max_acceleration")) if valid else None
    preset_name, operational, via = reference_preset(scenario)
    if preset_name is None:
        lat = "not measured" if max_lat is None else f"{max_lat:.2f} m/s^2"
        return (
            f"kinematic model without operational limits: max lateral acceleration {lat} (no preset's limits "
            "to compare with)"
        )
    note = limits_note(preset_name, operational, max_lat, accel if longitudinal else None)
    if via:
        note += f" (compared with the {preset_name} of {via}, the same route; this vehicle is not that preset)"
    return note


def road_limits_cell(scenario: Path, summary: Mapping) -> str:
    """``limits_cell`` of a solved road scenario (``road_limits_note`` in a table cell's length)."""
    lateral, longitudinal = summary.get("lateral_acceleration") or {}, summary.get("longitudinal") or {}
    valid = bool(summary.get("valid"))
    max_lat = lateral.get("max_abs_nodes") if valid else None
    accel = (longitudinal.get("min_acceleration"), longitudinal.get("max_acceleration")) if valid else None
    preset_name, operational, _ = reference_preset(scenario)
    if preset_name is None:
        return "none" if max_lat is None else f"none: a_lat {max_lat:.2f}"
    return limits_cell(preset_name, operational, max_lat, accel if longitudinal else None)


def cell_document(template: dict, preset_name: str, icd: float, apron: float, intervals: int,
                  operational: bool = False) -> dict:  # fmt: skip
    """One cell's scenario document: the template with the preset, ICD, apron and N set.

    The legs' curb fillet radii scale with the ICD (the template gives them at its own ICD). The
    template's ``bounds.phi`` stays only for a preset without a steering limit, and
    ``bounds.articulation`` only for an articulated vehicle; ``apron_use`` is "trailer" for an
    articulated vehicle (its tractor stays on the roadway), "none" for the passenger car P and
    "all" for a single-unit truck. With ``operational`` the vehicle runs at the preset's
    operational limits (``operational_document``).
    """
    from model.vehicles import VEHICLES, preset

    data = preset(preset_name)
    roles = VEHICLES[data["model"]].roles
    doc = copy.deepcopy(template)
    doc["vehicle"] = {"preset": preset_name}
    if operational:
        operational_document(doc, preset_name)
    bounds = doc.setdefault("bounds", {})
    if roles.steering in data.get("bounds", {}):
        bounds.pop(roles.steering, None)
    articulated = bool(roles.trailers)
    if not articulated:
        bounds.pop("articulation", None)
    rb = doc["roundabout"]
    scale = float(icd) / float(rb["inscribed_diameter"])
    for leg in rb["legs"]:  # curb fillets in proportion to the size (the template's at its own ICD)
        leg["entry_radius"] = float(leg["entry_radius"]) * scale
        leg["exit_radius"] = float(leg["exit_radius"]) * scale
    rb["inscribed_diameter"] = float(icd)
    rb["apron_width"] = float(apron)
    rb["apron_use"] = "trailer" if articulated else ("none" if preset_name == "P" else "all")
    doc["problem"] = {**doc.get("problem", {}), "objective": "time", "intervals": int(intervals)}
    doc.pop("title", None)
    doc["name"] = cell_name(preset_name, icd, apron)
    doc["title"] = f"{preset_name} turns left through a {icd:g} m roundabout" + (
        f" with a {apron:g} m apron" if apron > 0 else " without an apron"
    )
    return doc


def cell_name(preset_name: str, icd: float, apron: float) -> str:
    """The cell's file-name key, e.g. ``WB-62_icd40_apron2``."""
    return f"{preset_name}_icd{icd:g}_apron{apron:g}"


def parse_cell(name: str) -> tuple[str, float, float]:
    """Inverse of ``cell_name``."""
    head, icd, apron = name.rsplit("_", 2)
    return head, float(icd.removeprefix("icd")), float(apron.removeprefix("apron"))


def apron_used(ocp: OCP, states: Mapping[str, np.ndarray]) -> float:
    """How far any body reaches inside the ring roadway's inner edge (onto the apron or beyond), m; 0 if not."""
    rb = ocp.road.roundabout
    from model.analysis.bodies import body_corners

    cols = _arrays(states)
    worst = 0.0
    for c in body_corners(ocp, cols).values():
        dist = rectangle_distance(c - np.asarray(rb.center), (0.0, 0.0))
        worst = max(worst, float(rb.inner_radius - np.min(dist)))
    return worst


def swept_width(ocp: OCP, states: Mapping[str, np.ndarray], trim_deg: float = 45.0, step_deg: float = 1.0) -> float:
    """The largest radial extent of the swept area (all bodies) on rays through the ring, m.

    Rays from the centre at angles from the entry leg's axis + ``trim_deg`` to the exit leg's axis
    - ``trim_deg``, turned in the circulation direction (the circulating part, clear of the entry
    and exit curves), each cut at the outer curb; on each ray the extent is the outermost minus
    the innermost swept point.
    """
    import shapely

    from model.analysis.bodies import swept_polygons
    from model.scene.roundabout import sweep

    rb, route = ocp.road.roundabout, ocp.road.route
    swept = shapely.union_all(list(swept_polygons(ocp, _arrays(states)).values()))
    start = rb.legs[route.enter].angle
    total = sweep(rb, route)
    trim = math.radians(trim_deg)
    if abs(total) <= 2 * trim:
        return math.nan
    sign = 1.0 if total > 0 else -1.0
    angles = start + sign * np.arange(trim, abs(total) - trim + 1e-9, math.radians(step_deg))
    cx, cy = rb.center
    widest = 0.0
    for a in angles:
        ray = shapely.LineString([(cx, cy), (cx + rb.outer_radius * math.cos(a), cy + rb.outer_radius * math.sin(a))])
        cut = ray.intersection(swept)
        if cut.is_empty:
            continue
        xy = shapely.get_coordinates(cut)
        r = np.hypot(xy[:, 0] - cx, xy[:, 1] - cy)
        widest = max(widest, float(r.max() - r.min()))
    return widest


def cell_measures(ocp: OCP, states: Mapping[str, np.ndarray]) -> dict:
    """Apron used and swept width of a solved cell (exact rectangles)."""
    return {"apron_used_m": apron_used(ocp, states), "swept_width_m": swept_width(ocp, states)}
