"""The plant study (issue 43, item 5): a kinematic plan driven on the dynamic plant at rising lateral acceleration.

The cell's scenario and its bad input, the manoeuvre's name, the verdict on synthetic records, the section's
numbers read from the records, a real cell of the rigid truck at two levels (the numbers computed, growing with
the level), and the pipeline's rules (a dry run).
"""

from __future__ import annotations

import copy
import math
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from model.errors import InputError
from model.studies.plant_gap import RECORD_KEYS, cell_scenario, first_unsafe, manoeuvre_name, run_cell

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ROOT / "workflows" / "scenarios" / "plant-study"
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import plant_study_section  # noqa: E402


def template(name: str = "truck") -> dict:
    return tomllib.loads((TEMPLATES / f"{name}.toml").read_text())


def test_a_cell_sets_the_bound_exit_intervals_and_the_dynamic_plant_and_leaves_the_template():
    doc = template()
    before = copy.deepcopy(doc)
    sc = cell_scenario(doc, 2.5, exit=2, intervals=30, name="cell")
    assert sc.ocp.bounds["lateral_acceleration"] == (-2.5, 2.5)
    assert sc.ocp.road.route.exit == 2 and sc.intervals == 30 and sc.ocp.name == "cell"
    assert sc.plant.model == "single-track"
    assert doc == before


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), True, "2"])
def test_a_bad_level_names_the_key(bad):
    with pytest.raises(InputError, match="plant_study.lateral_acceleration"):
        cell_scenario(template(), bad)


def test_a_template_without_a_route_names_it():
    doc = template()
    del doc["route"]
    with pytest.raises(InputError, match="route"):
        cell_scenario(doc, 2.0)


@pytest.mark.parametrize("vehicle", ["truck", "semitrailer"])
def test_the_templates_parse_with_their_operational_limits(vehicle):
    sc = cell_scenario(template(vehicle), 1.5)
    assert "v" in sc.ocp.vehicle.states  # [vehicle] operational = true: the speed is a state
    assert sc.ocp.bodies


@pytest.mark.parametrize(("exit", "name"), [(1, "right turn"), (2, "straight on"), (3, "left turn"), (4, "U-turn")])
def test_the_manoeuvre_is_named_from_the_legs(exit, name):
    assert manoeuvre_name(cell_scenario(template(), 2.0, exit=exit)) == name


def test_left_hand_traffic_mirrors_the_names():
    doc = template()
    doc["roundabout"]["traffic"] = "left"
    names = [manoeuvre_name(cell_scenario(doc, 2.0, exit=k)) for k in (1, 2, 3, 4)]
    assert names == ["left turn", "straight on", "right turn", "U-turn"]  # clockwise: the first exit is to the left


def record(level: float, clearance: float, vehicle: str = "truck", valid: bool = True, **extra) -> dict:
    """A synthetic record: the plan keeps 0.05 m, the dynamic plant ``clearance``."""
    r = dict.fromkeys(RECORD_KEYS) | {
        "vehicle": vehicle, "preset": "SU-30", "manoeuvre": "right turn", "exit": 1, "status": "optimal",
        "lateral_acceleration_bound_mps2": level, "plan_valid": valid, "plan_max_speed_mps": 5.0 + level,
        "plan_max_lateral_acceleration_mps2": level, "plan_min_clearance_m": 0.05, "kinematic_min_clearance_m": 0.05,
        "kinematic_max_lateral_deviation_m": 0.01, "plant_min_clearance_m": clearance,
        "plant_max_lateral_deviation_m": 0.1 * level, "plant_max_side_slip_rad": 0.02 * level,
        "plant_max_lateral_acceleration_mps2": 1.2 * level, "plant_max_friction_use": 0.1 * level,
        "clearance_lost_m": 0.05 - clearance, "plant_reached_goal": True, "safe": valid and clearance >= 0,
    }  # fmt: skip
    return r | extra


def test_the_first_unsafe_level_is_the_lowest_validated_one_whose_plant_leaves_the_corridor():
    records = [record(3.0, -0.2), record(1.0, 0.03), record(2.0, -0.01), record(1.5, 0.0, valid=False)]
    assert first_unsafe(records)[("truck", 1)]["lateral_acceleration_bound_mps2"] == 2.0
    assert first_unsafe([record(1.0, 0.03), record(2.0, 0.01)])[("truck", 1)] is None
    missed = record(1.0, 0.03, safe=False, plant_reached_goal=False)
    assert first_unsafe([missed])[("truck", 1)]["lateral_acceleration_bound_mps2"] == 1.0


def test_the_section_reads_its_numbers_from_the_records():
    records = [record(1.0, 0.03), record(2.0, -0.0123), record(3.0, -0.2)]
    text = plant_study_section.section(records, "small", "results/x.png")
    assert "stops being safe at 2 m/s² (top speed 7 m/s)" in text
    assert "leave the corridor by 0.012 m" in text
    moved = plant_study_section.section([record(1.0, -0.05), *records[1:]], "small", "results/x.png")
    assert "already at the lowest level tested, 1 m/s²" in moved and "by 0.05 m" in moved
    safe = plant_study_section.section([record(1.0, 0.03), record(2.0, 0.02)], "small", "results/x.png")
    assert "stays in its corridor on the dynamic plant at every level up to 2 m/s²" in safe
    assert "![" in text and "(results/x.png)" in text and "| safe |" in text


def test_a_failed_plan_is_reported_without_numbers():
    records = [record(1.0, 0.03), record(2.0, -0.1, valid=False, status="validation_failed")]
    text = plant_study_section.section(records, "small", "x.png")
    assert "no validated plan at 2 m/s²: validation_failed" in text
    assert "stays in its corridor" in text


def test_the_table_has_units_in_its_column_names():
    header = plant_study_section.csv_text([record(1.0, 0.03)]).splitlines()[0].split(",")
    assert {"plant_min_clearance_m", "plant_max_lateral_deviation_m", "lateral_acceleration_bound_mps2"} <= set(header)
    assert all("(" in h for k, h in plant_study_section.COLUMNS.items() if k.endswith(("_m", "_mps", "_mps2", "_s")))


@pytest.fixture(scope="module")
def truck_cells() -> list[dict]:
    """The rigid truck's right turn at two levels (N = 40, the study's small grid)."""
    return [run_cell(cell_scenario(template(), level, exit=1, intervals=40), time_limit=120,
                     labels={"vehicle": "truck"}) for level in (1.5, 3.5)]  # fmt: skip


@pytest.mark.slow
def test_a_cell_computes_every_field_and_the_gap_grows_with_the_level(truck_cells):
    low, high = truck_cells
    for r in truck_cells:
        assert set(RECORD_KEYS) <= set(r) and r["plan_valid"], r["status"]
        numbers = [k for k in RECORD_KEYS if k.endswith(("_m", "_mps", "_mps2", "_rad", "_s", "_use"))]
        assert all(isinstance(r[k], float) and math.isfinite(r[k]) for k in numbers), r
        assert r["manoeuvre"] == "right turn" and r["vehicle"] == "truck"
        assert r["clearance_lost_m"] == pytest.approx(r["kinematic_min_clearance_m"] - r["plant_min_clearance_m"])
        assert r["safe"] == (r["plant_min_clearance_m"] >= 0 and r["plant_reached_goal"])
        assert r["plan_max_lateral_acceleration_mps2"] <= 1.05 * r["lateral_acceleration_bound_mps2"]
        assert r["kinematic_max_lateral_deviation_m"] < r["plant_max_lateral_deviation_m"]  # the dynamics, not the loop
    assert high["plan_max_speed_mps"] > low["plan_max_speed_mps"]
    assert high["final_time_s"] < low["final_time_s"]
    assert high["plant_max_lateral_deviation_m"] > low["plant_max_lateral_deviation_m"]
    assert high["clearance_lost_m"] > low["clearance_lost_m"]
    assert high["plant_max_lateral_acceleration_mps2"] > low["plant_max_lateral_acceleration_mps2"]


@pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed")
def test_the_pipeline_plans_one_job_per_manoeuvre_and_the_section(tmp_path):
    cmd = ["snakemake", "-s", str(ROOT / "Snakefile"), "--directory", str(tmp_path), "-n", "-p",
           "results/sections/82-plant-study.md"]  # fmt: skip
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    out = run.stdout + run.stderr
    assert "--exit 1 --levels 1.5 3.5 --intervals 40" in out
    jobs = dict(re.findall(r"^(plant_study_\w+)\s+(\d+)\s*$", out.split("Job stats:", 1)[1], re.M))
    assert jobs == {"plant_study_manoeuvre": "2", "plant_study_section": "1"}
