"""The road figure and the road animation, drawn from a small synthetic trajectory (no solve)."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest
import shapely

matplotlib.use("Agg")

from PIL import Image  # noqa: E402

from model.analysis.bodies import body_corners, swept_polygons  # noqa: E402
from model.plotting.animation import frame_times, road_animation  # noqa: E402
from model.plotting.roads import (  # noqa: E402
    SCALE_BAR_GID,
    driving_label,
    nice_length,
    paved_area,
    road_figure,
    sign_changes,
)
from model.problem.scenario import load_scenario  # noqa: E402
from tests.conftest import ROOT  # noqa: E402

SEMITRAILER = ROOT / "workflows" / "roads" / "semitrailer-left-turn.toml"


@pytest.fixture(scope="module")
def ocp():
    return load_scenario(SEMITRAILER).ocp


@pytest.fixture(scope="module")
def columns():
    """A tractor-semitrailer entering the roundabout on its entry lane with a gentle left curve, 2 s."""
    t = np.linspace(0.0, 2.0, 21)
    theta = 0.15 * (t / 2.0) ** 2
    return {
        "t": t,
        "x": -50.0 + 10.0 * t,
        "y": -2.0 + 0.4 * t**2,
        "theta": theta,
        "phi": 0.05 * t,
        "theta1": 0.5 * theta,
        "u1": np.full_like(t, 10.0),
        "u2": np.full_like(t, 0.05),
    }


def test_the_envelope_contains_every_rectangle(ocp, columns):
    envelopes = swept_polygons(ocp, columns)
    assert set(envelopes) == {"vehicle", "trailer"}
    for name, corners in body_corners(ocp, columns).items():
        envelope = envelopes[name]
        assert envelope.area > ocp.bodies[name].length * ocp.bodies[name].width
        assert all(envelope.buffer(1e-6).contains(shapely.Polygon(c)) for c in corners)


def test_the_carriageway_has_no_slivers_or_slits(ocp):
    paved = paved_area(ocp.road.roundabout)
    assert paved.geom_type == "Polygon" and not paved.interiors
    assert paved.contains(shapely.Point(-40.0, 0.0))  # the leg's centre line lies inside, not on a slit


def test_the_figure_has_the_plan_with_a_scale_bar_and_five_time_panels(ocp, columns, tmp_path):
    fig = road_figure(ocp, columns, note="synthetic")
    plan, *panels = fig.axes
    assert [a.get_gid() for a in plan.artists] == [SCALE_BAR_GID]
    assert plan.get_aspect() == 1.0
    assert len(panels) == 5  # u1, u2, phi, lateral acceleration, articulation
    lateral = panels[3].lines[0].get_ydata()  # u1^2 tan(phi) / d of the tractor, m/s^2
    assert lateral == pytest.approx(columns["u1"] ** 2 * np.tan(columns["phi"]) / ocp.vehicle.wheelbase)
    limits = [line.get_ydata()[0] for line in panels[-1].lines[1:]]  # the articulation bounds, degrees
    assert limits == pytest.approx([-np.degrees(1.2), np.degrees(1.2)])
    fig.savefig(tmp_path / "road.png", dpi=50)
    assert np.asarray(Image.open(tmp_path / "road.png").convert("L"), float).std() > 10


@pytest.mark.parametrize(("span", "length"), [(3.0, 1.0), (60.0, 10.0), (116.0, 20.0), (140.0, 25.0)])
def test_the_scale_bar_takes_a_round_length(span, length):
    assert nice_length(span) == length


def test_the_gif_has_one_frame_per_time_and_holds_the_last(ocp, columns, tmp_path):
    fps, duration, hold, dpi = 5.0, 1.0, 1.0, 40.0
    path = road_animation(ocp, columns, tmp_path / "turn.gif", fps=fps, duration=duration, hold=hold, dpi=dpi)
    times = frame_times(columns["t"][-1], fps, duration)
    with Image.open(path) as gif:
        assert gif.size == (round(5.6 * dpi), round(5.6 * dpi))
        assert gif.n_frames == len(times) == 5  # the held copies of the last frame merge into it
        durations = []
        for k in range(gif.n_frames):
            gif.seek(k)
            durations.append(gif.info["duration"])
    assert sum(durations) == pytest.approx(1000 * (duration + hold), abs=60)
    assert path.stat().st_size < 3e6


def test_sign_changes_skip_values_near_zero():
    assert sign_changes(np.array([0.5, -0.5, 0.5, 0.0, 0.5, -1e-6, 0.5]), tol=1e-3) == 2
    assert sign_changes(np.array([0.0, 0.0]), tol=1e-3) == 0


def test_the_driving_label_reads_its_numbers_from_the_problem():
    plain = load_scenario(SEMITRAILER).ocp
    design = load_scenario(SEMITRAILER.with_name("semitrailer-left-turn-design.toml")).ocp
    assert driving_label(plain).startswith("time-optimal")
    label = driving_label(design, math=False)
    assert f"design speed {design.bounds['u1'][1] * 3.6:.0f} km/h" in label
    assert f"|a_lat| <= {design.bounds['lateral_acceleration'][1]:g} m/s^2" in label
    assert f"{design.cost.steering_weight:g} * integral of u2^2 dt" in label
