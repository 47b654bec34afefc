"""model.direct.families: every row family of a built model is declared once, with its softness."""

from __future__ import annotations

import pyomo.environ as pyo
import pytest

from model.direct.families import Family, Transcription, transcription_of
from model.direct.options import Horizon, TranscriptionOptions
from model.direct.transcription import build_model
from model.problem.scenario import load_scenario
from tests.conftest import paper_energy_problem

ROAD = "workflows/roads/truck-straight-on.toml"  # a rigid truck's body on a road: island and corridor rows
HORIZON = Horizon(scales={"x": 1.0, "y": 1.0, "theta": 1.0, "phi": 1.0}, time_scale=2.0, energy_scale=3.0)


def test_a_family_refuses_an_unknown_kind_or_softness():
    with pytest.raises(ValueError, match="unknown"):
        Family("x", "curb")
    with pytest.raises(ValueError, match="unknown"):
        Family("x", "bound", softness="soft-ish")


def test_a_family_redeclared_with_another_kind_is_an_error():
    record = Transcription(("x",), ("u",))
    record.declare("articulation", "bound")
    with pytest.raises(ValueError, match="declared as bound/hard"):
        record.declare("articulation", "path")


def test_a_model_not_built_here_has_no_transcription():
    with pytest.raises(ValueError, match="no transcription"):
        transcription_of(pyo.ConcreteModel(name="bare"))


def test_the_scenario_model_declares_dynamics_per_state_and_a_hard_disc_keep_out():
    ocp = paper_energy_problem()
    m = build_model(ocp, 10)
    record = transcription_of(m)
    assert [row.local_name for row in record.dynamics()] == [f"d{s}_trapezoid" for s in ocp.vehicle.states]
    assert record.families["obstacle"].softness == "hard" and record.family_slacks("obstacle") == []
    assert set(record.initial) == set(ocp.initial) and record.slack_columns == []


def test_the_horizon_model_declares_its_soft_rows_and_terminal_slacks():
    m = build_model(paper_energy_problem(), 10, options=TranscriptionOptions(soft_penalty=1.0, horizon=HORIZON))
    record = transcription_of(m)
    assert record.families["obstacle"].softness == "slack" and record.family_slacks("obstacle") == [m.keep_out_slack]
    assert record.family_slacks("terminal") == [m.above, m.below] and record.families["terminal"].rows == [m.terminal]


def test_road_bodies_declare_their_rows_hard_and_relaxed_with_slacks():
    ocp = load_scenario(ROAD).ocp
    hard, relaxed = transcription_of(build_model(ocp, 10)), transcription_of(build_model(ocp, 10, relax=True))
    kinds = {f.kind for f in hard.of_kind("island", "corridor")}
    assert kinds == {"island", "corridor"} and all(f.softness == "hard" for f in hard.of_kind("island", "corridor"))
    assert hard.slack_columns == [] and hard.definitions  # the disc centres are defined points
    assert all(f.softness == "slack" for f in relaxed.of_kind("island", "corridor"))
    rows = sum(len(f.rows) for f in relaxed.of_kind("island", "corridor"))
    assert len(relaxed.slack_columns) == rows  # one slack column per relaxed row
