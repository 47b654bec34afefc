"""The traffic study's tables (workflows/scripts/traffic_table.py) on made-up cells: units, counts, intervals."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import traffic_table  # noqa: E402


def run(seed: int, delay: float, caused: float, alone: float, arrived: bool = True, loss: float = 10.0) -> dict:
    return {"seed": seed, "arrived": arrived, "delay": delay, "entry_wait": 0.5, "collisions": 0, "min_distance": 1.5,
            "min_clearance": 0.3, "max_braking_caused": caused, "max_braking_without_truck": alone,
            "others_time_loss": loss, "others_time_loss_without_truck": 8.0, "road_violation": False,
            "passages": 5, "recorded_seconds": 30.0, "entry": None, "others": {}}  # fmt: skip


def cell(driver: str, runs: list[dict]) -> dict:
    return {"cell": f"truck_q900_{driver}", "vehicle": "truck", "rate": 900.0, "driver": driver, "seed": 0,
            "demand_q": 0.25, "runs": runs}  # fmt: skip


def test_mean_ci_is_students_t_by_hand():
    mean, half = traffic_table.mean_ci([1.0, 2.0, 3.0])
    assert mean == 2.0 and half == pytest.approx(4.302653 / 3**0.5, rel=1e-6)  # t(0.975, 2) sd / sqrt(n), sd = 1
    assert traffic_table.mean_ci([4.0]) == (4.0, None) and traffic_table.mean_ci([]) == (None, None)


def test_a_cell_row_counts_runs_and_compares_braking_with_the_run_without_the_truck():
    row = traffic_table.flat(cell("autopilot", [run(0, 1.0, 4.5, 4.5), run(1, 3.0, 6.0, 4.5, arrived=False)]))
    assert row["arrived_text"] == "1/2" and row["harder_text"] == "1/2"  # 6.0 against 4.5 without the truck
    assert (row["max_braking"], row["max_braking_without"]) == (6.0, 4.5)
    assert row["everyone"] == pytest.approx((1.0 + 2.0 + 3.0 + 2.0) / 2)  # delay + loss 10 - 8 without the truck
    assert row["delay_text"].startswith("2 ± ")


def test_the_section_names_every_column_with_its_unit(tmp_path):
    paths = []
    for driver in ("autopilot", "sumo"):
        p = tmp_path / f"truck_q900_{driver}.json"
        p.write_text(json.dumps(cell(driver, [run(0, 1.0, 4.5, 4.5), run(1, 2.0, 4.5, 4.5)])))
        paths.append(str(p))
    section = tmp_path / "85-traffic.md"
    cmd = [sys.executable, str(ROOT / "workflows" / "scripts" / "traffic_table.py"), "--cells", *paths,
           "--mode", "test", "--vehicles", "truck", "--rates", "900", "--drivers", "autopilot", "sumo", "--runs", "2",
           "--out", str(tmp_path), "--figure-link", "comparison.png", "--section", str(section)]  # fmt: skip
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    text = section.read_text()
    headers = [line for line in text.splitlines() if line.startswith("| vehicle") or line.startswith("| drivers")]
    assert len(headers) >= 4
    for name in ("arrived (runs / runs)", "same runs without the truck (m/s²)", "truck's delay, mean ± 95 % CI (s)",
                 "t_c max. likelihood ± SE (s)", "autopilot (s)"):  # fmt: skip
        assert name in text, name
    assert "| 2/2 |" in text and (tmp_path / "table.csv").exists() and (tmp_path / "comparison.png").exists()
