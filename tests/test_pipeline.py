"""The Snakemake pipeline: dry run of everything, a real run of one scenario's figures, reruns after
an edit, the table and figures for a failed solve, the solve wrapper's exit codes, the paper builder,
and the SLURM profile."""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib
import pandas as pd
import pytest
import yaml

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "workflows" / "scripts"
SCENARIOS = ROOT / "workflows" / "scenarios"
sys.path.insert(0, str(SCRIPTS))

import paper_html  # noqa: E402
import paper_sections  # noqa: E402
import solve as solve_wrapper  # noqa: E402
import tables  # noqa: E402

from model.plotting import figures as plotting  # noqa: E402
from model.plotting.results import Result, comment_block  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed")


def snakemake(workdir: Path, *args: str, config: dict | None = None) -> subprocess.CompletedProcess:
    cmd = ["snakemake", "-s", str(ROOT / "Snakefile"), "--directory", str(workdir), *args]
    if config:
        cmd += ["--config", *(f"{k}={v}" for k, v in config.items())]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def job_counts(output: str) -> dict[str, int]:
    """The 'Job stats' table of a dry run as rule -> count."""
    assert "Job stats:" in output, output[-2000:]
    block = output.split("Job stats:", 1)[1]
    return {m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", block, re.M) if m[1] != "total"}


def test_dry_run_plans_every_solve_figure_table_and_the_paper(tmp_path):
    run = snakemake(tmp_path, "-n")
    assert run.returncode == 0, run.stderr
    jobs = job_counts(run.stdout + run.stderr)
    n = len(list(SCENARIOS.glob("*.toml")))
    assert jobs["solve"] == n and jobs["scenario_figures"] == n
    for rule in (
        "derivations",
        "scenario_table",
        "figure_phase_rate",
        "figure_paths",
        "paper_sections",
        "paper_html",
        "all",
    ):
        assert jobs[rule] == 1, rule


@pytest.fixture(scope="module")
def one_scenario(tmp_path_factory):
    """A real build of one scenario's figures, in a temporary working folder."""
    work = tmp_path_factory.mktemp("pipeline")
    shutil.copytree(SCENARIOS, work / "scenarios")  # a copy: the edit test touches it
    # PDF figures are the config switch's (the default draws PNG only): the build writes both
    config = {"scenarios": str(work / "scenarios" / "*.toml"), "figure_formats": "[pdf,png]"}
    run = snakemake(work, "-c2", "results/figures/s1/solution.png", config=config)
    assert run.returncode == 0, run.stderr[-3000:]
    return work, config


def test_one_scenario_builds_its_figures(one_scenario):
    work, _ = one_scenario
    summary = json.loads((work / "results/scenarios/s1/summary.json").read_text())
    assert summary["status"] == "optimal" and summary["exit_code"] == 0
    for name in ("solution", "costates"):
        for ext in ("png", "pdf"):
            assert (work / f"results/figures/s1/{name}.{ext}").stat().st_size > 10_000


def test_nothing_to_do_after_a_build_and_only_dependents_after_an_edit(one_scenario):
    work, config = one_scenario
    target = "results/figures/s1/solution.png"
    again = snakemake(work, "-n", target, config=config)
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr
    scenario = work / "scenarios" / "s1.toml"
    scenario.write_text(scenario.read_text() + "# an edit\n")  # a touch alone is no edit: checksums
    edited = snakemake(work, "-n", target, config=config)
    assert job_counts(edited.stdout + edited.stderr) == {"solve": 1, "scenario_figures": 1}


def failed(name: str = "bad") -> Result:
    summary = {
        "name": name,
        "status": "infeasible",
        "exit_code": 1,
        "valid": False,
        "final_time": 1.0,
        "energy": 0.1,
        "iterations": 3000,
        "solve_seconds": 9.0,
        "validation": {},
    }
    frame = pd.DataFrame({"t": [0.0, 1.0], "x": [0.0, 1.0], "y": [0.0, 0.0], "u1": [1.0, 1.0], "u2": [0.0, 0.0]})
    return Result(name, summary, frame)


def solved(name: str = "s1") -> Result:
    t = pd.Series([0.0, 0.5, 1.0])
    frame = pd.DataFrame(
        {
            "t": t,
            "x": t,
            "y": 0 * t,
            "theta": 0 * t,
            "phi": 0 * t,
            "u1": 1 + 0 * t,
            "u2": 0 * t,
            "psi_u1": 1 + 0 * t,
            "psi_u2": 0 * t,
            "H": 0 * t,
            "mu": 0 * t,
        }
    )
    summary = {
        "name": name,
        "status": "optimal",
        "exit_code": 0,
        "valid": True,
        "final_time": 1.0,
        "energy": 0.5,
        "iterations": 10,
        "solve_seconds": 0.5,
        "validation": {"defects": {"passed": True}},
    }
    return Result(name, summary, frame)


def test_table_shows_a_failed_solve_as_failed_without_numbers():
    claims = {"sec5.energy_bound.s1": {"id": "sec5.energy_bound.s1", "verdict": "fails", "evidence": "E too big"}}
    table = tables.build([solved(), failed()], [SCENARIOS / "s1.toml", SCENARIOS / "s1.toml"], {"s1": "s1"}, claims)
    good, bad = table.to_dict("records")
    assert good["status"] == "solved, validated" and good["printed_energy"] == pytest.approx(27.7)
    assert "sec5.energy_bound.s1" in good["energy_reason"]
    assert bad["status"] == "failed: infeasible" and not bad["solved"]
    assert pd.isna(bad["final_time"]) and pd.isna(bad["energy"])
    assert "| `bad` | – | failed: infeasible |" in tables.markdown(table)


def test_failed_solve_is_never_plotted():
    ocp = load_scenario(SCENARIOS / "s1.toml").ocp
    plotting.apply_style()
    fig = plotting.solution_figure(failed(), ocp)
    assert all(len(line.get_xdata()) == 0 for ax in fig.axes for line in ax.get_lines())
    assert any("SOLVE FAILED" in t.get_text() for ax in fig.axes for t in ax.texts)
    fig = plotting.phase_rate_figure([solved(), failed()], ["s1", "bad"])
    drawn = [ln.get_label() for ax in fig.axes for ln in ax.get_lines() if len(ln.get_xdata())]
    assert drawn and all(label == "s1" for label in drawn)


def test_solve_wrapper_records_exit_1_and_passes_exit_2(tmp_path, monkeypatch):
    monkeypatch.setattr(solve_wrapper, "command", lambda *a: [sys.executable, "-c", "import sys; sys.exit(1)"])
    assert solve_wrapper.main([str(SCENARIOS / "s1.toml"), "--out", str(tmp_path / "a")]) == 0
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["exit_code"] == 1 and summary["status"] == "error" and summary["valid"] is False
    assert (tmp_path / "a" / "trajectory.csv").read_text().startswith("t,x,y")
    monkeypatch.undo()
    bad = tmp_path / "bad.toml"
    bad.write_text((SCENARIOS / "s1.toml").read_text().replace("safety =", "saftey ="))
    assert solve_wrapper.main([str(bad), "--out", str(tmp_path / "b")]) == 2


def test_comment_block_bullets_are_read_from_scenario_files():
    notes = comment_block(SCENARIOS / "s3.toml")
    assert any(n.startswith("Tf = ") and "instead of the printed" in n for n in notes)


def test_paper_math_code_and_figures(tmp_path):
    fig = plotting.save(plotting.failed_figure(failed(), "x"), tmp_path / "f", ["png"])[0]
    display = "$$\\begin{aligned}a &= b\\\\ c &= d\\end{aligned}$$"
    text = f"# T\n\nInline $a^2$ and `$not math$`.\n\n{display}\n\n![cap]({fig})\n"
    html = paper_html.to_html(text, "", Path("/"))
    assert "<math" in html and "$not math$" in html and "<mtable>" in html
    assert 'src="data:image/png;base64,' in html and "Figure 1." in html


def test_unknown_placeholder_is_an_error():
    ctx = paper_sections.Context({"s1": solved()}, {"s1": SCENARIOS / "s1.toml"}, ["s1"], {}, "", "", Path("f"))
    assert paper_sections.render("{{ count SOLVED }} of {{ count SCENARIOS }}", ctx) == "1 of 1"
    with pytest.raises(KeyError):
        paper_sections.render("{{ typo }}", ctx)


def test_slurm_profile_parses_and_dry_runs(tmp_path):
    profile = ROOT / "workflows" / "profiles" / "slurm"
    conf = yaml.safe_load((profile / "config.yaml").read_text())
    assert conf["executor"] == "slurm" and conf["default-resources"]["runtime"] > 0
    extra = [] if importlib.util.find_spec("snakemake_executor_plugin_slurm") else ["--executor", "local"]
    run = snakemake(tmp_path, "-n", "--profile", str(profile), *extra)
    assert run.returncode == 0, run.stderr[-2000:]


def test_local_optima_counts_distinct_validated_objectives_on_the_search_grid():
    attempts = [
        {"route": "arc", "valid": True, "objective": 1.0},
        {"route": "line", "valid": True, "objective": 1.00001},  # the same optimum
        {"route": "reeds-shepp", "valid": True, "objective": 1.2},
        {"route": "arc", "valid": False, "objective": 0.5},  # not validated
        {"route": "screening N=40: all-reverse", "valid": None, "objective": 0.9},  # coarse
        {"route": "N=200 for accuracy", "valid": True, "objective": 0.99},  # another grid
    ]
    assert tables.local_optima(attempts) == 2
    assert tables.local_optima([]) == 0


def test_accuracy_note_names_the_grids_and_the_objective_on_n():
    summary = {"objective": 1.3326, "accuracy": {"intervals_requested": 100, "intervals": 200, "worst_state": "theta"},
               "attempts": [{"route": "arc", "valid": True, "objective": 1.3329},
                            {"route": "N=200 for accuracy", "valid": True, "objective": 1.3326}]}  # fmt: skip
    note = tables.accuracy_note(summary)
    assert "N = 100 (objective 1.3329 there)" in note and "N = 200: objective 1.3326" in note
    assert tables.accuracy_note({"accuracy": {"intervals_requested": 100, "intervals": 100}}) is None
