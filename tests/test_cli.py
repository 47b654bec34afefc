"""The roundabout command: the contract's exit codes, outputs and bad inputs."""

import json
import subprocess
import sys

import pandas as pd
import pytest

from model.problem.scenario import load_scenario
from tests.conftest import EXAMPLE, ROOT


def run(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True, cwd=cwd or ROOT
    )


def test_help_lists_commands_and_exit_codes():
    out = run("--help").stdout
    for word in ("solve", "derive", "exit codes"):
        assert word in out


def test_cli_and_python_api_agree(tmp_path):
    res = run("solve", EXAMPLE, "--out", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    traj = pd.read_csv(tmp_path / "out" / "trajectory.csv")
    sc = load_scenario(EXAMPLE)
    sol = sc.ocp.solve(intervals=sc.intervals)
    assert summary["status"] == sol.status == "optimal"
    assert summary["objective"] == pytest.approx(sol.objective, rel=1e-9)
    assert summary["energy"] == pytest.approx(sol.energy, rel=1e-9)
    assert len(traj) == summary["intervals"] + 1 == 101
    assert (traj[["x", "y"]].to_numpy() - sol.trajectory[["x", "y"]].to_numpy()).max() < 1e-8


def test_solver_failure_exits_1_with_summary(tmp_path):
    bad = tmp_path / "short.toml"
    bad.write_text(
        EXAMPLE.read_text().replace("final_time = 4.5", "final_time = 2.0").replace("intervals = 100", "intervals = 30")
    )
    res = run("solve", bad, "--out", tmp_path / "out")
    assert res.returncode == 1
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["status"] != "optimal"


BAD = {
    "malformed": ("[vehicle\nmodel = 'truck'", "malformed TOML"),
    "unknown_model": (('model = "truck"', 'model = "bicycle"'), "vehicle.model"),
    "negative_wheelbase": (("wheelbase = 0.1", "wheelbase = -0.1"), "vehicle.wheelbase"),
    "reversed_bounds": (("u1 = [-1.0, 1.0]", "u1 = [1.0, -1.0]"), "bounds.u1"),
    "missing_initial": (("phi = 0.0\n\n[final]", "\n[final]"), "initial.phi"),
    "energy_without_tf": (("final_time = 4.5\n", ""), "problem.final_time"),
    "start_inside": (("center = [0.5, 0.03]", "center = [0.1, 0.03]"), "initial.x"),
    "misspelled_key": (("safety = 0.05", "saftey = 0.05"), "obstacles[0].saftey"),
    "unknown_top": (("[problem]", "[problme]"), "problme"),
    "wrong_type": (("radius = 0.2", 'radius = "big"'), "obstacles[0].radius"),
    "bad_pass": (("intervals = 100", 'intervals = 100\npass = "left"'), "problem.pass"),
    "too_far": (("final_time = 4.5", "final_time = 0.5"), "problem.final_time"),
    "infinite_tf": (("final_time = 4.5", "final_time = inf"), "problem.final_time: must be a finite number"),
    "huge_grid": (("intervals = 100", "intervals = 100000000"), "problem.intervals: N = 100000000 needs about"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_exits_2_with_one_line_and_writes_nothing(case, tmp_path):
    change, key = BAD[case]
    text = change if isinstance(change, str) else EXAMPLE.read_text().replace(*change)
    assert text != EXAMPLE.read_text()
    path = tmp_path / "bad.toml"
    path.write_text(text)
    out = tmp_path / "out"
    res = run("solve", path, "--out", out)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], res.stderr
    assert "Traceback" not in res.stderr
    assert not out.exists()


def test_derive_prints_the_pontryagin_system():
    out = run("derive", EXAMPLE)
    assert out.returncode == 0, out.stderr
    assert "p_phi' = -p_theta*u1/(d*cos(phi)**2)" in out.stdout  # the truck's adjoint for phi
    latex = run("derive", EXAMPLE, "--latex")
    assert latex.returncode == 0 and "\\" in latex.stdout


def test_check_validates_without_solving(tmp_path):
    assert run("check", EXAMPLE).returncode == 0
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("wheelbase = 0.1", "wheelbase = 0"))
    res = run("check", bad)
    assert res.returncode == 2 and "vehicle.wheelbase" in res.stderr


@pytest.mark.parametrize(
    ("option", "names"),
    [
        ("mumps_pivot_order", "KEY=VALUE"),
        ("no_such_option=1", "Ipopt rejected option no_such_option"),
        ("mu_strategy=bogus", "mu_strategy"),
        ("=3", "KEY=VALUE"),
    ],
)
def test_bad_ipopt_option_exits_2_and_writes_nothing(tmp_path, option, names):
    res = run("solve", EXAMPLE, "--out", tmp_path / "out", "--intervals", "20", "--ipopt", option)
    assert res.returncode == 2, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("roundabout: invalid input: --ipopt") and names in last
    assert not (tmp_path / "out").exists()


def test_ipopt_options_reach_the_solver(tmp_path):
    """Another linear-solver ordering: same optimum; the log shows the option was used."""
    res = run("solve", EXAMPLE, "--out", tmp_path / "out", "--intervals", "20", "--ipopt", "mumps_pivot_order=0",
              "--ipopt", "print_user_options=yes", "--verbose")  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "mumps_pivot_order = 0" in res.stdout + res.stderr
    assert run("solve", EXAMPLE, "--out", tmp_path / "ref", "--intervals", "20").returncode == 0
    objective = [json.loads((tmp_path / d / "summary.json").read_text())["objective"] for d in ("out", "ref")]
    assert objective[0] == pytest.approx(objective[1], rel=1e-7)


def test_out_naming_a_file_is_refused_before_any_work(tmp_path):
    existing = tmp_path / "taken"
    existing.write_text("keep me")
    res = run("solve", EXAMPLE, "--out", existing)
    assert res.returncode == 2
    expected = f"roundabout: invalid input: --out: {existing} exists and is not a folder"
    assert res.stderr.strip().splitlines() == [expected]
    assert existing.read_text() == "keep me"


def test_a_huge_override_is_refused_with_the_estimate(tmp_path):
    res = run("solve", EXAMPLE, "--out", tmp_path / "out", "--intervals", "100000000")
    assert res.returncode == 2 and "--intervals: N = 100000000 needs about" in res.stderr and "GiB" in res.stderr
    assert not (tmp_path / "out").exists()


def test_a_failed_write_leaves_no_half_written_file(tmp_path, monkeypatch):
    """Each output is written to a temporary file and renamed: an error mid-write leaves none."""
    import model.outputs as outputs

    sol = load_scenario(EXAMPLE).ocp.solve(intervals=20)
    calls = []

    def failing_replace(src, dst):
        calls.append(src)
        raise OSError("disk full")

    monkeypatch.setattr(outputs.os, "replace", failing_replace)
    with pytest.raises(OSError):
        sol.write(tmp_path / "out")
    assert calls and not (tmp_path / "out").exists() and list(tmp_path.iterdir()) == []  # nor a staging folder


def test_search_levels_trade_starts_for_time_and_keep_the_optimum(tmp_path):
    scenario = ROOT / "workflows" / "scenarios" / "time-s1.toml"
    found = {}
    for level in ("quick", "thorough"):
        res = run("solve", scenario, "--out", tmp_path / level, "--search", level)
        assert res.returncode == 0, res.stderr
        found[level] = json.loads((tmp_path / level / "summary.json").read_text())
    assert len(found["quick"]["attempts"]) == 1
    routes = [a["route"] for a in found["thorough"]["attempts"]]
    assert len(routes) > 8 and any(r.startswith("screening") for r in routes)
    assert found["thorough"]["objective"] <= found["quick"]["objective"] * (1 + 1e-6)
    bad = run("solve", scenario, "--out", tmp_path / "bad", "--search", "deep")
    assert bad.returncode == 2 and not (tmp_path / "bad").exists()
