"""Time to quality: a start that cannot become the answer is not analysed, and a search builds each model once."""

from __future__ import annotations

from pathlib import Path

import pytest

import model.direct.solve as solve_module
from model.direct.solve import NOT_BELOW
from model.problem.scenario import load_scenario
from model.search.context import Search

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "workflows" / "scenarios" / "time-free.toml"


def solve_counting(monkeypatch, skip: bool):
    """The default search on the scenario, the model builds counted; ``skip`` False analyses every start."""
    builds, finished = [], []
    real, real_finish = solve_module.build_model, solve_module.finish

    def counting(*args, **kwargs):
        builds.append(args[1:3])
        return real(*args, **kwargs)

    def recording(*args, **kwargs):
        finished.append(real_finish(*args, **kwargs))
        return finished[-1]

    monkeypatch.setattr(solve_module, "build_model", counting)
    monkeypatch.setattr(solve_module, "finish", recording)
    if not skip:
        monkeypatch.setattr(Search, "least_validated", lambda self, intervals: None)
    sol = load_scenario(SCENARIO).ocp.solve(intervals=60)
    monkeypatch.undo()
    return sol, builds, finished


@pytest.fixture(scope="module")
def both():
    with pytest.MonkeyPatch.context() as mp:
        skipped = solve_counting(mp, skip=True)
    with pytest.MonkeyPatch.context() as mp:
        analysed = solve_counting(mp, skip=False)
    return skipped, analysed


def test_the_skipped_analyses_leave_the_answer_as_it_was(both):
    (sol, _, _), (full, _, _) = both
    assert sol.ok and full.ok
    assert sol.objective == pytest.approx(full.objective, rel=1e-9)
    assert sol.validation["passed"] and sol.certificate.get("passed") is not None  # the answer itself is analysed


def test_starts_not_below_the_best_are_marked_and_never_the_answer(both):
    (sol, _, finished), (_, _, analysed) = both
    skipped = [s for s in finished if s.validation.get("skipped") == NOT_BELOW]
    assert skipped, "no start was left unanalysed"
    assert not [s for s in analysed if s.validation.get("skipped") == NOT_BELOW]
    assert all(s.objective >= sol.objective for s in skipped) and all(not s.ok for s in skipped)
    assert len([s for s in finished if s.validation.get("passed") is not None]) < len(
        [s for s in analysed if s.validation.get("passed") is not None]
    )


def test_a_search_builds_each_model_once(both):
    (_, builds, _), _ = both
    assert builds and len(builds) == len(set(builds)), builds
