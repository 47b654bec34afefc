"""Two sections of the paper that state the same quantity from different files state the same value (issue 46).

- C = 2E/Tf at the seed paper's cases: the trade-off section (61, from results/studies/pareto/pareto.json)
  against the scenario table (30, from results/tables/scenarios.csv: the case's E and Tf). The trade-off
  section once interpolated C between the points of its coarse front (0.4537 for s1 where 2E/Tf = 0.449: C is
  convex in Tf, so the chord lies above it); now it prints each case's own 2E/Tf.
- The points of each time-energy front: the number the front table states, the points pareto.csv holds and
  the samples the second table lists (first, middle and last of them).
- The closed-loop study's open-loop optimum (80, from its row.json) against the scenario it re-solves (30): its
  energy and final time.

The checks run on sections rendered from small synthetic results (no solves) and, when a build is present,
on results/sections (or the results tree named by $PAPER_RESULTS).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import closed_loop_section  # noqa: E402
import studies_pareto  # noqa: E402
import tables  # noqa: E402

from model.studies.sweeps import front_statements  # noqa: E402

RESULTS = Path(os.environ.get("PAPER_RESULTS", ROOT / "results"))
U_MAX = (1.0, 0.35)
# closed-loop geometry -> the paper scenario it re-solves (workflows/scenarios/closed-loop/<geometry>.toml's header)
SAME_OPTIMUM = {"s2": "s2-case1"}
CASES = {"s1": ("s1", 1.15, 0.2584003), "s2-case2": ("s2", 1.7, 0.4273933), "s2-case3": ("s2", 2.5, 0.2883446)}


# -- reading the sections -------------------------------------------------------------------------
def half_unit(printed: str) -> float:
    """Half a unit of the last printed digit of a decimal number: its rounding error."""
    mantissa = printed.lower().split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(printed.lower().split("e")[1]) if "e" in printed.lower() else 0
    return 0.5 * 10.0 ** (exponent - decimals)


def table_rows(text: str, first_header: str) -> list[list[str]]:
    """The cells of the pipe table whose header starts with ``| first_header |``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first_header} |"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def scenario_table(text: str) -> dict[str, tuple[str, str]]:
    """Each scenario's printed (Tf, E) in the scenario table."""
    return {r[0].strip("`"): (r[3], r[5]) for r in table_rows(text, "scenario")}


def stated_c(text: str) -> dict[str, str]:
    """The C = 2E/Tf the trade-off section states at each of the paper's cases."""
    sentence = re.search(r"At the paper's cases C[^:]*: ([^\n]*)\.", text)
    assert sentence, "the trade-off section states no C at the paper's cases"
    return {case: value for case, value in (item.split() for item in sentence.group(1).split(", "))}


def c_mismatches(scenarios: str, pareto: str) -> list[str]:
    """The cases whose stated C differs from 2E/Tf of the scenario table beyond the printed digits."""
    table, out = scenario_table(scenarios), []
    for case, c in stated_c(pareto).items():
        tf, energy = table[case]
        expected = 2 * float(energy) / float(tf)
        slack = half_unit(c) + 2 * half_unit(energy) / float(tf) + expected * half_unit(tf) / float(tf)
        if abs(float(c) - expected) > slack:
            out.append(f"{case}: C = {c} in the trade-off section, 2E/Tf = {expected:.4f} in the scenario table")
    assert stated_c(pareto), "no case to compare"
    return out


def front_counts(pareto: str) -> dict[str, int]:
    """The converged points of each front as the front table states them."""
    return {r[0]: int(r[2]) for r in table_rows(pareto, "geometry") if len(r) > 3 and r[2].isdigit()}


def listed_samples(pareto: str) -> dict[str, list[float]]:
    """The final times the samples table lists for each front."""
    samples: dict[str, list[float]] = {}
    lines = pareto.split("Table: Samples", 1)[1]
    for r in table_rows(lines, "geometry"):
        samples.setdefault(r[0], []).append(float(r[1]))
    return samples


def front_mismatches(pareto: str, fronts: pd.DataFrame) -> list[str]:
    """Fronts whose stated count, pareto.csv's converged points and the listed samples disagree."""
    out, counts, samples = [], front_counts(pareto), listed_samples(pareto)
    for key, grp in fronts[fronts.ok].groupby("front"):
        tfs = sorted(grp.final_time_set)
        if counts.get(key) != len(tfs):
            out.append(f"{key}: {counts.get(key)} points stated, {len(tfs)} converged in pareto.csv")
        listed = samples.get(key, [])
        if len(listed) != min(3, len(tfs)) or not np.allclose([listed[0], listed[-1]], [tfs[0], tfs[-1]], atol=1e-4):
            out.append(f"{key}: samples {listed} are not the first, middle and last of {len(tfs)} points")
    return out


def closed_loop_optima(text: str) -> dict[str, tuple[str, str]]:
    """Each closed-loop geometry's open-loop optimum as its section prints it: (Tf, energy)."""
    optimum = r"\*\*(\S+)\*\*: [^\n]*?Open-loop optimum: objective \S+, energy (\S+) \([^)]*\), Tf (\S+) s"
    found = re.findall(optimum, text)
    return {geometry: (tf, energy) for geometry, energy, tf in found}


def optimum_mismatches(scenarios: str, closed_loop: str) -> list[str]:
    """The closed-loop optima whose energy or Tf differs from the scenario table's beyond the printed digits."""
    table, optima, out = scenario_table(scenarios), closed_loop_optima(closed_loop), []
    for geometry, name in SAME_OPTIMUM.items():
        if geometry not in optima or name not in table:
            continue
        for what, mine, theirs in zip(("Tf", "E"), optima[geometry], table[name], strict=True):
            if abs(float(mine) - float(theirs)) > half_unit(mine) + half_unit(theirs):
                out.append(f"{geometry}: {what} = {mine} in the closed-loop section, {theirs} for {name}")
    return out


# -- synthetic sections -----------------------------------------------------------------------------
def scenario_frame() -> pd.DataFrame:
    """The scenario table's records for the synthetic cases (the columns tables.markdown prints)."""
    rows = [
        {"scenario": name, "objective": "energy", "solved": True, "validation": "passed", "status": "solved",
         "final_time": tf, "printed_final_time": tf, "energy": e, "printed_energy": 50.0, "iterations": 20,
         "local_optima": 1, "solve_seconds": 1.0, "accuracy_note": None, "paper_key": None}
        for name, (_, tf, e) in CASES.items()
    ]  # fmt: skip
    return pd.DataFrame(rows)


def synthetic_front(key: str, length: float) -> pd.DataFrame:
    """Six converged points of J = L^2 / (2 Tf) (a path of length L at constant speed), denser near 1 s."""
    tf = 1.0 + 2.0 * np.linspace(0.0, 1.0, 6) ** 2
    return pd.DataFrame({"front": key, "ok": True, "final_time_set": tf, "objective": length**2 / (2 * tf),
                         "iterations": 10})  # fmt: skip


def pareto_section(fronts: pd.DataFrame) -> str:
    """The trade-off section of the synthetic fronts, with the synthetic cases' own (Tf, E)."""
    marks = [{"front": k, "case": c, "final_time": tf, "energy": e} for c, (k, tf, e) in CASES.items()]
    verdicts = {}
    for key, grp in fronts.groupby("front"):
        own = {m["case"]: (m["final_time"], m["energy"]) for m in marks if m["front"] == key}
        verdicts[key] = front_statements(grp, own, U_MAX) | {"t_min": 0.99}
    return studies_pareto.section(verdicts, marks, fronts, Path("x.png"))


@pytest.fixture
def fronts() -> pd.DataFrame:
    return pd.concat([synthetic_front("s1", 0.7), synthetic_front("s2", 0.9)], ignore_index=True)


def test_trade_off_c_per_case_is_the_scenario_tables_2e_over_tf(fronts):
    pareto = pareto_section(fronts)
    assert set(stated_c(pareto)) == set(CASES)
    assert c_mismatches(tables.markdown(scenario_frame()), pareto) == []


def test_a_c_interpolated_between_front_points_is_caught(fronts):
    """The old statement (C interpolated on the front's chord) is off by more than the printed digits."""
    pareto = pareto_section(fronts)
    stated = stated_c(pareto)
    good = fronts[fronts.front == "s1"]
    chord = np.interp(CASES["s1"][1], good.final_time_set, 2 * good.objective / good.final_time_set)
    old = pareto.replace(f"s1 {stated['s1']}", f"s1 {chord:.4f}")
    assert [m.split(":")[0] for m in c_mismatches(tables.markdown(scenario_frame()), old)] == ["s1"]


def test_points_per_front_stated_listed_and_computed_agree(fronts):
    pareto = pareto_section(fronts)
    assert front_counts(pareto) == {"s1": 6, "s2": 6}
    assert front_mismatches(pareto, fronts) == []
    fewer = fronts.drop(index=[1])
    assert front_mismatches(pareto, fewer) == ["s1: 6 points stated, 5 converged in pareto.csv"]


def closed_loop_text(energy: float) -> str:
    """The closed-loop section of one synthetic s2 row whose optimum spends ``energy`` in the case's Tf."""
    tf = CASES["s1"][1]
    numbers = dict.fromkeys(closed_loop_section.ACCURACY, 0.0) | {"runs": 1, "reach_rate": 1.0, "violations": 0,
                                                                   "failed_steps": 0}  # fmt: skip
    numbers |= dict.fromkeys(("position_error_mean", "position_error_worst", "heading_error_mean",
                              "heading_error_worst", "energy_ratio_mean", "energy_ratio_worst", "min_clearance",
                              "step_seconds_mean", "step_seconds_max", "realtime_factor"), 0.5)  # fmt: skip
    row = {"geometry": "s2", "title": "A case", "level": 0.0, "controller": "mpc", "objective": "energy",
           "weights": {}, "sample_time": 0.05, "horizon": 40, "numbers": numbers, "criteria": None,
           "optimum": {"energy": energy, "objective": energy, "final_time": tf, "certified": True},
           "goal_tolerance": {"position": 0.02, "angle": 0.05},
           "level1_disturbance": {"speed_gain": 1.0, "steering_bias": 0.0, "drift": [0, 0], "wheelbase": {},
                                  "delay": 0.0, "noise": 0.0}}  # fmt: skip
    return closed_loop_section.section([row], "demo", None)


def test_the_closed_loop_optimum_is_the_scenario_tables():
    frame = scenario_frame().assign(scenario=["s2-case1", "s2-case2", "s2-case3"])
    energy = CASES["s1"][2]
    assert list(closed_loop_optima(closed_loop_text(energy))) == ["s2"]
    assert optimum_mismatches(tables.markdown(frame), closed_loop_text(energy)) == []
    assert optimum_mismatches(tables.markdown(frame), closed_loop_text(energy * 1.01)) == [
        f"s2: E = {energy * 1.01:.6g} in the closed-loop section, {energy:.4g} for s2-case1"
    ]


# -- the built paper ----------------------------------------------------------------------------------
def built(*names: str) -> list[Path]:
    paths = [RESULTS / name for name in names]
    if not all(p.exists() for p in paths):
        pytest.skip(f"no built {', '.join(names)} under {RESULTS}")
    return paths


def test_built_sections_state_one_c_per_case():
    scenarios, pareto = built("sections/30-scenarios.md", "sections/61-pareto.md")
    assert c_mismatches(scenarios.read_text(), pareto.read_text()) == []


def test_built_fronts_state_the_points_they_hold():
    pareto, csv = built("sections/61-pareto.md", "studies/pareto/pareto.csv")
    assert front_mismatches(pareto.read_text(), pd.read_csv(csv)) == []


def test_built_closed_loop_optimum_is_the_scenario_tables():
    scenarios, closed_loop = built("sections/30-scenarios.md", "sections/80-closed-loop.md")
    assert optimum_mismatches(scenarios.read_text(), closed_loop.read_text()) == []
