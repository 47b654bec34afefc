"""Helpers shared by the studies scripts: results I/O, Markdown tables, figures.

``plt`` (pyplot on the Agg backend) is imported on first use: the per-cell scripts (a design-table cell,
a map-study cell, a traffic cell) import this module for ``write_json`` only, and pyplot with pandas
cost about 0.7 s of CPU per process (84 processes in the full design grid).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from model.outputs import write_atomically  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402


def parser(doc: str | None, results: bool = False) -> argparse.ArgumentParser:
    """The study scripts' common options: --out folder, --section Markdown file (and --results)."""
    ap = argparse.ArgumentParser(description=doc)
    if results:
        ap.add_argument("--results", type=Path, default=Path("results"))
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--section", type=Path, required=True)
    return ap


def scenario(name: str):
    """The OCP of workflows/scenarios/<name>.toml."""
    return load_scenario(ROOT / "workflows" / "scenarios" / f"{name}.toml").ocp


def solved(results: Path, name: str) -> SimpleNamespace | None:
    """A pipeline solve (results/scenarios/<name>) as .ocp/.trajectory/.summary; None if failed."""
    folder = results / "scenarios" / name
    summary = json.loads((folder / "summary.json").read_text())
    if summary.get("status") != "optimal" or not summary.get("valid"):
        return None
    import pandas as pd

    traj = pd.read_csv(folder / "trajectory.csv")
    return SimpleNamespace(ocp=scenario(name), trajectory=traj, summary=summary, ok=True)


def fmt(x, digits: int = 4) -> str:
    """A number for a table: significant digits, '-' for missing."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def table(rows: list[dict], columns: dict[str, str], digits: int = 4) -> str:
    """A Markdown table of ``rows``; ``columns`` maps keys to headers."""
    head = "| " + " | ".join(columns.values()) + " |"
    rule = "| " + " | ".join("---" for _ in columns) + " |"
    body = ["| " + " | ".join(fmt(r.get(k), digits) for k in columns) + " |" for r in rows]
    return "\n".join([head, rule, *body])


def write_json(path: Path, data) -> None:
    write_atomically(path, json.dumps(data, indent=2, default=_default) + "\n")


def _default(obj):
    if hasattr(obj, "item"):
        return obj.item()
    raise TypeError(type(obj))


def save(fig, stem: Path) -> None:
    stem.parent.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "pdf"):
        fig.savefig(stem.with_suffix(f".{ext}"), dpi=130, bbox_inches="tight")
    __getattr__("plt").close(fig)


def write_text(path: Path, text: str) -> None:
    write_atomically(path, text.rstrip() + "\n")


def run_and_leave(main) -> None:
    """Run a cell script's ``main``, then leave without tearing the interpreter down (``model.cli.leave``).

    Its files are written and closed by then (P ICD 25 m design cell: 8.2 -> 6.7-7.4 s of CPU per process).
    """
    from model.cli import leave

    main()
    leave(0)


def __getattr__(name: str):
    """``plt``: matplotlib.pyplot on the Agg backend, imported when a script first asks for it."""
    if name != "plt":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def limits_paragraph(df, switch: str) -> str:
    """How a study's vehicles were driven: at their presets' operational limits (with those limits), or not.

    ``df``: the study's rows (``operational``, ``preset``, ``initial_speed``, ``speed_bound``); ``switch``: the
    workflows/config.yaml key that turns the limits on and off.
    """
    from model.studies.roads import operational_text

    on = df[df.operational]
    if on.empty:
        return ("Every cell is solved with the kinematic model **without operational limits** (the speed a control: "
                f"it may jump; no acceleration or lateral-acceleration bound; `{switch}: true` in "
                "workflows/config.yaml applies them): each row's *limits* column sets what it reached beside what "
                "its preset allows.")
    speeds = {fmt(v, 3) for v in on.initial_speed.dropna()}
    bound = next((b for b in on.speed_bound if isinstance(b, list) and b), None)
    some = "Every vehicle runs" if len(on) == len(df) else (
        f"{len(on)} of the {len(df)} cells run (the others without them: the kinematic model, the speed a control)")
    return (f"{some} at **its preset's operational limits** (`[vehicle] operational = true`, "
            f"docs/dynamics-format.md; `{switch}: false` in workflows/config.yaml runs the kinematic "
            "model without them): the speed is the state v, the jerk the control; "
            + "; ".join(operational_text(p) for p in dict.fromkeys(on.preset))
            + (f". It enters at the crawl speed ({', '.join(sorted(speeds))} m/s: a start speed left free would let "
               "the minimum time choose how fast the vehicle arrives)" if speeds else ". It enters at its crawl speed")
            + " and leaves at any speed"
            + (f"; v in [{bound[0]:g}, {bound[1]:g}] m/s (the template's bound of the speed)" if bound else "")
            + ". Each row's *limits* column says what it reached.")  # fmt: skip


__all__ = [  # and plt (module __getattr__)
    "scenario",
    "solved",
    "table",
    "fmt",
    "write_json",
    "save",
    "write_text",
    "limits_paragraph",
]
