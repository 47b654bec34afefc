"""The paper's figure rules on small synthetic data: text at least 7 pt at print size, legends off the data,
the path at equal aspect with start, goal and direction marked (model.plotting.rules)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from model.plotting import figures as plotting
from model.plotting.results import Result
from model.plotting.rules import (
    MIN_FONT_PT,
    PRINT_WIDTH_IN,
    legends_on_data,
    narrowest_axes,
    print_scale,
    smallest_print_font,
)
from model.problem.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SOLVED = {"status": "optimal", "valid": True, "exit_code": 0, "final_time": 1.35, "energy": 0.69}


def synthetic_s3(n: int = 60) -> pd.DataFrame:
    """A smooth pass above the obstacle from (0, 0) to (1, 0), reversing for the first nodes."""
    t = np.linspace(0.0, 1.35, n)
    s = t / t[-1]
    u1 = np.where(s < 0.1, -0.5, 1.0)
    frame = {"t": t, "x": s, "y": 0.28 * np.sin(np.pi * s) ** 2, "theta": 0 * t, "phi": 0 * t, "u1": u1,
             "u2": 0.35 * np.sign(np.sin(6 * s)), "H": 1.5 + 0 * t, "mu": 0 * t}  # fmt: skip
    for name in ("x", "y", "theta", "phi"):
        frame[f"p_{name}"] = np.cos(3 * s + len(name))
    frame["psi_u1"], frame["psi_u2"] = frame["p_x"], frame["p_phi"]
    return pd.DataFrame(frame)


@pytest.fixture(scope="module")
def s3():
    ocp = load_scenario(ROOT / "workflows/scenarios/s3.toml").ocp
    return Result("s3", dict(SOLVED), synthetic_s3()), ocp


def close(fig) -> None:
    plotting.plt.close(fig)


def test_the_checks_fail_on_a_wide_figure_with_small_text_and_a_legend_on_its_line():
    plotting.apply_style()
    fig, ax = plotting.plt.subplots(figsize=(2 * PRINT_WIDTH_IN, 4))
    ax.plot([0, 1], [1, 1], label="a line under its legend")
    ax.set_ylim(0.0, 1.05)  # the line runs along the top, where the legend is
    ax.legend(loc="upper left")
    ax.set_xlabel("x (m)", fontsize=9)
    assert print_scale(fig) < 0.7
    assert smallest_print_font(fig) < MIN_FONT_PT
    assert legends_on_data(fig)
    close(fig)


@pytest.mark.parametrize("draw", ["solution_figure", "costate_figure"])
def test_a_scenario_figure_prints_its_text_at_7_pt_with_its_legends_off_the_data(s3, draw):
    plotting.apply_style()
    fig = getattr(plotting, draw)(*s3)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    assert legends_on_data(fig) == []
    assert narrowest_axes(fig) > 1.5, "a panel squeezed by its legend"
    close(fig)


def test_the_path_is_equal_aspect_with_start_goal_direction_and_reversing_marked(s3):
    plotting.apply_style()
    result, ocp = s3
    fig = plotting.solution_figure(result, ocp)
    path = fig.axes[2]
    assert path.get_aspect() == 1.0
    labels = {t.get_text() for t in path.get_legend().get_texts()}
    assert {"start pose", "goal pose", "reversing ($u_1$ < 0)"} <= labels
    assert any(a.arrow_patch is not None for a in path.texts), "no arrowhead on the path"
    close(fig)


def test_the_compared_paths_name_every_scenario_given(s3):
    plotting.apply_style()
    result, ocp = s3
    other = Result("s2-case1", dict(SOLVED), synthetic_s3().assign(y=lambda f: -f["y"]))
    fig = plotting.paths_figure([result, other], [ocp, ocp], ["s2-case1", "s3"])
    labels = " ".join(t.get_text() for t in fig.axes[0].get_legend().get_texts())
    assert "s3" in labels and "s2-case1" in labels
    assert smallest_print_font(fig) >= MIN_FONT_PT
    assert legends_on_data(fig) == []
    close(fig)


def test_the_cases_figure_overlays_the_cases_and_measures_how_far_their_paths_are_apart(s3):
    plotting.apply_style()
    result, ocp = s3
    slower = Result("s3-slow", dict(SOLVED, final_time=2.0), synthetic_s3().assign(t=lambda f: f["t"] * 1.5))
    fig = plotting.cases_figure([result, slower], [ocp, ocp], ["s3", "s3-slow"])
    assert "one path" in fig.get_suptitle()
    assert len(fig.axes[0].get_lines()) >= 2
    assert smallest_print_font(fig) >= MIN_FONT_PT
    assert legends_on_data(fig) == []
    close(fig)
    assert plotting.path_gap([np.array([[0, 0], [1, 0]]), np.array([[0, 0.5], [1, 0.5]])]) == pytest.approx(0.5)


def test_a_road_figure_prints_its_time_panels_at_7_pt_and_marks_start_goal_and_direction():
    from model.plotting.roads import road_figure

    ocp = load_scenario(ROOT / "workflows/roads/semitrailer-left-turn.toml").ocp
    t = np.linspace(0.0, 2.0, 21)
    theta = 0.15 * (t / 2.0) ** 2
    columns = {"t": t, "x": -50.0 + 10.0 * t, "y": -2.0 + 0.4 * t**2, "theta": theta, "phi": 0.05 * t,
               "theta1": 0.5 * theta, "u1": np.full_like(t, 10.0), "u2": np.full_like(t, 0.05)}  # fmt: skip
    fig = road_figure(ocp, columns, note="a note line")
    assert smallest_print_font(fig) >= MIN_FONT_PT
    plan = fig.axes[0]
    assert plan.get_aspect() == 1.0
    labels = {t.get_text() for t in plan.get_legend().get_texts()}
    assert {"start (rear axle)", "goal (rear axle)"} <= labels
    assert sum(a.arrow_patch is not None for a in plan.texts) >= 2, "no direction arrowheads (besides north)"
    close(fig)


def test_the_map_figure_frames_the_ring_names_movements_by_direction_and_keeps_its_legend_off_the_map():
    from model.plotting.maps import island, map_figure
    from model.scene.lanelet_map import dataset_file, read_map

    lanelet_map = read_map(dataset_file("rounD/DEU_Kackertstrasse-1"))
    route = {"from_lanelet": 90, "to_lanelet": 102, "start_offset": 11.9, "goal_offset": -5.6}
    box = {"type": "Polygon", "coordinates": [[[100, -70], [104, -70], [104, -60], [100, -60], [100, -70]]]}
    cell = {"cell": "c", "preset": "P", "movement": "90-102", "route": route, "valid": True, "final_time": 9.0,
            "swept_path": {"features": [{"geometry": box}]}, "apron_use": "trailer"}  # fmt: skip
    fig = map_figure(lanelet_map, [dict(cell, apron=True), dict(cell, cell="d", apron=False)], "P")
    ax = fig.axes[0]
    assert len(fig.axes) == 1, "two panels sweeping the same area are drawn once"
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    hx0, hy0, hx1, hy1 = island(lanelet_map).bounds
    assert x0 < hx0 and hx1 < x1 and y0 < hy0 and hy1 < y1, "the frame clips the ring"
    texts = [t.get_text() for t in fig.findobj(plotting.plt.Text)]
    assert any(t.startswith("from ") and " to " in t for t in texts)
    assert not any("90" in t or "102" in t for t in texts), "a lanelet id in the figure"
    assert ax.get_legend() is None and fig.legends, "the legend belongs below the map"
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def closed_loop_rows() -> list[dict]:
    rows = []
    for g, tol in (("s2", 0.02), ("truck", 0.91)):
        for level in (0.0, 1.0):
            for k, c in enumerate(("open-loop", "tracking", "mpc")):
                err = 10.0 ** (-4 + 2 * level - k)
                numbers = {"position_error_mean": err, "position_error_worst": 2 * err,
                           "heading_error_mean": err, "heading_error_worst": 3 * err}  # fmt: skip
                rows.append({"geometry": g, "level": level, "controller": c, "numbers": numbers,
                             "goal_tolerance": {"position": tol, "angle": 0.05}})  # fmt: skip
    return rows


def test_the_error_figure_draws_levels_as_separate_markers_not_lines_and_its_legend_below():
    from model.plotting.closed_loop import errors_figure

    colors = {"open-loop": "tab:red", "tracking": "tab:green", "mpc": "tab:blue"}
    fig = errors_figure(closed_loop_rows(), colors)
    for ax in fig.axes:
        joined = [ln for ln in ax.get_lines() if ln.get_linestyle() not in ("None", "", " ") and len(ln.get_xdata()) > 1
                  and len(set(np.round(np.asarray(ln.get_ydata(), float), 12))) > 1]  # fmt: skip
        assert joined == [], "levels joined by a line"
        assert list(ax.get_xticks()) == [0, 1], "one tick per level"
    assert fig.legends and all(ax.get_legend() is None for ax in fig.axes)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_wheelbase_figure_normalises_both_panels_by_the_same_reference():
    from model.plotting.studies import wheelbase_figure

    rows = [{"sweep": "a", "d": d, "kind": kind, "ok": True, "final_time": 1.0 + d, "objective": 2.0 * (1.0 + d)}
            for d in (0.5, 1.0, 2.0) for kind in ("time", "energy")]  # fmt: skip
    fig = wheelbase_figure(pd.DataFrame(rows))
    time_line, energy_line = fig.axes[0].get_lines()[0], fig.axes[1].get_lines()[0]
    assert list(time_line.get_xdata()) == list(energy_line.get_xdata()) == [0.5, 1.0, 2.0]
    assert np.allclose(time_line.get_ydata(), energy_line.get_ydata())  # J = 2 Tmin: the same ratios
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_time_controls_figure_titles_each_run_labels_its_quantity_and_keeps_one_legend_below():
    from model.plotting.studies import time_controls_figure

    t = np.linspace(0.0, 1.0, 41)
    tr = pd.DataFrame({"t": t, "u1": np.ones_like(t), "u2": 0.35 * np.sign(np.sin(9 * t))})
    bounds = {"u1": (-1.0, 1.0), "u2": (-0.35, 0.35)}
    runs = [(f"run-{k}", tr, bounds, {"u2": [{"t0": 0.4, "t1": 0.5}]} if k else {}) for k in range(3)]
    fig = time_controls_figure(runs)
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title(loc="left").split()[0] for ax in shown] == ["run-0", "run-1", "run-2"]
    assert all(ax.get_legend() is None for ax in shown) and fig.legends
    assert "bound" in shown[0].get_ylabel()
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_closed_loop_paths_figure_prints_at_7_pt_with_one_legend_below():
    from model.plotting.closed_loop import paths_figure

    s = np.linspace(0.0, 1.0, 30)
    path = pd.DataFrame({"x": s, "y": -0.2 * np.sin(np.pi * s)})
    runs = {c: path.assign(y=path["y"] * (1 + 0.1 * k)) for k, c in enumerate(("open-loop", "tracking", "mpc"))}
    panels = [{"title": f"{g}, level 1 (first run)", "ocp": None, "optimum": path, "runs": runs} for g in ("a", "b")]
    fig = paths_figure(panels, {"open-loop": "tab:red", "tracking": "tab:green", "mpc": "tab:blue"})
    assert fig.legends and all(ax.get_legend() is None for ax in fig.axes)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_plant_gap_figure_prints_at_7_pt_with_its_legend_below():
    from model.plotting.studies import plant_gap_figure

    def record(level: float) -> dict:
        return {"plan_valid": True, "clearance_lost_m": 0.1 * level, "plan_max_lateral_acceleration_mps2": level,
                "plant_max_lateral_deviation_m": 0.2 * level,
                "kinematic_max_lateral_deviation_m": 0.01 * level}  # fmt: skip

    groups = [("rigid truck SU-30, right turn", "o", [record(1.5), record(3.5)]),
              ("tractor-semitrailer EU-semitrailer, right turn", "s", [record(1.5), record(3.0)])]  # fmt: skip
    fig = plant_gap_figure(groups)
    assert fig.legends and all(ax.get_legend() is None for ax in fig.axes)
    assert all("(m/s²)" in ax.get_xlabel() for ax in fig.axes)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def tradeoff_columns(ocp, speed: float) -> dict:
    """A straight pass through the scene at constant speed with every state of the vehicle."""
    t = np.linspace(0.0, 40.0 / speed, 21)
    cols = {name: np.zeros_like(t) for name in ocp.vehicle.states}
    cols.update({"t": t, "x": -20.0 + speed * t, "y": -2.0 + 0 * t, "u1": speed + 0 * t, "u2": 0.1 * np.sin(t)})
    return cols


def test_the_road_tradeoff_figure_prints_at_7_pt_with_one_legend_below():
    from model.plotting.studies import tradeoff_figure

    ocp = load_scenario(ROOT / "workflows/scenarios/roads/su30-left-turn.toml").ocp
    rows = [{"objective": "time", "valid": True, "final_time": 4.0, "energy": 600.0},
            {"objective": "energy", "valid": True, "final_time": 5.0, "energy": 500.0},
            {"objective": "energy", "valid": True, "final_time": 8.0, "energy": 300.0}]  # fmt: skip
    trajectories = {"time": tradeoff_columns(ocp, 10.0), "energy, 2 T_min": tradeoff_columns(ocp, 5.0)}
    fig = tradeoff_figure(ocp, rows, trajectories)
    assert fig.legends and all(ax.get_legend() is None for ax in fig.axes)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_turning_circle_figure_prints_at_7_pt_with_one_legend_below():
    from model.plotting.studies import turning_figure

    theta = np.linspace(0.0, 4 * np.pi, 81)  # two turns, 40 nodes each
    square = np.array([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]])

    def body(radius: float) -> np.ndarray:
        rot = np.stack(
            [np.stack([np.cos(theta), -np.sin(theta)], -1), np.stack([np.sin(theta), np.cos(theta)], -1)], -2
        )
        centre = radius * np.column_stack([np.sin(theta), -np.cos(theta)])
        return centre[:, None, :] + np.einsum("nij,kj->nki", rot, square)

    result = {
        "phi_deg": 20.0,
        "steady": {"inner": 6.0},
        "transient": {"turns": [1, 2], "run": {"t": theta, "theta": theta}},
    }
    from model.studies.roads import rectangle_distance

    trailer = body(7.5)
    fig = turning_figure("a semitrailer", result, {"vehicle": body(9.0), "trailer": trailer}, 12.5, 5.3,
                         rectangle_distance(trailer))  # fmt: skip
    assert fig.legends and all(ax.get_legend() is None for ax in fig.axes)
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_map_figure_holds_its_legend_inside_the_figure():
    from model.plotting.maps import map_figure
    from model.scene.lanelet_map import dataset_file, read_map

    lanelet_map = read_map(dataset_file("rounD/DEU_Kackertstrasse-1"))
    route = {"from_lanelet": 90, "to_lanelet": 102, "start_offset": 11.9, "goal_offset": -5.6}
    box = {"type": "Polygon", "coordinates": [[[100, -70], [104, -70], [104, -60], [100, -60], [100, -70]]]}
    cell = {"cell": "c", "preset": "P", "movement": "90-102", "route": route, "valid": True, "final_time": 9.0,
            "swept_path": {"features": [{"geometry": box}]}, "apron_use": "trailer", "apron": True}  # fmt: skip
    fig = map_figure(lanelet_map, [cell], "P")
    fig.canvas.draw()
    legend, page = fig.legends[0].get_window_extent(), fig.bbox
    assert page.x0 <= legend.x0 and legend.x1 <= page.x1, "the legend runs past the figure's edge (cut when saved)"
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)


def test_the_traffic_comparison_figure_prints_at_7_pt_with_its_legends_beside_the_axes():
    from model.plotting.studies import comparison_figure

    cells = [{"vc_pcph": v, "line_wait": 0.005 * v} for v in (200.0, 450.0, 650.0)]
    cars = {"critical_gap": 4.75, "follow_up": 2.35, "cells": cells}
    measures = {("truck", "autopilot"): {"critical_gap": 5.2, "cells": cells[:1]},
                ("semitrailer", "sumo"): {"critical_gap": None, "cells": cells[1:2]}}  # fmt: skip
    styles = {"autopilot": {"color": "#1f6fb4", "marker": "o"}, "sumo": {"color": "#d2691e", "marker": "s"}}
    from model.traffic.gaps import adams_delay, gap_capacity, hcm_capacity

    formulas = {"adams_delay": adams_delay, "gap_capacity": gap_capacity, "hcm_capacity": hcm_capacity,
                "hcm_label": "HCM 6th ed."}  # fmt: skip
    fig = comparison_figure(cars, measures, styles, formulas)
    assert legends_on_data(fig) == []
    assert narrowest_axes(fig) > 1.5, "a panel squeezed by its legend"
    assert smallest_print_font(fig) >= MIN_FONT_PT
    close(fig)
