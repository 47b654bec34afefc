"""What a new user meets on the command line: readable outputs, progress, Ctrl-C, check = solve, plot."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from model.cli.progress import Progress
from model.outputs import run_folder, write_atomically

ROOT = Path(__file__).resolve().parents[1]
FORMAT = ROOT / "examples" / "format-example.toml"
TRUCK = ROOT / "examples" / "roundabout-truck.toml"


def cli(*args, umask: int = 0o022, **kw) -> subprocess.CompletedProcess:
    def child():
        os.umask(umask)

    return subprocess.run([sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, preexec_fn=child, **kw)  # fmt: skip


def files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}


def test_write_atomically_keeps_the_umask(tmp_path):
    old = os.umask(0o027)
    try:
        path = write_atomically(tmp_path / "a" / "b.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    assert [p.name for p in path.parent.iterdir()] == ["b.txt"]  # no temporary file left


def test_a_failed_run_leaves_its_folder_as_it_was(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text("old")
    with pytest.raises(KeyboardInterrupt), run_folder(out) as stage:
        write_atomically(stage / "summary.json", "new")
        write_atomically(stage / "trajectory.csv", "new")
        raise KeyboardInterrupt
    assert files_under(out) == {"summary.json"} and (out / "summary.json").read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # the staging folder is gone


@pytest.fixture(scope="module")
def used_folder(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """A folder that held a road solve and a closed loop (and a user's own file), solved into again."""
    out = tmp_path_factory.mktemp("used") / "out"
    for name in ("swept_path.geojson", "closed_loop.csv", "runs.csv", "figure.png", "optimum/summary.json",
                 "optimum/trajectory.csv", "summary.json", "notes.txt"):  # fmt: skip
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_text("earlier run")
    return out, cli("solve", FORMAT, "--out", out, "--intervals", 30)


def test_a_solve_into_a_used_folder_leaves_no_file_of_the_earlier_run(used_folder):
    out, res = used_folder
    assert res.returncode == 0, res.stderr
    assert files_under(out) == {"summary.json", "trajectory.csv", "scenario.toml", "notes.txt"}
    assert json.loads((out / "summary.json").read_text())["name"] == "format-example"
    assert (out / "notes.txt").read_text() == "earlier run"  # not a file this project writes


def test_outputs_are_readable_by_others_and_the_folder_is_named(used_folder):
    out, res = used_folder
    for path in out.rglob("*"):
        assert stat.S_IMODE(path.stat().st_mode) & 0o044 == 0o044, path
    assert str(out) in res.stdout.splitlines()[-1] and "summary.json" in res.stdout


def test_quiet_prints_no_progress(tmp_path):
    res = cli("solve", FORMAT, "--out", tmp_path / "q", "--intervals", 20, "--quiet")
    assert res.returncode == 0 and res.stderr == "", res.stderr


def test_start_lines_are_numbered_as_printed(tmp_path):
    res = cli("solve", FORMAT, "--out", tmp_path / "n", "--intervals", 60)
    numbers = [int(line.split("]")[0].strip(" [")) for line in res.stderr.splitlines() if line.startswith("  [")]
    assert numbers and numbers == list(range(1, len(numbers) + 1)), res.stderr


def test_the_heartbeat_speaks_when_nothing_else_does(tmp_path):
    """The watcher is a process of its own: it speaks while this one holds the GIL (a C loop here)."""
    log = tmp_path / "progress.txt"
    with log.open("w") as stream, Progress(stream=stream, quiet_seconds=0.3) as progress:
        progress.activity = "building the model"
        deadline = time.monotonic() + 1.2
        while time.monotonic() < deadline:
            sum(range(10**6))  # a busy main thread
    lines = log.read_text().splitlines()
    assert len(lines) >= 2 and all("building the model" in line for line in lines), lines
    silent = tmp_path / "silent.txt"
    with silent.open("w") as stream, Progress(stream=stream, quiet=True, quiet_seconds=0.1) as progress:
        progress("a phase")
        time.sleep(0.5)
    assert silent.read_text() == ""


def test_the_heartbeat_speaks_while_the_gil_is_held(tmp_path):
    """A C call that never releases the interpreter lock (re.match on a pathological pattern)."""
    import re

    log = tmp_path / "progress.txt"
    with log.open("w") as stream, Progress(stream=stream, quiet_seconds=0.3) as progress:
        progress.activity = "inside C"
        t0 = time.monotonic()
        re.match(r"(a+)+$", "a" * 24 + "b")  # catastrophic backtracking, GIL held throughout
        held = time.monotonic() - t0
    if held > 1.0:
        assert len(log.read_text().splitlines()) >= 2, (held, log.read_text())


def test_check_refuses_what_solve_refuses(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text(FORMAT.read_text().replace("intervals = ", "intervals = 1000001 #"))
    checked, solved = cli("check", big), cli("solve", big, "--out", tmp_path / "big")
    assert checked.returncode == solved.returncode
    assert checked.stderr.split(", more than")[0] == solved.stderr.split(", more than")[0]  # free memory moves
    if solved.returncode == 2:  # machines with less than ~65 GiB free
        assert "needs about" in checked.stderr and not (tmp_path / "big").exists()


def test_ctrl_c_ends_with_one_line_exit_130_and_nothing_written(tmp_path):
    out = tmp_path / "interrupted"
    proc = subprocess.Popen([sys.executable, "-m", "model.cli", "solve", str(FORMAT), "--out", str(out),
                             "--intervals", "3000"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))  # fmt: skip
    first = proc.stderr.readline()  # the run has started (SIGINT ignored by the parent: the CLI re-arms it)
    time.sleep(3.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert "solving with N = 3000" in first
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "roundabout: interrupted; nothing was written"
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kind", ["road", "disc"])
def test_plot_draws_a_results_folder(tmp_path, kind):
    scenario, n = (TRUCK, 40) if kind == "road" else (FORMAT, 30)
    out = tmp_path / kind
    assert cli("solve", scenario, "--out", out, "--intervals", n, "--quiet").returncode == 0
    res = cli("plot", out)
    assert res.returncode == 0, res.stderr
    png = (out / "figure.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    assert ("to scale" in res.stdout) == (kind == "road")


def test_plot_refuses_what_it_cannot_draw(tmp_path):
    for args, key in (((tmp_path / "nothing",), "no such folder"), ((tmp_path,), "no summary.json"),
                      ((tmp_path, "--out", tmp_path / "f.gif"), "must end in")):  # fmt: skip
        res = cli("plot", *args)
        assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and key in res.stderr, res.stderr


def test_a_swallowed_interrupt_is_raised_again():
    """An interrupt that a C callback dropped (here: simply recorded) is raised again within about a second."""
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt), Progress(quiet=True) as progress:
        progress.interrupted = time.monotonic()
        time.sleep(10)
    assert time.monotonic() - t0 < 5
