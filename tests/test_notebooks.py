"""The notebooks in paper/notebooks/ run as plain Python scripts (jupytext percent format)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "paper" / "notebooks").glob("*.py"))


def test_there_are_notebooks():
    names = {p.stem for p in NOTEBOOKS}
    assert {"04_roads_and_bodies", "05_closed_loop", "06_real_roundabout"} <= names  # issues 18, 21
    assert len(NOTEBOOKS) >= 6


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(notebook: Path, tmp_path: Path):
    assert notebook.read_text().startswith("# ---\n# jupyter:"), "jupytext header missing"
    assert "# %%" in notebook.read_text()
    run = subprocess.run(
        [sys.executable, str(notebook)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode == 0, run.stderr[-3000:]
