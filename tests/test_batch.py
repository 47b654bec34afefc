"""`roundabout solve A.toml B.toml ... --out DIR`: one process, one folder per scenario."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
A = ROOT / "examples" / "format-example.toml"
B = ROOT / "workflows" / "scenarios" / "time-s1.toml"


def cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT)  # fmt: skip


def test_a_batch_writes_one_folder_per_scenario_with_the_single_solves_answers(tmp_path):
    res = cli("solve", A, B, "--out", tmp_path / "batch", "--intervals", 30, "--quiet")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (tmp_path / "batch").iterdir()) == ["format-example", "time-s1"]
    assert res.stdout.splitlines()[-1].startswith("batch: 2 of 2 solved and validated")
    for path in (A, B):
        single = cli("solve", path, "--out", tmp_path / path.stem, "--intervals", 30, "--quiet")
        assert single.returncode == 0, single.stderr
        one = json.loads((tmp_path / path.stem / "summary.json").read_text())
        name = one["name"]
        batched = json.loads((tmp_path / "batch" / name / "summary.json").read_text())
        assert batched["objective"] == one["objective"] and batched["valid"]


def test_a_bad_file_in_a_batch_stops_it_before_anything_is_written(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(A.read_text().replace("wheelbase = ", "wheelbase = -"))
    for args, key in (((A, bad), str(bad)), ((A, A), "is also that of")):
        res = cli("solve", *args, "--out", tmp_path / "out")
        assert res.returncode == 2 and key in res.stderr and len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert not (tmp_path / "out").exists()


def test_solve_many_from_python_writes_the_folders_the_command_writes(tmp_path):
    from model import InputError, solve_many

    seen = []
    sols = solve_many([A, B], tmp_path / "py", intervals=30, on_solved=lambda sc, sol: seen.append(sc.ocp.name))
    assert seen == ["format-example", "time-s1"] and all(sol.ok for sol in sols)
    for sol, name in zip(sols, seen, strict=True):
        folder = tmp_path / "py" / name
        assert sorted(p.name for p in folder.iterdir()) == ["scenario.toml", "summary.json", "trajectory.csv"]
        assert json.loads((folder / "summary.json").read_text())["objective"] == sol.objective
    bad = tmp_path / "bad.toml"
    bad.write_text(A.read_text().replace("wheelbase = ", "wheelbase = -"))
    try:
        solve_many([A, bad], tmp_path / "none", intervals=30)
    except InputError as err:
        assert str(bad) in str(err)
    else:
        raise AssertionError("a bad file was accepted")
    assert not (tmp_path / "none").exists()
