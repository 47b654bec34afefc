"""Paper fragments of the study scripts (issue 46): every pipe table has a ``Table:`` caption right before it.

The sections are built from small synthetic results (no solves); the captions' numbers come from those
results, and the turning-circle script cites each preset's source with a key of paper/references.bib.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import paper_citations  # noqa: E402
import plant_study_section  # noqa: E402
import studies_convergence  # noqa: E402
import studies_pareto  # noqa: E402
import studies_roads_turning  # noqa: E402
import studies_wheelbase  # noqa: E402

from model.studies.plant_gap import RECORD_KEYS  # noqa: E402
from model.vehicles import PRESETS, preset  # noqa: E402


def captions_of_tables(text: str) -> list[str]:
    """The caption before each pipe table of ``text``; fails when a table has none (or no blank line between)."""
    blocks = [b.strip() for b in text.split("\n\n")]
    captions = []
    for i, block in enumerate(blocks):
        if block.startswith("|"):
            assert i > 0 and blocks[i - 1].startswith("Table: "), f"table without a caption: {block[:60]!r}"
            captions.append(blocks[i - 1])
    assert captions, "no table found"
    return captions


def test_convergence_table_is_captioned_with_units_in_its_headers():
    rows = [{"scenario": "s1", "grids": "100,200", "objective": 1.5, "unit": "s", "diffs": "1e-3", "order_J": "2.0"}]
    text = studies_convergence.section(rows, {"s1": [100, 200]})
    (caption,) = captions_of_tables(text)
    assert "one row per scenario" in caption
    assert "[@betts2010]" in text


def pareto_inputs(t_min: float) -> tuple[dict, list[dict], pd.DataFrame]:
    verdict = {"t_min": t_min, "points": 3, "failed": 0, "monotone_decreasing": True, "C_max": 0.2,
               "C_bound": 0.25, "C_ratio_at_tmin": 0.8, "C_at_cases": {"s1": 0.1}}  # fmt: skip
    front = pd.DataFrame({"front": "s1", "ok": True, "final_time_set": [1.0, 2.0, 3.0],
                          "objective": [0.3, 0.2, 0.1], "iterations": [10, 11, 12]})  # fmt: skip
    return {"s1": verdict}, [{"front": "s1", "case": "s1", "final_time": 2.0, "energy": 0.2}], front


def test_both_pareto_tables_are_captioned_and_the_seed_paper_cited():
    text = studies_pareto.section(*pareto_inputs(1.234), Path("x.png"))
    first, second = captions_of_tables(text)
    assert "one row per geometry" in first and "(s)" in first
    assert studies_pareto.ENERGY_UNIT in second
    assert "[@seed]" in text
    assert "| 1.2340 |" in text  # the table prints the result it is given, to 0.1 ms


def test_wheelbase_table_is_captioned():
    base = {"sweep": "paper s2", "d": 0.02, "status": "optimal", "certificate": True}
    frame = pd.DataFrame([
        {**base, "kind": "time", "ok": True, "final_time": 1.7, "objective": 1.7, "fixed_tf": None},
        {**base, "kind": "energy", "ok": True, "final_time": 2.0, "objective": 0.4, "fixed_tf": 2.0},
    ])  # fmt: skip
    (caption,) = captions_of_tables(studies_wheelbase.section(frame, Path("x.png")))
    assert "wheelbase d (m)" in caption


def plant_record(level: float) -> dict:
    """A synthetic manoeuvre record at ``level`` (every field of the table set)."""
    r = dict.fromkeys(RECORD_KEYS, 0.1) | {
        "vehicle": "truck", "preset": "SU-30", "manoeuvre": "right turn", "exit": 1, "status": "optimal",
        "intervals": 80, "lateral_acceleration_bound_mps2": level, "plan_valid": True, "safe": True,
        "plant_reached_goal": True, "plant_min_clearance_m": 0.05, "clearance_lost_m": 0.0,
    }  # fmt: skip
    return r


def test_plant_study_table_is_captioned_with_the_records_levels():
    text = plant_study_section.section([plant_record(1.5), plant_record(2.5)], "small", "x.png")
    (caption,) = captions_of_tables(text)
    assert "(1.5, 2.5 m/s^2)" in caption and "`small` grid" in caption
    assert "[@commonroadvehicles]" in text


def test_every_preset_source_is_cited_with_a_key_of_the_bibliography():
    keys = set(paper_citations.parse_bib((ROOT / "paper" / "references.bib").read_text()))
    sentence = studies_roads_turning.preset_sources(list(PRESETS))
    cited = paper_citations.cited_keys(sentence)
    assert set(cited) <= keys
    assert {"aashto2018", "directive9653", "commonroadvehicles"} <= set(cited)
    for name in PRESETS:
        assert name in sentence and preset(name)["source"] in sentence


@pytest.mark.parametrize(
    ("key", "value", "printed"),
    [
        ("inner", 5.34567, "5.346"),
        ("phi_deg", 20.0521, "20.05"),
        ("inner_margin", -0.07286, "-0.073"),
        ("inner", None, None),
    ],
)
def test_preset_rows_print_lengths_to_the_millimetre_and_angles_to_the_hundredth(key, value, printed):
    assert studies_roads_turning.preset_cells({key: value, "verdict": "yes"})[key] == printed


@pytest.mark.parametrize(("change", "printed"), [(1.02e-05, "0.47803"), (4.9e-03, "0.478"), (None, 0.4780312)])
def test_convergence_prints_j_to_the_decimal_of_its_last_change(change, printed):
    row = {"objective": 0.4780312, "last_change": change, "costate_change": 0.30372}
    assert studies_convergence.printed(row)["objective"] == printed
    assert studies_convergence.printed(row)["costate_change"] == "3.04e-01"
