"""The presets' operational limits (model.vehicles.operational_limits): invariants, sources, cross-checks."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from model.errors import InputError
from model.vehicles import PRESETS, OperationalLimits, operational_limits, preset

G = 9.80665
DOCS = Path(__file__).resolve().parents[1] / "docs" / "dynamics-format.md"
NUMBER_FIELDS = [f.name for f in dataclasses.fields(OperationalLimits) if f.name != "sources"]
SEMITRAILERS = ("WB-40", "WB-62", "WB-67", "EU-semitrailer", "CommonRoad-4")


def limits(name: str) -> OperationalLimits:
    lim = operational_limits(name)
    assert lim is not None, f"{name} has no operational limits"
    return lim


@pytest.mark.parametrize("name", PRESETS)
def test_limits_are_ordered_and_finite(name):
    lim = limits(name)
    for lo, hi in (lim.acceleration, lim.jerk):
        assert math.isfinite(lo) and math.isfinite(hi)
        assert lo < 0.0 < hi
    assert 0.0 < lim.lateral_acceleration < lim.rollover_threshold
    assert 0.0 < lim.crawl_speed < lim.speed
    assert lim.steering_rate > 0.0


@pytest.mark.parametrize("name", PRESETS)
def test_every_field_has_a_source(name):
    sources = limits(name).sources
    assert set(sources) == set(NUMBER_FIELDS)
    assert all(isinstance(text, str) and len(text) > 10 for text in sources.values())


@pytest.mark.parametrize("name", PRESETS)
def test_physically_sensible(name):
    """The ranges the cited sources give (SUMO, AASHTO, Jarvis 1989, UMTRI-99-19)."""
    lim = limits(name)
    lo, hi = lim.acceleration
    if name == "P":
        assert hi == pytest.approx(2.6) and lo == pytest.approx(-3.4)  # SUMO passenger, AASHTO SSD
    else:
        assert 0.5 <= hi <= 1.3  # SUMO truck 1.3, trailer 1.0
        assert -3.0 <= lo <= -2.0  # a truck's comfortable braking
        assert 1.5 <= lim.lateral_acceleration <= 2.0
        assert lim.lateral_acceleration <= 0.5 * lim.rollover_threshold
    if name in SEMITRAILERS:
        assert 0.25 * G <= lim.rollover_threshold <= 0.40 * G
    assert lim.crawl_speed <= 15.0 / 3.6 + 1e-12  # AASHTO design turns


@pytest.mark.parametrize("name", [n for n in PRESETS if "phi" in preset(n)["bounds"]])
def test_a_full_lock_turn_at_crawl_speed_keeps_the_lateral_bound(name):
    """The rear axle's a_lat = v^2 tan(phi_max) / d (docs/scenario-format.md) at crawl speed and full lock.

    EU-semitrailer has no steering bound in its preset and is not checked.
    """
    p, lim = preset(name), limits(name)
    a_lat = lim.crawl_speed**2 * math.tan(p["bounds"]["phi"][1]) / p["wheelbase"]
    assert a_lat < lim.lateral_acceleration


def test_quoted_full_lock_values_at_15_kmh():
    """The crawl speed's source quotes a_lat at full lock and 15 km/h; they are recomputed here."""
    text = limits("P").sources["crawl_speed"]
    for name, label in (("P", "P"), ("WB-40", "WB-40"), ("WB-62", "WB-62/67"), ("CommonRoad-4", "CommonRoad-4")):
        p = preset(name)
        a_lat = (15.0 / 3.6) ** 2 * math.tan(p["bounds"]["phi"][1]) / p["wheelbase"]
        assert f"{label} {a_lat:.2f}" in text
        assert a_lat > limits(name).lateral_acceleration


def test_commonroad_4_matches_its_source():
    vehiclemodels = pytest.importorskip("vehiclemodels.parameters_vehicle4")
    source = vehiclemodels.parameters_vehicle4()
    lim = limits("CommonRoad-4")
    assert lim.steering_rate == pytest.approx(source.steering.v_max)
    assert (-lim.steering_rate, lim.steering_rate) == pytest.approx(preset("CommonRoad-4")["bounds"]["u2"])
    assert lim.speed < source.longitudinal.v_max


def test_unknown_name_is_reported_as_preset_reports_it():
    with pytest.raises(InputError) as caught:
        operational_limits("WB-26")
    with pytest.raises(InputError) as expected:
        preset("WB-26")
    assert caught.value.key == "vehicle.preset"
    assert str(caught.value) == str(expected.value)
    assert "did you mean" in caught.value.message


def test_case_insensitive_and_a_fresh_copy():
    first = limits("eu-SEMITRAILER")
    assert first == limits("EU-semitrailer")
    first.sources["speed"] = "changed"
    assert limits("EU-semitrailer").sources["speed"] != "changed"
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.speed = 1.0  # type: ignore[misc]


def limits_table() -> list[str]:
    """The markdown rows docs/dynamics-format.md lists (its "Implementation notes")."""
    rows = []
    for name in PRESETS:
        lim = limits(name)
        rows.append(
            f"| {name} | {lim.acceleration[0]:.2f} .. {lim.acceleration[1]:.2f} | {lim.jerk[0]:.2f} .. "
            f"{lim.jerk[1]:.2f} | {lim.speed:.2f} | {lim.steering_rate:.4f} | {lim.rollover_threshold:.2f} "
            f"({lim.rollover_threshold / G:.2f} g) | {lim.lateral_acceleration:.2f} | {lim.crawl_speed:.2f} |"
        )
    return rows


def test_docs_table_matches_the_presets():
    text = DOCS.read_text(encoding="utf-8")
    for row in limits_table():
        assert row in text, f"docs/dynamics-format.md lacks the row {row}"
