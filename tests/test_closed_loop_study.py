"""The closed-loop study of the pipeline (workflows/rules/closed_loop.smk): its scripts and its rule file."""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "workflows" / "scripts"
STUDY = ROOT / "workflows" / "scenarios" / "closed-loop"


def script(name: str):
    """A workflow script as a module."""
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def runs():
    return script("closed_loop_runs")


@pytest.fixture(scope="module")
def section():
    return script("closed_loop_section")


def test_study_geometries_are_outside_the_pipeline_scenario_glob():
    assert sorted(p.stem for p in STUDY.glob("*.toml")) == ["road-straight-on", "s2", "truck", "truck-weighted"]
    assert not any(p.name.startswith("closed-loop") for p in (ROOT / "workflows" / "scenarios").glob("*.toml"))


def test_levels_scale_the_file_disturbance(runs):
    sc = runs.load_scenario(STUDY / "truck.toml")
    assert runs.disturbance_at(sc, 0.0).none
    half = runs.disturbance_at(sc, 0.5)
    assert half.speed_gain == pytest.approx(0.975) and half.steering_bias == pytest.approx(0.0085)
    assert half.wheelbase == {"wheelbase": pytest.approx(5.125)} and half.drift == pytest.approx((0.0, 0.15))
    assert half.delay == pytest.approx(0.1)  # half a sample rounds up to one
    assert runs.disturbance_at(sc, 2.0).delay == pytest.approx(0.2)
    assert runs.disturbance_at(sc, 1.0) == sc.disturbance


def test_runs_script_writes_the_table_row_and_the_runs(runs, tmp_path):
    out = tmp_path / "s2-open-loop"
    runs.main(["--scenario", str(STUDY / "s2.toml"), "--level", "1", "--controller", "open-loop", "--runs", "2",
               "--out", str(out)])  # fmt: skip
    row = json.loads((out / "row.json").read_text())
    assert (row["geometry"], row["level"], row["controller"]) == ("s2", 1.0, "open-loop")
    assert row["optimum"]["valid"] and row["optimum"]["certified"]
    assert tuple(row["numbers"]) == runs.ROW_KEYS and row["numbers"]["runs"] == 2
    assert row["numbers"]["energy_ratio_mean"] == pytest.approx(1.0, abs=0.05)
    with (out / "runs.csv").open() as f:
        lines = list(csv.DictReader(f))
    assert [r["seed"] for r in lines] == ["0", "1"]
    assert {"final_position_error", "final_heading_error", "energy", "objective", "min_clearance",
            "solve_seconds_mean", "realtime_factor", "reached_goal"} <= set(lines[0])  # fmt: skip
    assert (out / "closed_loop.csv").exists() and (out / "optimum" / "trajectory.csv").exists()


def fake_row(controller: str, level: float, error: float, energy: float) -> dict:
    n = {k: 0.0 for k in script("closed_loop_runs").ROW_KEYS}
    n |= {"runs": 50, "reach_rate": 1.0 if error < 0.5 else 0.0, "position_error_mean": error,
          "position_error_worst": 2 * error, "energy_ratio_mean": energy, "energy_ratio_worst": energy,
          "violations": 0, "failed_steps": 0, "realtime_factor": 0.25}  # fmt: skip
    return {
        "geometry": "demo", "title": "A demo geometry", "level": level, "controller": controller,
        "objective": "energy", "weights": {}, "sample_time": 0.1, "horizon": 40, "safety": 2.0,
        "lengths": {"wheelbase": 5.0}, "disturbance": {}, "level1_disturbance": {
            "speed_gain": 0.95, "steering_bias": 0.01, "drift": [0.0, 0.3], "wheelbase": {}, "delay": 0.1,
            "noise": 0.03, "seed": 0},
        "optimum": {"energy": 10.0, "objective": 10.0, "final_time": 7.0, "certified": True, "valid": True},
        "goal_tolerance": {"position": 0.9, "angle": 0.05}, "numbers": n,
    }  # fmt: skip


def test_section_from_two_fake_result_files(section, tmp_path):
    paths = []
    for controller, error in (("open-loop", 8.0), ("mpc", 0.4)):
        p = tmp_path / controller / "row.json"
        p.parent.mkdir()
        machine = {"cpus": 2, "load_before": 2.7, "load_after": 2.9}  # recorded by the runs, never reported
        p.write_text(json.dumps(fake_row(controller, 1.0, error, 1.2) | {"machine": machine}))
        paths.append(p)
    out = tmp_path / "80-closed-loop.md"
    section.main(["--rows", *map(str, paths), "--study", "demo", "--figures", str(tmp_path / "fig"),
                  "--formats", "png", "--out", str(out)])  # fmt: skip
    text = out.read_text()
    assert "Study grid **demo**" in text and "runs per setting 50" in text
    assert "| 1 | open-loop | 50 | 0% | 8 | 16 |" in text and "| 1 | mpc | 50 | 100% | 0.4 | 0.8 |" in text
    assert "load average" not in text  # the machine's load is not a result of the study
    assert "MPC ends 20 times closer to the goal than the open-loop replay" in text
    assert "objective / optimum" not in text  # plain energy: the objective is the energy
    assert (tmp_path / "fig" / "errors.png").exists() and (tmp_path / "fig" / "paths.png").exists()


@pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed")
def test_rule_file_plans_one_job_per_geometry_and_level(tmp_path):
    config = tmp_path / "config.yaml"
    config.write_text(
        "closed_loop_study: tiny\nclosed_loop_studies:\n  tiny:\n    geometries: [s2]\n    levels: [0, 1]\n"
        "    controllers: [open-loop, mpc]\n    runs: 2\n    extra: ['truck-weighted:1:mpc']\n"
    )
    target = "results/sections/80-closed-loop.md"  # before --configfile, which takes several paths
    cmd = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "--directory", str(tmp_path), "-n",
           "--nolock", "-c1", target, "--configfile", str(config)]  # fmt: skip
    # an empty working directory: nothing built yet, whatever the repository's results/ holds
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "results/closed-loop/tiny/s2/level1/mpc/row.json" in done.stdout
    assert "results/closed-loop/tiny/truck-weighted/level1/mpc/row.json" in done.stdout
    assert "results/closed-loop/tiny/s2/level0/open-loop/row.json" in done.stdout
    # one job per geometry x level (the optimum solved once for its controllers): s2 0, s2 1, truck-weighted 1
    jobs = {line.split()[0] for line in done.stdout.splitlines() if line.startswith("closed_loop_")}
    assert jobs == {"closed_loop_s2_level0", "closed_loop_s2_level1", "closed_loop_truck_weighted_level1",
                    "closed_loop_section"}  # fmt: skip
