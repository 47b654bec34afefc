"""The Reeds-Shepp start of a vehicle with longitudinal dynamics is driven within its limits (issue 43)."""

from __future__ import annotations

import numpy as np
import pytest

from model.search.guess import reeds_shepp_guess, reeds_shepp_start_path, retimed
from model.search.multistart import reeds_shepp_starts
from model.search.paths import limited_path_guess, path_guess
from tests.test_longitudinal import _rest_ocp

PARKING = (0.0, 6.0, 0.0)  # parallel parking 6 m to the side: every word reverses
NO_REVERSING_WORD = (60.0, 10.0, 0.0)  # no word reverses into this goal or out of this start


@pytest.mark.parametrize("ends", [None, "reverse-in", "reverse-out"])
def test_a_longitudinal_vehicle_gets_the_limited_guess_and_its_time(ends):
    ocp = _rest_ocp(-3.0, PARKING, jerk=True)
    path = reeds_shepp_start_path(ocp, ends)
    expected, tf = limited_path_guess(ocp.vehicle, path, 60, ocp.bounds, ocp.initial, ocp.final)
    values, time = reeds_shepp_guess(ocp, 60, ends=ends)
    assert time == tf
    assert values.keys() == expected.keys()
    assert all(np.array_equal(values[k], expected[k]) for k in values)


def test_the_seed_model_keeps_the_constant_speed_guess():
    ocp = _rest_ocp(-3.0, PARKING, longitudinal=False)
    path = reeds_shepp_start_path(ocp)
    values, tf = reeds_shepp_guess(ocp, 60)
    assert tf == pytest.approx(path.length / (0.7 * ocp.max_speed()))
    expected = path_guess(ocp.vehicle, path, tf, 60, initial=ocp.initial, final=ocp.final)
    assert all(np.array_equal(values[k], expected[k]) for k in expected)


def test_a_stand_still_reversing_start_is_skipped_only_with_longitudinal_dynamics():
    for ends in ("reverse-in", "reverse-out"):
        longitudinal = _rest_ocp(-3.0, NO_REVERSING_WORD)
        assert reeds_shepp_start_path(longitudinal, ends) is None
        assert reeds_shepp_guess(longitudinal, 60, ends=ends) is None
        seed = _rest_ocp(-3.0, NO_REVERSING_WORD, longitudinal=False)
        assert reeds_shepp_start_path(seed, ends).segments == ()  # the seed search's empty path, as before
    assert [r for _, r in reeds_shepp_starts(_rest_ocp(-3.0, NO_REVERSING_WORD))] == ["reeds-shepp"]


def test_a_path_the_speed_bound_forbids_is_no_start():
    ocp = _rest_ocp(0.0, PARKING)  # every word reverses; v >= 0
    assert reeds_shepp_start_path(ocp) is None and reeds_shepp_guess(ocp, 60) is None


def test_a_scaled_or_given_final_time_retimes_the_same_poses():
    ocp = _rest_ocp(-3.0, PARKING, jerk=True)
    values, tf = reeds_shepp_guess(ocp, 60)
    slow, slow_tf = reeds_shepp_guess(ocp, 60, tf_scale=2.0)
    assert slow_tf == pytest.approx(2.0 * tf)
    for name in ("x", "y", "theta", "phi"):
        assert np.array_equal(slow[name], values[name])
    assert np.allclose(slow["v"], values["v"] / 2) and np.allclose(slow["a"], values["a"] / 4)
    assert np.allclose(slow["j"], values["j"] / 8) and np.allclose(slow["u2"], values["u2"] / 2)
    t = np.linspace(0.0, slow_tf, 61)
    assert np.max(np.abs(np.gradient(slow["x"], t) - slow["v"] * np.cos(slow["theta"]))) < 0.05
    with pytest.raises(ValueError, match="stretch"):
        retimed(ocp, values, 0.0)
