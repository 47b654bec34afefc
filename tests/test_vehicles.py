"""The vehicles layer: the tricycle and tractor-trailer models, bodies and their disc cover, presets."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from derivations.paper.checking import compare
from derivations.pmp import derive
from model import OCP, Energy, Time
from model.errors import InputError
from model.vehicles import PRESETS, VEHICLES, Body, TractorTrailer, Tricycle, Truck, preset, sym

FT = 0.3048
STATE = {"x": 1.0, "y": -2.0, "theta": 0.7, "phi": 0.3, "theta1": 0.4}
CONTROL = {"u1": 1.5, "u2": -0.2}


def numeric_rhs(vehicle, state=STATE, control=CONTROL) -> dict[str, float]:
    """The model's right-hand side evaluated at one point (parameters substituted)."""
    values = {sym(k): v for k, v in {**state, **control}.items()}
    return {s: float(e.subs(values)) for s, e in zip(vehicle.states, vehicle.rhs(numeric=True), strict=True)}


# -- right-hand sides, against values computed by hand (math module, see the formulas) -------------


def test_registry_names_the_contract_models():
    assert VEHICLES["tricycle"] is Tricycle and VEHICLES["tractor-trailer"] is TractorTrailer
    assert Tricycle().model == "tricycle" and TractorTrailer().model == "tractor-trailer"
    assert TractorTrailer.states == ("x", "y", "theta", "phi", "theta1")
    assert TractorTrailer.parameter_keys == {"d": "wheelbase", "h": "hitch_offset", "L": "trailer_wheelbase"}
    # the scenario parser takes a vehicle's dataclass fields as its [vehicle] keys
    assert {f.name for f in dataclasses.fields(TractorTrailer)} == {"wheelbase", "hitch_offset", "trailer_wheelbase"}


def test_tricycle_rhs_regression():
    # u1 cos(phi) cos(theta), u1 cos(phi) sin(theta), u1 sin(phi) / d, u2 with d = 2.5
    f = numeric_rhs(Tricycle(wheelbase=2.5))
    expected = {"x": 1.0960224749032688, "y": 0.9231669953374102, "theta": 0.1773121239968037, "phi": -0.2}
    assert f == pytest.approx(expected, rel=1e-14, abs=1e-15)


def test_tricycle_front_wheel_rolls_at_u1_along_theta_plus_phi():
    v = Tricycle(wheelbase=2.5)
    x, y, theta, phi = v.state_symbols()
    u1 = sym("u1")
    f = v.rhs(numeric=False)
    d = sym("d")
    front_velocity = sp.Matrix([f[0] - d * sp.sin(theta) * f[2], f[1] + d * sp.cos(theta) * f[2]])
    expected = u1 * sp.Matrix([sp.cos(theta + phi), sp.sin(theta + phi)])
    assert sp.simplify(sp.expand_trig(front_velocity - expected)) == sp.zeros(2, 1)


def test_tractor_trailer_rhs_regression():
    # the truck's four equations, and (u1 / L)(sin(b) + (h / d) tan(phi) cos(b)), b = theta - theta1
    f = numeric_rhs(TractorTrailer(wheelbase=3.8, hitch_offset=0.5, trailer_wheelbase=7.8))
    expected = {
        "x": 1.1472632809267327,
        "y": 0.9663265308565365,
        "theta": 0.12210641431958813,
        "phi": -0.2,
        "theta1": 0.0643085469961417,
    }
    assert f == pytest.approx(expected, rel=1e-14, abs=1e-15)
    behind = numeric_rhs(TractorTrailer(wheelbase=3.8, hitch_offset=-0.6, trailer_wheelbase=7.8))
    assert behind["theta1"] == pytest.approx(0.04785752334596591, rel=1e-14)


def test_tractor_is_the_truck():
    tt, truck = TractorTrailer(3.8, 0.5, 7.8), Truck(3.8)
    for state, expr in truck.dynamics().items():
        assert sp.simplify(tt.dynamics()[state] - expr) == 0, state


def test_on_axle_hitch_matches_commonroad_kst_hitch_angle():
    """CommonRoad's KST model writes the hitch angle alpha = theta1 - theta:
    alpha' = -v (sin(alpha) / l_wbt + tan(delta) / l_wb)."""
    tt = TractorTrailer(wheelbase=3.6, hitch_offset=0.0, trailer_wheelbase=8.1)
    f = numeric_rhs(tt)
    alpha = STATE["theta1"] - STATE["theta"]
    v, delta = CONTROL["u1"], STATE["phi"]
    assert f["theta1"] - f["theta"] == pytest.approx(-v * (math.sin(alpha) / 8.1 + math.tan(delta) / 3.6), rel=1e-13)


def test_hitch_offset_may_be_zero_or_negative_but_not_the_lengths():
    assert TractorTrailer.positive_parameters == ("d", "L")
    assert TractorTrailer(3.8, -0.4, 7.8).parameters() == {"d": 3.8, "h": -0.4, "L": 7.8}
    with pytest.raises(InputError) as err:
        OCP(vehicle=TractorTrailer(3.8, 0.5, -7.8), cost=Time(), final_time=2.0, bounds=BOUNDS, initial=START)
    assert err.value.key == "vehicle.trailer_wheelbase"


def test_ocp_accepts_an_on_axle_hitch():
    OCP(vehicle=TractorTrailer(3.8, 0.0, 7.8), cost=Time(), final_time=2.0, bounds=BOUNDS, initial=START)


# -- steady-state off-tracking of the trailer ---------------------------------------------------------


def steady_trailer_radius(h: float, R: float = 12.0, d: float = 3.8, L: float = 7.8, turn: int = 1) -> float:
    """Drive the model at u1 = 1 with phi fixed (rear-axle radius R) to steady state; the trailer axle's radius."""
    vehicle = TractorTrailer(wheelbase=d, hitch_offset=h, trailer_wheelbase=L)
    phi = turn * math.atan(d / R)
    args = [sym(s) for s in vehicle.states] + [sym("u1"), sym("u2")]
    f = sp.lambdify(args, vehicle.rhs(numeric=True), "math")
    sol = solve_ivp(
        lambda t, z: f(*z, 1.0, 0.0),
        (0.0, 50 * L),
        [0.0, 0.0, 0.0, phi, 0.0],
        rtol=1e-10,
        atol=1e-10,
        dense_output=True,
    )
    assert sol.success
    radii = []
    for t in (45 * L, 50 * L):  # two instants: the radius must have stopped changing
        x, y, theta, _, theta1 = sol.sol(t)
        centre = np.array([x, y]) + turn * R * np.array([-math.sin(theta), math.cos(theta)])
        hitch = np.array([x, y]) + h * np.array([math.cos(theta), math.sin(theta)])
        axle = hitch - L * np.array([math.cos(theta1), math.sin(theta1)])
        radii.append(float(np.hypot(*(axle - centre))))
    assert radii[0] == pytest.approx(radii[1], abs=1e-6)
    return radii[1]


def test_on_axle_offtracking_is_sqrt_R2_minus_L2():
    assert steady_trailer_radius(h=0.0) == pytest.approx(math.sqrt(12.0**2 - 7.8**2), abs=1e-3)


@pytest.mark.parametrize("h", [0.5, 1.5, -0.5, -1.5])
@pytest.mark.parametrize("turn", [1, -1])
def test_off_axle_offtracking_is_sqrt_R2_plus_h2_minus_L2_for_either_sign(h, turn):
    """The hitch runs on radius sqrt(R^2 + h^2) whether it is ahead of or behind the axle."""
    assert steady_trailer_radius(h=h, turn=turn) == pytest.approx(math.sqrt(12.0**2 + h**2 - 7.8**2), abs=1e-3)


# -- the Pontryagin engine takes the new systems unchanged --------------------------------------------

BOUNDS = {"u1": (-1.0, 1.0), "u2": (-0.5, 0.5)}
START = {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0, "theta1": 0.0}
GOAL = {"x": 10.0, "y": 2.0, "theta": 0.0}


def test_pmp_of_the_tractor_trailer():
    ocp = OCP(
        vehicle=TractorTrailer(3.8, 0.5, 7.8),
        cost=Time(),
        bounds=BOUNDS,
        initial=START,
        final=GOAL,
        final_time=20.0,
        name="TT",
    )
    system = derive(ocp)
    theta, phi, theta1 = sym("theta"), sym("phi"), sym("theta1")
    d, h, L, u1 = sym("d"), sym("h"), sym("L"), sym("u1")
    px, py, pth, pth1 = (system.costate_of(s) for s in ("x", "y", "theta", "theta1"))
    b = theta - theta1
    trailer = (
        pth1 * u1 / L * (sp.cos(b) - h / d * sp.tan(phi) * sp.sin(b))
    )  # -dH/dtheta1 = the theta1 part of dH/dtheta
    hand = {
        "x": 0,
        "theta": u1 * (px * sp.sin(theta) - py * sp.cos(theta)) - trailer,
        "phi": -u1 / sp.cos(phi) ** 2 * (pth / d + pth1 * h * sp.cos(b) / (L * d)),
        "theta1": trailer,
    }
    for state, expected in hand.items():
        assert compare(system.adjoint_of(state), expected).equal, state
    switching = (
        px * sp.cos(theta)
        + py * sp.sin(theta)
        + pth * sp.tan(phi) / d
        + pth1 / L * (sp.sin(b) + h / d * sp.tan(phi) * sp.cos(b))
    )
    assert system.law("u1").kind == "bang-singular" and compare(system.law("u1").switching, switching).equal
    assert [str(e.lhs) for e in system.transversality()] == ["p_phi(T_f)", "p_theta1(T_f)", "H(T_f)"]
    assert system.parameters[h] == 0.5


def test_pmp_of_the_tricycle():
    start = {k: v for k, v in START.items() if k != "theta1"}
    ocp = OCP(vehicle=Tricycle(2.5), cost=Energy(), bounds=BOUNDS, initial=start, final=GOAL, final_time=20.0)
    system = derive(ocp)
    theta, phi, d, u1 = sym("theta"), sym("phi"), sym("d"), sym("u1")
    px, py, pth = (system.costate_of(s) for s in ("x", "y", "theta"))
    hand = {
        "theta": u1 * sp.cos(phi) * (px * sp.sin(theta) - py * sp.cos(theta)),
        "phi": u1 * sp.sin(phi) * (px * sp.cos(theta) + py * sp.sin(theta)) - pth * u1 * sp.cos(phi) / d,
    }
    for state, expected in hand.items():
        assert compare(system.adjoint_of(state), expected).equal, state
    stationary = sp.cos(phi) * (px * sp.cos(theta) + py * sp.sin(theta)) + pth * sp.sin(phi) / d
    assert system.law("u1").kind == "projection" and compare(system.law("u1").stationary, stationary).equal


# -- bodies ---------------------------------------------------------------------------------------


def test_body_corners_and_overhangs():
    body = Body(length=8.0, width=2.5, rear_overhang=1.5)
    assert body.front_overhang(5.0) == pytest.approx(1.5)
    turned = body.corners(1.0, 2.0, math.pi / 2)  # heading +y: ahead is +y, left is -x
    assert turned == pytest.approx(np.array([[2.25, 0.5], [2.25, 8.5], [-0.25, 8.5], [-0.25, 0.5]]))
    nodes = np.linspace(0, 2 * math.pi, 7)
    many = body.corners(np.cos(nodes), np.sin(nodes), nodes)
    assert many.shape == (7, 4, 2)
    assert many[3] == pytest.approx(body.corners(math.cos(nodes[3]), math.sin(nodes[3]), nodes[3]))
    assert body.corners(np.zeros((2, 3)), 0.0, 0.0).shape == (2, 3, 4, 2)
    # edges keep their lengths under rotation
    edges = np.linalg.norm(np.diff(many, axis=-2, append=many[..., :1, :]), axis=-1)
    assert edges == pytest.approx(np.tile([8.0, 2.5, 8.0, 2.5], (7, 1)))


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(length=0.0, width=2.0, rear_overhang=0.0), "vehicle.body.length"),
        (dict(length=5.0, width=-1.0, rear_overhang=1.0), "vehicle.body.width"),
        (dict(length=5.0, width=2.0, rear_overhang=-0.1), "vehicle.body.rear_overhang"),
        (dict(length=5.0, width=2.0, rear_overhang=5.0), "vehicle.body.rear_overhang"),
        (dict(length=math.nan, width=2.0, rear_overhang=1.0), "vehicle.body.length"),
        (
            dict(length=5.0, width=2.0, rear_overhang=6.0, key="vehicle.trailer_body"),
            "vehicle.trailer_body.rear_overhang",
        ),
    ],
)
def test_body_checks_name_the_key(kwargs, key):
    with pytest.raises(InputError) as err:
        Body(**kwargs)
    assert err.value.key == key


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_disc_cover_contains_the_rectangle_with_the_least_radius(n):
    body = Body(length=13.6, width=2.55, rear_overhang=4.2)
    cover = body.cover(n)
    assert cover.radius == pytest.approx(math.sqrt((13.6 / (2 * n)) ** 2 + (2.55 / 2) ** 2), rel=1e-15)
    assert cover.offsets[0] == pytest.approx(-4.2 + 13.6 / (2 * n)) and len(cover.offsets) == n
    centres = np.column_stack([cover.offsets, np.zeros(n)])

    def covered(points, radius):
        return (np.linalg.norm(points[:, None, :] - centres[None], axis=-1) <= radius + 1e-12).any(axis=1)

    assert covered(body.outline(), cover.radius).all()
    gx, gy = np.meshgrid(np.linspace(-4.2, 9.4, 401), np.linspace(-1.275, 1.275, 41))
    assert covered(np.column_stack([gx.ravel(), gy.ravel()]), cover.radius).all()
    assert not covered(body.outline(), cover.radius * (1 - 1e-6)).all()  # exact: no smaller radius will do


def test_world_discs_follow_the_body():
    body = Body(length=8.0, width=2.5, rear_overhang=1.5)
    x, y, heading = np.array([0.0, 3.0]), np.array([1.0, -2.0]), np.array([0.3, -2.0])
    centres, radius = body.discs(x, y, heading, 4)
    assert centres.shape == (2, 4, 2)
    gap = np.linalg.norm(body.corners(x, y, heading)[:, :, None, :] - centres[:, None, :, :], axis=-1)
    assert (gap.min(axis=-1) <= radius + 1e-12).all()
    with pytest.raises(InputError, match="vehicle.body.discs"):
        body.cover(0)


# -- presets --------------------------------------------------------------------------------------


def build(p: dict) -> tuple:
    """The vehicle and bodies a preset describes (as the scenario parser would build them)."""
    cls = VEHICLES[p["model"]]
    vehicle = cls(**{f.name: p[f.name] for f in dataclasses.fields(cls)})
    bodies = [Body(**p["body"])]
    if "trailer_body" in p:
        bodies.append(Body(**p["trailer_body"], key="vehicle.trailer_body"))
    return vehicle, bodies


def overall_length(p: dict) -> float:
    """Front bumper of the tractor to the rear end of the trailer, straight ahead."""
    body = Body(**p["body"])
    if "trailer_body" not in p:
        return body.length
    return body.front - p["hitch_offset"] + p["trailer_wheelbase"] + p["trailer_body"]["rear_overhang"]


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_builds_a_vehicle_with_bodies(name):
    p = preset(name)
    vehicle, bodies = build(p)
    assert vehicle.model == p["model"] and len(bodies) == (2 if p["model"] == "tractor-trailer" else 1)
    assert p["source"] and set(p["bounds"]) <= set(vehicle.states) | set(vehicle.controls)
    for lo, hi in p["bounds"].values():
        assert lo < 0 < hi
    assert bodies[0].front_overhang(p["wheelbase"]) > 0


AASHTO_LENGTH_FT = [("P", 19.0), ("SU-30", 30.0), ("WB-40", 45.5), ("WB-62", 69.0), ("WB-67", 73.5)]  # Table 2-1a


@pytest.mark.parametrize("name, feet", AASHTO_LENGTH_FT)
def test_aashto_presets_close_to_the_published_overall_length(name, feet):
    assert overall_length(preset(name)) == pytest.approx(feet * FT, abs=1e-9)


@pytest.mark.parametrize("name, inside_ft", [("P", 14.4), ("SU-30", 28.3)])
def test_aashto_single_units_reproduce_the_minimum_inside_radius(name, inside_ft):
    """Table 2-2a: at full lock the rear axle runs on d / tan(phi_max); its inner side is width / 2 inside."""
    p = preset(name)
    inside = p["wheelbase"] / math.tan(p["bounds"]["phi"][1]) - p["body"]["width"] / 2
    assert inside / FT == pytest.approx(inside_ft, abs=0.05)


def test_aashto_wb62_steering_limit_is_the_template_angle():
    assert math.degrees(preset("WB-62")["bounds"]["phi"][1]) == pytest.approx(28.4, abs=0.05)


def test_eu_preset_meets_directive_96_53():
    p = preset("EU-semitrailer")
    tractor, trailer = p["body"], p["trailer_body"]
    kingpin_to_front = trailer["length"] - trailer["rear_overhang"] - p["trailer_wheelbase"]
    assert overall_length(p) == pytest.approx(16.50)
    assert p["trailer_wheelbase"] + trailer["rear_overhang"] == pytest.approx(12.00)
    assert math.hypot(kingpin_to_front, trailer["width"] / 2) <= 2.04
    assert tractor["width"] == trailer["width"] == 2.55
    # turning ring (Annex I 1.5): outer front corner on 12.50 m, steady state, trailer's inner side >= 5.30 m
    h, L, half = p["hitch_offset"], p["trailer_wheelbase"], 2.55 / 2
    front = Body(**tractor).front
    R = math.sqrt(12.50**2 - front**2) - half
    assert math.sqrt(R**2 + h**2 - L**2) - half >= 5.30


def test_commonroad_preset_matches_vehicle_4():
    p = preset("CommonRoad-4")
    assert (p["wheelbase"], p["hitch_offset"], p["trailer_wheelbase"]) == (3.6, 0.0, 8.1)
    assert p["bounds"]["phi"] == (-0.55, 0.55) and p["bounds"]["u2"] == (-0.7103, 0.7103)
    assert (p["body"]["length"], p["body"]["width"]) == (5.1, 2.55)
    assert (p["trailer_body"]["length"], p["trailer_body"]["width"]) == (13.6, 2.55)
    assert overall_length(p) == pytest.approx(16.5)  # l_total
    assert p["trailer_wheelbase"] + p["trailer_body"]["rear_overhang"] == pytest.approx(12.0)  # l_hitch


def test_preset_lookup_is_case_insensitive_and_returns_a_copy():
    p = preset("wb-62")
    p["body"]["length"] = -1.0
    assert preset("WB-62")["body"]["length"] > 0
    assert set(PRESETS) >= {"P", "SU-30", "WB-40", "WB-62", "WB-67", "EU-semitrailer", "CommonRoad-4"}


@pytest.mark.parametrize(
    "typo, suggestion", [("WB62", "WB-62"), ("wb-76", "WB-67"), ("comonroad-4", "CommonRoad-4"), ("SU30", "SU-30")]
)
def test_misspelt_preset_suggests_the_closest(typo, suggestion):
    with pytest.raises(InputError) as err:
        preset(typo)
    assert err.value.key == "vehicle.preset"
    assert err.value.message == f"unknown preset '{typo}' (did you mean '{suggestion}'?)"


def test_unknown_preset_without_a_close_name_lists_them():
    with pytest.raises(InputError, match="known: P, SU-30"):
        preset("zeppelin")


def test_expressions_are_never_parsed_from_strings():
    """No expression on the model's paths is parsed (model.vehicles.expression): a string (which
    SymPy's sympify would parse and evaluate) is refused, so no text from a scenario file can become code."""
    import pytest
    import sympy as sp

    from model.problem.closed_loop import Disturbance
    from model.simulation.plant import plant_rhs
    from model.vehicles import Truck

    truck = Truck(wheelbase=0.5)
    with pytest.raises(sp.SympifyError):
        truck.state_function(["__import__('os').getcwd()"])
    with pytest.raises(sp.SympifyError):
        truck.path_function(["__import__('os').getcwd()"])
    truck.dynamics = lambda: {name: "__import__('os').getcwd()" for name in truck.states}
    with pytest.raises(sp.SympifyError):
        plant_rhs(truck, Disturbance())
    with pytest.raises(AttributeError):  # a string has no .subs: reference_speed never parses one
        truck.reference_speed()
    from derivations.paper.checking import compare
    from model.vehicles import expression

    with pytest.raises(sp.SympifyError):
        compare("__import__('os').getcwd()", 0)
    assert expression(2) == sp.Integer(2) and expression(0.5) == sp.Float(0.5)
    with pytest.raises(sp.SympifyError):
        expression(True)


def test_reference_speed_is_the_simplified_norm_of_every_vehicle_model():
    import sympy as sp

    from model.vehicles import VEHICLES
    from model.vehicles.base import sym

    for cls in dict.fromkeys(VEHICLES.values()):
        vehicle = cls()
        f, r = vehicle.dynamics(), vehicle.roles
        others = {sym(c): 0 for c in vehicle.controls if c != r.speed}
        norm = sp.sqrt(f[r.x].subs(others) ** 2 + f[r.y].subs(others) ** 2).subs(sym(r.speed), 1)
        assert sp.simplify(vehicle.reference_speed() - norm) == 0, cls
    assert VEHICLES["truck"]().reference_speed() == 1
    assert VEHICLES["tricycle"]().reference_speed() == sp.Abs(sp.cos(sym("phi")))
