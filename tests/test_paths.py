"""Reeds-Shepp and Dubins guess paths (model/search/paths.py): known lengths, properties, vehicle guesses."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from model.search.paths import (
    Path,
    dubins,
    min_turning_radius,
    path_guess,
    reeds_shepp,
    reeds_shepp_time,
    sample,
)
from model.vehicles import TractorTrailer, Tricycle, Truck, Unicycle

ORIGIN = (0.0, 0.0, 0.0)

# Shortest lengths from the origin at rho = 1, computed independently with OMPL 2.0.1
# (ompl.base.ReedsSheppStateSpace(1).distance, DubinsStateSpace(1).distance), one per family of words.
OMPL_REEDS_SHEPP = [
    ((1.2, -0.4, 0.0), "R+L+", 1.2870022175865685),
    ((-1.2, 1.2, 1.0), "L-R-L+", 2.8435131569409475),
    ((-0.9, -1.4, 3.0), "L+R-L+", 3.0),
    ((1.0, 1.9, 2.0), "L+S+L+", 2.4922812616419403),
    ((-3.9, 2.3, 0.5), "L-S-R-", 4.790823028614358),
    ((-1.6, -1.1, -1.0), "R-L-R+", 2.8786767854603506),
    ((-3.8, -0.3, -0.5), "R-S-L-", 3.848051035851353),
    ((0.3, -0.8, -0.5), "L-R+L+R-", 1.8485739182792917),
    ((0.7, 1.0, -1.0), "L+R+L-R-", 2.5071226242329203),
    ((1.6, -2.5, 1.5), "L+R-S-L-", 4.063279584621656),
    ((2.1, -3.4, 3.0), "L+R-S-R-", 5.080535511886588),
    ((-2.2, 1.5, -3.0), "L-S-L-R+", 3.775053248509632),
    ((3.3, 2.1, -1.0), "L+S+R+L-", 4.665732727496857),
    ((-1.1, 2.3, 0.5), "R+L-R-L+", 3.840641507567885),
    ((-2.6, 2.2, 3.0), "R-L+S+L+", 4.521061212712506),
    ((0.9, -3.0, -3.0), "R+S+R+L-", 4.166067908448829),
    ((1.7, -2.9, 0.0), "L-R+S+L+R-", 4.050845395339046),
    ((0.1, 3.5, 0.0), "R-L+S+R+L-", 4.973892270464237),
    ((0.0, 1.0, 0.0), "R+L-R-L+", 2.636232143305636),  # parallel parking: one radius sideways
    ((0.0, 0.0, math.pi), "L+R-L+", math.pi),  # turning round on the spot
]
OMPL_DUBINS = [
    ((-2.7, 3.3, -1.0), "L+S+L+", 8.677511055989031),
    ((1.2, -0.8, -2.0), "L+R+L+", 7.083006379180919),
    ((-0.9, -3.9, 0.0), "R+S+L+", 7.189286455547462),
    ((3.7, -3.6, -3.0), "R+S+R+", 6.906117120368343),
    ((2.4, -0.1, -3.0), "L+S+R+", 6.128626584931901),
    ((0.5, 2.0, 2.0), "R+L+R+", 5.854220552282294),
    ((0.0, 1.0, 0.0), None, 2.0 * math.pi + 1.0),  # a tie: a full circle each way plus the shift
    ((-3.0, 0.0, 0.0), None, 2.0 * math.pi + 3.0),  # a tie: turn round, drive back 3, turn round
]

coord = st.floats(-10.0, 10.0, allow_nan=False)
angle = st.floats(-7.0, 7.0, allow_nan=False)
poses = st.tuples(coord, coord, angle)
radii = st.floats(0.2, 3.0)


def angle_gap(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2.0 * math.pi))


def assert_reaches(path: Path, goal, tol: float = 1e-6) -> None:
    end = sample(path, 7)
    assert abs(end["x"][-1] - goal[0]) < tol and abs(end["y"][-1] - goal[1]) < tol
    assert angle_gap(end["theta"][-1], goal[2]) < tol


def flipped(pose):
    return pose[0], pose[1], pose[2] + math.pi


# Rounding moves a pose by ~1e-15 and a sideways step e costs about sqrt(rho e): lengths of
# poses computed two ways are compared to NOISE. The Dubins length even jumps by up to 2 pi rho
# where a segment of the shortest word shrinks to 0 (a goal just off a pure arc or straight
# needs a loop): such cases are compared only when ``dubins_stable``.
NOISE = 1e-6


def dubins_stable(a, b, *paths: Path) -> bool:
    """The poses are apart and no path has a vanishing segment: the Dubins length is continuous there."""
    apart = math.hypot(b[0] - a[0], b[1] - a[1]) > 1e-3
    return apart and all(len(p.segments) == 3 and min(abs(seg) for _, seg in p.segments) > 1e-6 for p in paths)


# -- known lengths ----------------------------------------------------------------------------


@pytest.mark.parametrize("planner", [reeds_shepp, dubins])
def test_straight_ahead_is_the_distance(planner):
    start, goal = (1.0, 2.0, 0.6), (1.0 + 5.0 * math.cos(0.6), 2.0 + 5.0 * math.sin(0.6), 0.6)
    path = planner(start, goal, 0.7)
    assert path.word == "S+"
    assert path.length == pytest.approx(5.0, abs=1e-12)


def test_straight_behind_is_reversing_for_reeds_shepp():
    path = reeds_shepp(ORIGIN, (-4.0, 0.0, 0.0), 1.5)
    assert path.word == "S-" and path.length == pytest.approx(4.0, abs=1e-12)


@pytest.mark.parametrize("a", [0.1, 1.0, 2.0, math.pi - 1e-3])
@pytest.mark.parametrize("rho", [0.5, 2.0])
def test_a_turn_on_the_circle_is_rho_times_the_angle(a, rho):
    for side, word in ((1.0, "L"), (-1.0, "R")):
        goal = (rho * math.sin(a), side * rho * (1.0 - math.cos(a)), side * a)
        assert reeds_shepp(ORIGIN, goal, rho).word == word + "+"
        assert reeds_shepp(ORIGIN, goal, rho).length == pytest.approx(rho * a, rel=1e-12)
        assert dubins(ORIGIN, goal, rho).length == pytest.approx(rho * a, rel=1e-12)
        behind = (-goal[0], goal[1], -goal[2])  # the same arc driven backwards
        assert reeds_shepp(ORIGIN, behind, rho).word == word + "-"
        assert reeds_shepp(ORIGIN, behind, rho).length == pytest.approx(rho * a, rel=1e-12)


@pytest.mark.parametrize(("goal", "word", "length"), OMPL_REEDS_SHEPP)
def test_reeds_shepp_lengths_agree_with_ompl(goal, word, length):
    for rho in (1.0, 2.5):
        scaled = (rho * goal[0], rho * goal[1], goal[2])
        path = reeds_shepp(ORIGIN, scaled, rho)
        assert path.length == pytest.approx(rho * length, rel=1e-12, abs=1e-12)
        assert_reaches(path, scaled, 1e-9)
    assert reeds_shepp(ORIGIN, goal, 1.0).word == word


@pytest.mark.parametrize(("goal", "word", "length"), OMPL_DUBINS)
def test_dubins_lengths_agree_with_ompl(goal, word, length):
    path = dubins(ORIGIN, goal, 1.0)
    assert path.length == pytest.approx(length, rel=1e-12)
    assert word is None or path.word == word
    assert_reaches(path, goal, 1e-9)


def test_turning_round_on_the_spot_is_three_arcs_of_sixty_degrees():
    """An explicit L+R-L+ of pi/3 each ends where it began, heading reversed: length pi rho, the shortest."""
    third = math.pi / 3.0
    manual = Path(ORIGIN, 2.0, (("L", 2.0 * third), ("R", -2.0 * third), ("L", 2.0 * third)))
    assert np.allclose(manual.goal, (0.0, 0.0, math.pi), atol=1e-12)
    assert reeds_shepp(ORIGIN, (0.0, 0.0, math.pi), 2.0).length == pytest.approx(manual.length, rel=1e-12)


def test_same_pose_is_the_empty_path():
    for planner in (reeds_shepp, dubins):
        path = planner((1.0, 2.0, 0.3), (1.0, 2.0, 0.3 + 2.0 * math.pi), 1.0)
        assert path.segments == () and path.length == 0.0
        assert sample(path, 4)["x"].tolist() == [1.0] * 5


def test_bad_radius_is_refused():
    with pytest.raises(ValueError, match="rho"):
        reeds_shepp(ORIGIN, (1.0, 0.0, 0.0), 0.0)


# -- properties on random poses ---------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(poses, poses, radii)
def test_reeds_shepp_properties(a, b, rho):
    path = reeds_shepp(a, b, rho)
    length = path.length
    assert_reaches(path, b)
    assert len(path.segments) <= 5 and path.cusps <= 2
    tol = 1e-9 * (1.0 + length)
    assert reeds_shepp(b, a, rho).length == pytest.approx(length, abs=NOISE)  # swap start and goal
    assert reeds_shepp(flipped(a), flipped(b), rho).length == pytest.approx(length, abs=NOISE)  # drive it reversed
    assert length <= dubins(a, b, rho).length + tol
    assert length >= math.hypot(b[0] - a[0], b[1] - a[1]) - tol
    assert length >= rho * angle_gap(a[2], b[2]) - tol  # every radian of heading costs rho metres


@settings(max_examples=300, deadline=None)
@given(poses, poses, radii)
def test_dubins_properties(a, b, rho):
    path = dubins(a, b, rho)
    assert_reaches(path, b)
    assert len(path.segments) <= 3 and all(seg > 0 for _, seg in path.segments)
    tol = 1e-9 * (1.0 + path.length)
    back = dubins(flipped(b), flipped(a), rho)  # swapped and driven reversed
    if dubins_stable(a, b, path, back):
        assert back.length == pytest.approx(path.length, abs=NOISE)
    assert path.length >= math.hypot(b[0] - a[0], b[1] - a[1]) - tol


@settings(max_examples=200, deadline=None)
@given(poses, poses, poses, radii)
def test_triangle_inequality(a, b, c, rho):
    """The shortest length through any third pose is no shorter: a check of optimality independent of the formulas."""
    for planner in (reeds_shepp, dubins):
        assert planner(a, c, rho).length <= planner(a, b, rho).length + planner(b, c, rho).length + NOISE


@settings(max_examples=100, deadline=None)
@given(poses, poses, radii, st.floats(-math.pi, math.pi), st.floats(0.25, 4.0))
def test_lengths_move_and_scale_with_the_poses(a, b, rho, turn, scale):
    """Rigid motions keep the length; scaling lengths and rho together scales it (up to NOISE)."""
    c, s = math.cos(turn), math.sin(turn)

    def moved(p):
        return c * p[0] - s * p[1] + 3.0, s * p[0] + c * p[1] - 1.0, p[2] + turn

    for planner in (reeds_shepp, dubins):
        path = planner(a, b, rho)
        other = planner(moved(a), moved(b), rho)
        big = planner((scale * a[0], scale * a[1], a[2]), (scale * b[0], scale * b[1], b[2]), scale * rho)
        if planner is dubins and not dubins_stable(a, b, path, other, big):
            continue
        assert other.length == pytest.approx(path.length, rel=1e-9, abs=NOISE)
        assert big.length == pytest.approx(scale * path.length, rel=1e-9, abs=NOISE)


# -- sampling ---------------------------------------------------------------------------------


def test_sample_steps_equally_and_follows_its_own_curvature():
    path = reeds_shepp((0.5, -1.0, 0.2), (0.7, 1.3, -0.3), 1.0)  # parallel-parking-like: cusps, arcs
    assert path.cusps >= 1
    n = 2000
    smp = sample(path, n)
    assert set(smp) == {"s", "s_signed", "x", "y", "theta", "kappa", "direction"}
    assert all(v.shape == (n + 1,) for v in smp.values())
    assert np.allclose(np.diff(smp["s"]), path.length / n)
    assert (smp["s"][0], smp["s"][-1]) == (0.0, pytest.approx(path.length))
    assert set(np.unique(smp["direction"])) == {-1.0, 1.0}
    assert set(np.round(np.unique(smp["kappa"]), 12)) <= {-1.0, 0.0, 1.0}
    same = smp["direction"][1:] == smp["direction"][:-1]  # steps that cross no cusp
    assert np.allclose(np.diff(smp["s_signed"])[same], smp["direction"][1:][same] * path.length / n)
    assert smp["s_signed"][-1] == pytest.approx(sum(seg for _, seg in path.segments))
    # inside each segment: dx/ds = dir cos(theta), dy/ds = dir sin(theta), dtheta/ds = dir kappa
    same = (np.diff(smp["kappa"])[:-1] == 0) & (np.diff(smp["kappa"])[1:] == 0)
    same &= (np.diff(smp["direction"])[:-1] == 0) & (np.diff(smp["direction"])[1:] == 0)
    inner = np.flatnonzero(same) + 1
    ds, sgn = path.length / n, smp["direction"][inner]
    for name, rate in (("x", np.cos(smp["theta"])), ("y", np.sin(smp["theta"])), ("theta", smp["kappa"])):
        slope = (smp[name][inner + 1] - smp[name][inner - 1]) / (2.0 * ds)
        assert np.allclose(slope, sgn * rate[inner], atol=1e-5), name
    assert np.max(np.abs(np.diff(smp["theta"]))) < 2.0 * ds  # continuous: no 2 pi jumps


def test_sample_refuses_no_steps():
    with pytest.raises(ValueError, match="n must be"):
        sample(reeds_shepp(ORIGIN, (1.0, 0.0, 0.0), 1.0), 0)


# -- vehicle guesses --------------------------------------------------------------------------

VEHICLES = [Truck(wheelbase=0.4), Tricycle(wheelbase=0.4), Unicycle(), TractorTrailer(0.4, 0.1, 0.8)]


def state_rates(vehicle, guess: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The project's own dynamics evaluated on the guess, by state."""
    args = [sp.Symbol(n, real=True) for n in (*vehicle.states, *vehicle.controls)]
    rates = sp.lambdify(args, vehicle.rhs(numeric=True), modules="numpy")(*(guess[a.name] for a in args))
    return {s: np.broadcast_to(r, guess[s].shape) for s, r in zip(vehicle.states, rates, strict=True)}


@pytest.mark.parametrize("vehicle", VEHICLES, ids=lambda v: v.model)
def test_path_guess_satisfies_the_dynamics(vehicle):
    start, goal = (0.0, 0.0, 0.3), (0.4, 1.6, 2.5)
    rho, tf, n = 1.2, 8.0, 3000
    path = reeds_shepp(start, goal, rho)
    guess = path_guess(vehicle, path, tf, n, initial={"theta1": 0.2})
    assert list(guess) == [*vehicle.states, *vehicle.controls]
    assert all(v.shape == (n + 1,) for v in guess.values())
    assert (guess["x"][0], guess["y"][0], guess["theta"][0]) == pytest.approx(start)
    assert (guess["x"][-1], guess["y"][-1]) == pytest.approx(goal[:2], abs=1e-9)
    assert angle_gap(guess["theta"][-1], goal[2]) < 1e-9
    smp = sample(path, n)
    assert np.allclose(np.abs(guess["u1"] * np.cos(guess.get("phi", 0.0)) if vehicle.model == "tricycle"
                              else np.abs(guess["u1"])), path.length / tf)  # fmt: skip
    t = np.linspace(0.0, tf, n + 1)
    rates = state_rates(vehicle, guess)
    smooth = (np.diff(smp["kappa"])[:-1] == 0) & (np.diff(smp["kappa"])[1:] == 0)
    smooth &= (np.diff(smp["direction"])[:-1] == 0) & (np.diff(smp["direction"])[1:] == 0)
    inner = np.flatnonzero(smooth) + 1
    for name in vehicle.states:
        slope = (guess[name][inner + 1] - guess[name][inner - 1]) / (t[inner + 1] - t[inner - 1])
        assert np.allclose(slope, rates[name][inner], atol=1e-4), name


def test_truck_steers_atan_d_kappa_and_u2_is_the_steering_rate():
    truck = Truck(wheelbase=0.5)
    path = reeds_shepp(ORIGIN, (2.0, 3.0, 1.0), 1.0)
    guess = path_guess(truck, path, 5.0, 400)
    kappa = sample(path, 400)["kappa"]
    assert np.allclose(guess["phi"], np.arctan(0.5 * kappa))
    assert np.allclose(guess["u2"], np.gradient(guess["phi"], np.linspace(0.0, 5.0, 401)))


def test_unicycle_turn_rate_is_speed_times_curvature():
    path = reeds_shepp(ORIGIN, (-1.0, 2.0, 2.0), 0.8)
    guess = path_guess(Unicycle(), path, 4.0, 300)
    smp = sample(path, 300)
    assert np.allclose(guess["u1"], smp["direction"] * path.length / 4.0)
    assert np.allclose(guess["u2"], guess["u1"] * smp["kappa"])


@pytest.mark.parametrize(("goal", "sign"), [((6.0, 0.0, 0.0), 1.0), ((-6.0, 0.0, 0.0), -1.0)])
def test_trailer_angle_on_a_straight_has_the_closed_form(goal, sign):
    """On a straight b = theta - theta1 obeys db/ds = -dir sin(b) / L: tan(b/2) = tan(b0/2) exp(-dir s / L)."""
    vehicle = TractorTrailer(wheelbase=1.0, hitch_offset=0.3, trailer_wheelbase=2.0)
    path = reeds_shepp(ORIGIN, goal, 1.0)
    guess = path_guess(vehicle, path, 3.0, 60, initial={"theta1": -0.4})
    s = np.linspace(0.0, 6.0, 61)
    b = 2.0 * np.arctan(math.tan(0.2) * np.exp(-sign * s / 2.0))
    assert np.allclose(guess["theta1"], -b, atol=1e-7)


def test_trailer_starts_aligned_by_default_and_steady_turn_angle():
    """Driving forwards round a long circle the trailer settles at sin(b) + h kappa cos(b) = L kappa."""
    vehicle = TractorTrailer(wheelbase=1.0, hitch_offset=0.3, trailer_wheelbase=1.5)
    rho = 2.0
    path = Path(ORIGIN, rho, (("L", 60.0),))  # nearly five times round: the transient dies out
    guess = path_guess(vehicle, path, 10.0, 1000)
    assert guess["theta1"][0] == 0.0
    b = guess["theta"][-1] - guess["theta1"][-1]
    k = 1.0 / rho
    assert math.sin(b) + 0.3 * k * math.cos(b) == pytest.approx(1.5 * k, abs=1e-6)


def test_path_guess_needs_the_states_the_path_does_not_fix():
    class Odd(Unicycle):
        states = ("x", "y", "theta", "mass")

        def dynamics(self):  # the unicycle's, and a constant mass (the speed control is read off the dynamics)
            return {**Unicycle().dynamics(), "mass": sp.Integer(0)}

    path = reeds_shepp(ORIGIN, (1.0, 0.0, 0.0), 1.0)
    with pytest.raises(ValueError, match="mass"):
        path_guess(Odd(), path, 1.0, 4)
    assert path_guess(Odd(), path, 1.0, 4, initial={"mass": 2.0})["mass"].tolist() == [2.0] * 5


# -- turning radius and the time bound --------------------------------------------------------


def test_min_turning_radius():
    phi = (-0.5, 0.6)
    assert min_turning_radius(Truck(wheelbase=2.0), {"phi": phi}) == pytest.approx(2.0 / math.tan(0.6))
    assert min_turning_radius(Truck(wheelbase=2.0), {"phi": phi}, both_ways=True) == pytest.approx(2.0 / math.tan(0.5))
    assert min_turning_radius(TractorTrailer(3.0, 0.5, 7.0), {"phi": phi}) == pytest.approx(3.0 / math.tan(0.6))
    assert min_turning_radius(Tricycle(wheelbase=2.0), {"phi": phi}) == pytest.approx(2.0 / math.tan(0.6))
    assert min_turning_radius(Truck(), {"u1": (-1, 1)}) is None  # phi free: any radius
    assert min_turning_radius(Truck(), {"phi": (-2.0, 2.0)}) is None
    assert min_turning_radius(Truck(), {"phi": (0.0, 0.5)}, both_ways=True) == math.inf
    assert min_turning_radius(Unicycle(), {"u1": (-1.0, 1.0), "u2": (-2.0, 2.0)}) is None  # turns on the spot
    assert min_turning_radius(Unicycle(), {"u1": (0.5, 1.0), "u2": (-2.0, 2.0)}) == pytest.approx(0.25)
    assert min_turning_radius(Unicycle(), {"u2/u1": (-4.0, 4.0)}) == pytest.approx(0.25)


def test_tricycle_rear_axle_turns_on_d_over_tan_phi():
    """Holding phi at its bound, the tricycle's reference point (the rear axle) circles at d / tan(phi)."""
    d, phi = 2.0, 0.6
    radius = min_turning_radius(Tricycle(wheelbase=d), {"phi": (-phi, phi)})
    theta = np.linspace(0.0, 1.0, 11)  # x' = u cos(phi) cos(theta), theta' = u sin(phi) / d
    x = d / math.tan(phi) * np.sin(theta)  # integral of cos(phi) cos(theta) d theta / (sin(phi) / d)
    assert radius == pytest.approx(x[-1] / math.sin(theta[-1]))


def test_reeds_shepp_time_is_length_over_top_speed():
    start, goal = (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    assert reeds_shepp_time(start, goal, 1.0, 2.0) == pytest.approx(2.636232143305636 / 2.0)
    assert reeds_shepp_time(start, goal, None, 2.0) == pytest.approx(0.5)
    assert reeds_shepp_time(start, (3.0, 0.0, 0.0), math.inf, 1.5) == pytest.approx(2.0)
    assert reeds_shepp_time(start, goal, math.inf, 1.5) == math.inf
    times = [reeds_shepp_time(start, (1.0, 2.0, 2.5), rho, 1.0) for rho in (0.25, 0.5, 1.0, 2.0)]
    assert times == sorted(times)  # a tighter radius never makes it shorter
    with pytest.raises(ValueError, match="u1max"):
        reeds_shepp_time(start, goal, 1.0, 0.0)


def test_reeds_shepp_restricted_to_reverse_into_the_goal_or_out_of_the_start():
    from model.search.paths import reeds_shepp

    start, goal = (0.0, 0.0, 0.0), (3.0, 1.0, 0.5)
    shortest = reeds_shepp(start, goal, 1.0)
    for ends, index in (("reverse-in", -1), ("reverse-out", 0)):
        path = reeds_shepp(start, goal, 1.0, ends)
        assert path.segments[index][1] < 0  # drives backwards at that end
        assert path.length >= shortest.length - 1e-12
        assert np.allclose(path.goal[:2], goal[:2]) and math.isclose(
            math.remainder(path.goal[2] - goal[2], math.tau), 0.0, abs_tol=1e-9
        )
