"""Reading the pipeline's results: scenario summaries, trajectories, notes and claims."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd


@dataclass
class Result:
    """One scenario's solve as the workflow recorded it."""

    name: str
    summary: dict
    trajectory: pd.DataFrame

    @property
    def solved(self) -> bool:
        """Solved and validated; anything else is a failure and is never plotted as a solution."""
        s = self.summary
        return s.get("exit_code", 0) == 0 and s.get("status") == "optimal" and s.get("valid") is True

    @property
    def status_text(self) -> str:
        if self.solved:
            return "solved, validated"
        status = self.summary.get("status", "error")
        return "failed: validation" if status == "optimal" else f"failed: {status}"


def load_result(directory: str | Path, name: str | None = None) -> Result:
    """summary.json and trajectory.csv of one solve folder."""
    import pandas as pd  # lazy: a job that only formats numbers does not pay pandas' import

    directory = Path(directory)
    summary = json.loads((directory / "summary.json").read_text())
    trajectory = pd.read_csv(directory / "trajectory.csv")
    return Result(name or summary.get("name") or directory.name, summary, trajectory)


def comment_block(path: str | Path) -> list[str]:
    """The bullets ("# - ...", continued by "#   ...") of a scenario file's leading comment block."""
    bullets: list[str] = []
    for line in Path(path).read_text().splitlines():
        if not line.startswith("#"):
            break
        text = line[1:].strip()
        if line[1:].lstrip().startswith("- "):
            bullets.append(text[2:].strip())
        elif bullets and text and line.startswith("#   "):
            bullets[-1] += " " + text
    return bullets


def load_claims(path: str | Path) -> dict[str, dict]:
    """claims.json as id -> claim."""
    return {c["id"]: c for c in json.loads(Path(path).read_text())}


def fmt(value: float | None, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; a dash for a missing one."""
    if value is None or (isinstance(value, float) and value != value):
        return "–"
    return f"{value:.{digits}g}"
