"""Paper fragments of the study scripts (issue 46): every pipe table has a ``Table:`` caption right before it,
and (roads, design vehicles, trade-off, map, closed loop) one value per cell, numbers to their precision.

The sections are built from small synthetic results (no solves); the captions' numbers come from those
results, and the turning-circle script cites each preset's source with a key of paper/references.bib.
"""

from __future__ import annotations

import json
import re
import sys
import tomllib
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import closed_loop_section  # noqa: E402
import map_study_table  # noqa: E402
import paper_citations  # noqa: E402
import plant_study_section  # noqa: E402
import roads_section  # noqa: E402
import studies_convergence  # noqa: E402
import studies_pareto  # noqa: E402
import studies_roads_table  # noqa: E402
import studies_roads_tradeoff  # noqa: E402
import studies_roads_turning  # noqa: E402
import studies_wheelbase  # noqa: E402

from model.problem.scenario import load_scenario  # noqa: E402
from model.studies.plant_gap import RECORD_KEYS  # noqa: E402
from model.vehicles import PRESETS, preset  # noqa: E402


def captions_of_tables(text: str) -> list[str]:
    """The caption before each pipe table of ``text``; fails when a table has none (or no blank line between)."""
    blocks = [b.strip() for b in text.split("\n\n")]
    captions = []
    for i, block in enumerate(blocks):
        if block.startswith("|"):
            assert i > 0 and blocks[i - 1].startswith("Table: "), f"table without a caption: {block[:60]!r}"
            captions.append(blocks[i - 1])
    assert captions, "no table found"
    return captions


def test_convergence_table_is_captioned_with_units_in_its_headers():
    rows = [{"scenario": "s1", "grids": "100,200", "objective": 1.5, "unit": "s", "diffs": "1e-3", "order_J": "2.0"}]
    text = studies_convergence.section(rows, {"s1": [100, 200]})
    (caption,) = captions_of_tables(text)
    assert "one row per scenario" in caption
    assert "[@betts2010]" in text


def pareto_inputs(t_min: float) -> tuple[dict, list[dict], pd.DataFrame]:
    verdict = {"t_min": t_min, "points": 3, "failed": 0, "monotone_decreasing": True, "C_max": 0.2,
               "C_bound": 0.25, "C_ratio_at_tmin": 0.8, "C_at_cases": {"s1": 0.1}}  # fmt: skip
    front = pd.DataFrame({"front": "s1", "ok": True, "final_time_set": [1.0, 2.0, 3.0],
                          "objective": [0.3, 0.2, 0.1], "iterations": [10, 11, 12]})  # fmt: skip
    return {"s1": verdict}, [{"front": "s1", "case": "s1", "final_time": 2.0, "energy": 0.2}], front


def test_both_pareto_tables_are_captioned_and_the_seed_paper_cited():
    text = studies_pareto.section(*pareto_inputs(1.234), Path("x.png"))
    first, second = captions_of_tables(text)
    assert "one row per geometry" in first and "(s)" in first
    assert studies_pareto.ENERGY_UNIT in second
    assert "[@seed]" in text
    assert "| 1.2340 |" in text  # the table prints the result it is given, to 0.1 ms


def test_wheelbase_table_is_captioned():
    base = {"sweep": "paper s2", "d": 0.02, "status": "optimal", "certificate": True}
    frame = pd.DataFrame([
        {**base, "kind": "time", "ok": True, "final_time": 1.7, "objective": 1.7, "fixed_tf": None},
        {**base, "kind": "energy", "ok": True, "final_time": 2.0, "objective": 0.4, "fixed_tf": 2.0},
    ])  # fmt: skip
    (caption,) = captions_of_tables(studies_wheelbase.section(frame, Path("x.png")))
    assert "wheelbase d (m)" in caption


def plant_record(level: float) -> dict:
    """A synthetic manoeuvre record at ``level`` (every field of the table set)."""
    r = dict.fromkeys(RECORD_KEYS, 0.1) | {
        "vehicle": "truck", "preset": "SU-30", "manoeuvre": "right turn", "exit": 1, "status": "optimal",
        "intervals": 80, "lateral_acceleration_bound_mps2": level, "plan_valid": True, "safe": True,
        "plant_reached_goal": True, "plant_min_clearance_m": 0.05, "clearance_lost_m": 0.0,
    }  # fmt: skip
    return r


def test_plant_study_table_is_captioned_with_the_records_levels():
    text = plant_study_section.section([plant_record(1.5), plant_record(2.5)], "small", "x.png")
    (caption,) = captions_of_tables(text)
    assert "(1.5, 2.5 m/s²)" in caption and "`small` grid" in caption
    assert "[@commonroadvehicles]" in text


def test_every_preset_source_is_cited_with_a_key_of_the_bibliography():
    keys = set(paper_citations.parse_bib((ROOT / "paper" / "references.bib").read_text()))
    sentence = studies_roads_turning.preset_sources(list(PRESETS))
    cited = paper_citations.cited_keys(sentence)
    assert set(cited) <= keys
    assert {"aashto2018", "directive9653", "commonroadvehicles"} <= set(cited)
    for name in PRESETS:
        assert name in sentence and preset(name)["source"] in sentence


@pytest.mark.parametrize(
    ("key", "value", "printed"),
    [
        ("inner", 5.34567, "5.346"),
        ("phi_deg", 20.0521, "20.05"),
        ("inner_margin", -0.07286, "-0.073"),
        ("inner", None, None),
    ],
)
def test_preset_rows_print_lengths_to_the_millimetre_and_angles_to_the_hundredth(key, value, printed):
    assert studies_roads_turning.preset_cells({key: value, "verdict": "yes"})[key] == printed


@pytest.mark.parametrize(("change", "printed"), [(1.02e-05, "0.47803"), (4.9e-03, "0.478"), (None, 0.4780312)])
def test_convergence_prints_j_to_the_decimal_of_its_last_change(change, printed):
    row = {"objective": 0.4780312, "last_change": change, "costate_change": 0.30372}
    assert studies_convergence.printed(row)["objective"] == printed
    assert studies_convergence.printed(row)["costate_change"] == "3.04e-01"


# -- the road, design-vehicle, trade-off, map and closed-loop sections (issue 46) -----------------------------
RUN_TOGETHER = re.compile(r"\| [^|]*\d / [^|]*\d [^|]*\|")  # a cell holding "a / b" numbers


def cells_fit_their_headers(text: str) -> None:
    """Every row of every pipe table has its header's number of cells, and no cell runs numbers together."""
    for block in (b.strip() for b in text.split("\n\n")):
        if block.startswith("|"):
            header, _, *rows = block.splitlines()
            assert all(r.count("|") == header.count("|") for r in rows), block[:80]
            assert not RUN_TOGETHER.search("\n".join(rows)), block[:200]


def write_road(folder: Path, summary: dict, columns: dict) -> None:
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps(summary))
    pd.DataFrame(columns).to_csv(folder / "trajectory.csv", index=False)


def test_road_tables_are_captioned_with_short_cells(tmp_path):
    roads = ROOT / "workflows" / "roads"
    scenarios = [roads / "truck-straight-on.toml", roads / "truck-straight-on-operational.toml"]
    t = [0.0, 1.0, 2.0]
    free = {"valid": True, "final_time": 10.5, "energy": 500.0, "objective": 10.5, "iterations": 30,
            "min_clearance": 0.1234, "min_clearance_dense": 0.1, "lateral_acceleration": {"max_abs_nodes": 7.25,
            "max_abs_dense": 7.5}}  # fmt: skip
    held = free | {"longitudinal": {"min_acceleration": -2.25, "max_acceleration": 1.25}}
    base = {"t": t, "x": t, "y": [0.0] * 3, "theta": [0.0] * 3, "phi": [0.0] * 3, "u2": [1.0, -1.0, 1.0]}
    write_road(tmp_path / "truck-straight-on", free, base | {"u1": [10.0] * 3})
    write_road(tmp_path / "truck-straight-on-operational", held, base | {"v": t, "a": [0.0] * 3, "j": [0.0] * 3})
    text = "\n".join(roads_section.tables(scenarios, tmp_path))
    setting, solved = captions_of_tables(text)
    assert "length x width (m" in setting and "(m, negative: an encroachment)" in solved
    cells_fit_their_headers(text)
    assert "| 0.123 |" in text and "| 10.50 |" in text  # clearances to the millimetre, times to 10 ms
    assert "[@ipopt]" in text


def road_cell(preset_name: str, apron: float, valid: bool = True) -> dict:
    """A synthetic cell of the design-vehicle study (the fields ``studies_roads_table.flat`` reads)."""
    time = {"valid": valid, "final_time": 19.654, "min_clearance": 0.1, "max_abs_lateral_acceleration": 2.0,
            "min_acceleration": -1.9, "max_acceleration": 1.3,
            "diagnosis": None if valid else {"message": "the trailer crosses the apron by 1.30 m"}}  # fmt: skip
    return {"preset": preset_name, "icd": 45.0, "apron": apron, "apron_use": "trailer", "intervals": 60,
            "time": time, "energy": {"energy": 0.1147, "valid": True, "final_time_set": 23.6},
            "measures": {"apron_used_m": 1.9049, "swept_width_m": 4.4621}, "seconds": 10.0, "cpu_seconds": 9.0,
            "operational": True, "speed_bound": [0, 10], "initial_speed": 2.78}  # fmt: skip


def test_design_vehicle_tables_are_captioned_one_value_per_cell():
    cells = [road_cell("SU-30", 0.0), road_cell("SU-30", 2.0), road_cell("EU-semitrailer", 0.0, valid=False)]
    df = pd.DataFrame([studies_roads_table.flat(c) for c in cells])
    template = tomllib.loads((ROOT / "workflows" / "scenarios" / "roads" / "left-turn.toml").read_text())
    grid = {"vehicles": ["SU-30", "EU-semitrailer"], "icd": [45.0], "apron": [0.0, 2.0], "intervals": 60}
    text = studies_roads_table.section(df, "small", grid, template, Path("x.png"), 1.2, "a figure")
    matrix, cells_caption = captions_of_tables(text)
    assert "(1 such cells)" in matrix and "`small` run" in cells_caption
    cells_fit_their_headers(text)
    assert "| 1.905 | 4.462 | held: a_lat 2.00, a -1.90 to 1.30 |" in text
    assert "- EU-semitrailer, ICD 45 m, apron 0 m: the trailer crosses the apron by 1.30 m." in text
    assert "SU-30 [@aashto2018]" in text and "EU-semitrailer [@directive9653]" in text


def tradeoff_row(objective: str, ratio: float | None, final_time: float, energy: float) -> dict:
    return {"objective": objective, "ratio": ratio, "final_time": final_time, "status": "optimal", "valid": True,
            "energy": energy, "iterations": 30, "max_speed": 10.0, "mean_speed": 9.9912, "path_length": 124.8612,
            "speed_share": 0.99813, "min_clearance": 0.09744, "max_abs_lateral_acceleration": 8.22,
            "apron_used_m": 1.9031, "swept_width_m": 4.1987, "diagnosis": None}  # fmt: skip


def test_tradeoff_tables_are_captioned_with_numbers_to_their_precision():
    ocp = load_scenario(ROOT / "workflows" / "scenarios" / "roads" / "su30-left-turn.toml").ocp
    rows = [tradeoff_row("time", None, 12.486, 625.47), tradeoff_row("energy", 1.25, 15.6075, 499.86)]
    text = studies_roads_tradeoff.section(ocp, rows, Path("x.png"), 60, 0.075, "SU-30", None)
    solves, geometry = captions_of_tables(text)
    assert "Tf (s)" in solves and "clearance (m)" in geometry
    cells_fit_their_headers(text)
    assert "| 12.49 | 625.5 | 10.00 | 9.99 | 0.9981 |" in text and "| 124.86 | 1.903 | 4.199 | 0.097 |" in text
    assert "[@seed]" in text and "SU-30 [@aashto2018]" in text


def map_cell(apron: bool, valid: bool = True) -> dict:
    """A synthetic cell of the map study (the fields ``map_study_table.flat`` reads)."""
    return {"preset": "EU-semitrailer", "movement": "90-102", "apron": apron, "apron_use": "trailer" if apron else
            "none", "route": {"from_lanelet": 90, "to_lanelet": 102}, "intervals": 100, "intervals_solved": 100,
            "status": "optimal" if valid else "infeasible", "valid": valid, "final_time": 23.0912,
            "min_clearance": 0.013951, "min_clearance_dense": 0.01229, "apron_used_m": 0.0, "apron_area_m2": 0.0,
            "apron_gap_m": 2.12, "lanelets_used": [41, 42], "seconds": 40.0, "operational": True,
            "max_abs_lateral_acceleration": 1.5, "min_acceleration": -1.72, "max_acceleration": 1.0,
            "diagnosis": None if valid else {"message": "the trailer leaves lanelet 47 by 0.40 m"}}  # fmt: skip


def test_map_tables_are_captioned_and_lanelets_never_read_as_citations():
    df = pd.DataFrame([map_study_table.flat(c) for c in (map_cell(True), map_cell(False, valid=False))])
    template = tomllib.loads((ROOT / "workflows" / "scenarios" / "maps" / "kackertstrasse.toml").read_text())
    grid = {"vehicles": ["EU-semitrailer"], "movements": ["90-102"], "apron": [True, False], "intervals": 100}
    text = map_study_table.section(df, "small", grid, template, 20, [(Path("x.png"), "a figure")])
    matrix, cells_caption = captions_of_tables(text)
    assert "entry-exit" in matrix and "(m²)" in cells_caption
    cells_fit_their_headers(text)
    assert "| 23.1 | fails |" in text and "| 23.09 | 100 | 0.014 | 0.012 |" in text
    assert not re.search(r"\[\d+(, \d+)*\]", text)  # "[50]" reads as a citation: "lanelet 50"
    apron = template["route"]["apron_lanelets"]
    assert map_study_table.lanelet_words(apron).startswith("lanelet") and f" {apron[-1]}" in text
    assert "[@round2020]" in text and "[@commonroad2017]" in text


def closed_loop_row(controller: str, level: float, error: float) -> dict:
    """A synthetic row of the closed-loop study (the fields the section reads)."""
    numbers = dict.fromkeys(("energy_ratio_mean", "energy_ratio_worst", "heading_error_mean", "heading_error_worst",
                             "min_clearance", "step_seconds_mean", "step_seconds_max"), 0.5)  # fmt: skip
    numbers |= {"runs": 3, "reach_rate": 1.0, "position_error_mean": error, "position_error_worst": 2 * error,
                "violations": 0, "failed_steps": 0, "realtime_factor": 0.25, "steps": 70}  # fmt: skip
    return {"geometry": "demo", "title": "A demo", "level": level, "controller": controller, "objective": "energy",
            "weights": {}, "sample_time": 0.1, "horizon": 40, "safety": 2.0, "numbers": numbers,
            "optimum": {"energy": 10.0, "objective": 10.0, "final_time": 7.0, "certified": True},
            "goal_tolerance": {"position": 0.9, "angle": 0.05, "angle_states": ["theta"]},
            "criteria": {"runs": 3, "position": 3, "heading": 2, "steps": 3},
            "machine": {"cpus": 2, "load_before": 2.7, "load_after": 2.9},
            "level1_disturbance": {"speed_gain": 0.95, "steering_bias": 0.01, "drift": [0.0, 0.3], "wheelbase": {},
                                   "delay": 0.1, "noise": 0.03}}  # fmt: skip


def test_closed_loop_tables_are_captioned_one_value_per_cell():
    rows = [closed_loop_row(c, 1.0, e) for c, e in (("open-loop", 8.0), ("tracking", 0.5), ("mpc", 0.4))]
    text = closed_loop_section.section(rows, "demo", None)
    accuracy, effort = captions_of_tables(text)
    assert accuracy.startswith("Table: demo, accuracy") and "(ms)" in effort
    cells_fit_their_headers(text)
    assert "| 1 | mpc | 3 | 100% | 0.4 | 0.8 | 0.5 | 0.5 | 3 of 3 | 2 of 3 | 3 of 3 |" in text
    assert "| 500 | 500 |" in text  # step times in whole milliseconds
    assert "load" not in text  # the machine's load average is no result


def test_turning_circle_table_holds_one_value_per_row():
    steady = {"R": 10.137, "front_axle_radius": 10.791, "trailer_axle_radius": 6.621, "articulation": 0.8014,
              "outer": 12.5, "inner": 5.346, "outer_body": "vehicle", "inner_body": "trailer"}  # fmt: skip
    turns = [{"inner": 5.365, "outer": 16.131}, {"inner": 5.346, "outer": 12.5, "outside_annulus_m2": 6.8e-11}]
    result = {"steady": steady, "phi_deg": 20.05, "phi": 0.35, "outer_margin": 0.0, "inner_margin": 0.046,
              "transient": {"turns": turns, "trailer_axle_radius": [6.64, 6.621], "swing_out": 0.426}}  # fmt: skip
    rows = studies_roads_turning.circle_rows(result, "none")
    assert all(len(re.findall(r"\d+\.\d+", r["value"])) == 1 for r in rows if r["value"] != "none")
    assert {"10.137 m", "10.791 m", "6.640 m", "6.621 m", "45.92 deg"} <= {r["value"] for r in rows}
