"""``roundabout plot DIR``: the figure of a results folder written by ``solve`` or ``simulate``.

A road solve gets the plan to scale with its bodies and its controls; a disc solve the
paper's four panels; a closed-loop run the driven path against the optimum. A failed solve
is drawn as a failure (its reason), never as a solution.
"""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

from model.errors import InputError
from model.outputs import write_atomically

FORMATS = (".png", ".pdf", ".svg")


def plot_folder(folder: Path, out: Path | None, scenario_file: Path | None) -> int:
    """Draw ``folder`` into ``out`` (default ``folder/figure.png``); the exit code (0, or 2 on bad input)."""
    try:
        out = _check_out(out if out is not None else folder / "figure.png")
        summary, scenario_file = _check_folder(folder, scenario_file)
        from model.problem.scenario import load_scenario

        ocp = load_scenario(scenario_file).ocp
    except InputError as err:
        print(f"roundabout: invalid input: {err}", file=sys.stderr)
        return 2
    fig, kind = figure(folder, ocp, summary)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=out.suffix[1:], metadata={"CreationDate": None} if out.suffix == ".pdf" else None)
    import matplotlib.pyplot as plt

    plt.close(fig)
    write_atomically(out, buffer.getvalue())
    print(f"{out}: {kind}")
    return 0


def _check_out(out: Path) -> Path:
    if out.suffix.lower() not in FORMATS:
        raise InputError("--out", f"{out}: the figure's file name must end in {', '.join(FORMATS)}")
    if out.exists() and out.is_dir():
        raise InputError("--out", f"{out} is a folder; name a file such as {out / 'figure.png'}")
    return out


def _check_folder(folder: Path, scenario_file: Path | None) -> tuple[dict, Path]:
    """The folder's summary and the scenario file to draw it with."""
    if not folder.is_dir():
        raise InputError("DIR", f"{folder}: no such folder")
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except FileNotFoundError:
        msg = f"{folder}: no summary.json (not a folder written by roundabout solve or simulate)"
        raise InputError("DIR", msg) from None
    except (OSError, ValueError) as err:
        raise InputError("DIR", f"{folder}/summary.json cannot be read ({err})") from None
    data = "closed_loop.csv" if (folder / "closed_loop.csv").exists() else "trajectory.csv"
    if summary.get("optimum") is None and not (folder / data).is_file():
        raise InputError("DIR", f"{folder}: no {data} beside summary.json")
    scenario_file = scenario_file or folder / "scenario.toml"
    if not scenario_file.is_file():
        raise InputError("--scenario", f"{folder} holds no scenario.toml: name the scenario file with --scenario FILE")
    return summary, scenario_file


def figure(folder: Path, ocp, summary: dict):
    """The figure of ``folder`` and a few words on what it shows."""
    import pandas as pd

    from model.plotting.results import load_result

    if (folder / "closed_loop.csv").is_file():
        from model.plotting.closed_loop import closed_loop_figure

        optimum = pd.read_csv(folder / "optimum" / "trajectory.csv")
        driven = pd.read_csv(folder / "closed_loop.csv")
        return closed_loop_figure(ocp, optimum, driven, summary), "closed loop against the optimum"
    if summary.get("optimum") is not None:  # simulate whose open-loop solve failed
        folder = folder / "optimum"
    result = load_result(folder, name=ocp.name)
    if not result.solved:
        from model.plotting.figures import failed_figure

        reason = (result.summary.get("diagnosis") or {}).get("message")
        if reason:
            result.summary.setdefault("failure", reason)
        return failed_figure(result, ocp.title or ocp.name), f"the solve failed ({result.status_text}), drawn as such"
    if ocp.road is not None:
        from model.plotting.roads import road_figure, road_note

        note = road_note(result.summary, ocp, result.trajectory)
        return road_figure(ocp, result.trajectory, note=note), "road manoeuvre to scale"
    from model.plotting.figures import solution_figure

    return solution_figure(result, ocp), "controls, states, path and energy"


__all__ = ["FORMATS", "figure", "plot_folder"]
