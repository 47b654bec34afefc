"""Feasibility first where the steady turn cuts the inner edge (issue 22: the WB-62 at ICD 45 m)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from model.problem.scenario import load_scenario
from model.search import multistart, road
from tests.conftest import ROOT

LIMITS = ROOT / "benchmarks" / "limits"


@pytest.fixture(scope="module")
def wb62():
    return load_scenario(LIMITS / "wb62-45m-left.toml").ocp


def test_only_the_wb62_steady_turn_cuts_its_inner_edge(wb62):
    """The WB-62's trailer is 0.137 m over the apron's inner edge in the steady turn at the outer curb;
    the other limits scenarios' steady turns keep inside (the mini roundabout's misses the outer curb)."""
    assert road.cuts_inner_edge(wb62)
    for name in ("eu-annulus-uturn", "semi-30m-uturn", "mini-18m-straight"):
        assert not road.cuts_inner_edge(load_scenario(LIMITS / f"{name}.toml").ocp), name


def test_with_a_time_limit_the_continuation_comes_before_the_cold_starts(wb62, monkeypatch):
    """No Ipopt run before the continuation: the stand-in is called first (and stops the search)."""
    called = []

    def stand_in(search, best):
        called.append((best, len(search.solutions)))
        raise RuntimeError("stop: the continuation was reached")

    monkeypatch.setattr(multistart, "geometry_continuation", stand_in)
    with pytest.raises(RuntimeError, match="continuation was reached"):
        multistart.solve_ocp(wb62, intervals=10, time_limit=30.0)
    assert called == [(None, 0)]


def _solved(status, validation, u1=(), tf=50.0, slack=0.0):
    model = SimpleNamespace(slack_total=slack, body_formulation="corners")
    return SimpleNamespace(status=status, validation=validation, columns={"u1": np.asarray(u1, float)},
                           final_time=tf, intervals=100, ok=validation.get("passed") is True, model=model,
                           diagnosis=None, objective=tf)  # fmt: skip


def test_zero_violation_at_the_nodes_is_reported_with_its_cusps_and_the_steady_bound(wb62):
    failed = {"passed": False, "checks": {"dense_clearance": {"passed": False}, "defects": {"passed": True}},
              "measures": {"min_clearance_integrated": -0.96}}  # fmt: skip
    fast = _solved("validation_failed", failed, u1=[5, 10, -4, -10, 0.1, 3, 10, -2, 6])  # four cusps (0.1: standing)
    got = road.feasibility_diagnosis(wb62, fast, 0.0, fast)
    assert got["kind"] == "zero violation at the nodes" and got["cusps"] == 4
    assert got["failed_checks"] == ["dense_clearance"] and got["min_clearance_integrated_m"] == -0.96
    assert got["steady_turn"]["inner_body"] == "trailer"
    assert got["steady_turn"]["inner_margin"] == pytest.approx(-0.137, abs=1e-3)
    assert "0.137 m inside" in got["message"] and "4 cusps" in got["message"]


def test_failed_road_resolves_from_a_zero_violation_answer_whose_validation_failed(wb62):
    """Ipopt converged on the minimal-violation problem with zero slack, a check failed: it is a trajectory
    inside the corridor at the nodes, so the problem is solved again from it (before: only "optimal")."""
    calls = []
    good = _solved("optimal", {"passed": True})

    def fake_solve(intervals, passing, starts, extra=None, relax=False, analyse=True, formulation=None):
        calls.append(relax)
        return [_solved("validation_failed", {"passed": False, "checks": {}}, slack=1e-9)] if relax else [good]

    search = SimpleNamespace(formulation="corners", intervals=20, solve=fake_solve,
                             values=lambda passing, guess=None: guess)  # fmt: skip
    got = road.failed_road(search, _solved("wall_time_limit", {"passed": False}), start=object())
    assert calls == [True, False]
    assert got is good and got.diagnosis["via"] == "minimal violation"


def test_a_converged_answer_a_finer_grid_may_cure_ends_the_walk(wb62):
    """With ``reached`` the walk stops at the scenario's road on an answer that is not validated;
    without it the failed step is halved (x0.25, ...)."""
    from model.search import geometry_continuation as gc

    def walk(reached):
        asked = []

        def step(problem, last):
            asked.append(problem.name)
            return SimpleNamespace(ok=False, status="optimal" if "relaxed" in problem.name else "validation_failed",
                                   objective=60.0)  # fmt: skip

        found, _ = gc.shrink_road(wb62, step, lambda line: None, lambda: False, reached)
        return found, asked

    found, asked = walk(lambda sol: sol.status == "validation_failed")
    assert len(asked) == len(gc.SCALES) and found.status == "validation_failed"
    _, asked = walk(None)
    assert len(asked) > len(gc.SCALES)


def test_a_converged_minimal_violation_on_the_scenarios_road_is_a_refusal_with_evidence():
    """Only a converged minimal-violation diagnosis ends the search; a cut one or a valid answer does not."""

    def answer(ok, kind, status, metres=0.5):
        return SimpleNamespace(ok=ok, diagnosis={"kind": kind, "relaxed_status": status, "encroachment_m": metres})

    assert road.refused_with_evidence(answer(False, "minimal violation", "validation_failed"))
    assert road.refused_with_evidence(answer(False, "minimal violation", "optimal"))
    assert not road.refused_with_evidence(answer(False, "minimal violation", "wall_time_limit"))
    assert not road.refused_with_evidence(answer(False, "minimal violation not converged", "optimal"))
    assert not road.refused_with_evidence(answer(True, "minimal violation", "optimal"))
    assert not road.refused_with_evidence(None)
    assert not road.refused_with_evidence(answer(False, "minimal violation", "optimal", 0.004))  # within tolerance


def test_feasibility_first_walks_from_the_roomiest_road_straight_to_the_scenarios(wb62):
    """``FEASIBILITY_SCALES``: x1 then the scenario's road; a failed last step is halved (x0.5) as before."""
    from model.search import geometry_continuation as gc

    asked = []

    def step(problem, last):
        asked.append(problem.name)
        own = "relaxed" not in problem.name
        return SimpleNamespace(ok=False, status="validation_failed" if own else "optimal", objective=60.0)

    gc.shrink_road(wb62, step, lambda line: None, lambda: False, lambda sol: False, road.FEASIBILITY_SCALES)
    assert asked[:2] == [f"{wb62.name} (relaxed x1)", wb62.name]
    assert asked[2] == f"{wb62.name} (relaxed x0.5)"


def _coarse_search(wb62, time_limit, answer):
    asked = []

    def fake_solve(intervals, passing, starts, extra=None, relax=False, analyse=True, formulation=None):
        asked.append((intervals, relax, formulation))
        return [answer]

    search = SimpleNamespace(ocp=wb62, intervals=60, time_limit=time_limit, solve=fake_solve, evidence=[],
                             values=lambda passing, guess=None, intervals=None: intervals,
                             record=lambda *a: None)  # fmt: skip
    return search, asked


@pytest.mark.parametrize("node_metres, refused", [(3.7, True), (0.2, False)])
def test_a_far_too_tight_road_is_refused_on_half_the_grid(wb62, monkeypatch, node_metres, refused):
    """With a time limit the minimal violation is solved on N / 2 first; it ends the search only where a body
    is at least ``COARSE_EVIDENCE_M`` outside at the nodes, else the search goes on on N (None)."""
    answer = _solved("validation_failed", {"passed": False}, slack=5.0)
    diagnosis = {"kind": "minimal violation", "relaxed_status": "validation_failed", "encroachment_m": node_metres,
                 "node_encroachment_m": node_metres, "message": "the trailer crosses the island"}  # fmt: skip
    monkeypatch.setattr(road, "feasibility_diagnosis", lambda ocp, mv, violation, fast: dict(diagnosis))
    search, asked = _coarse_search(wb62, 60.0, answer)
    got = road.coarse_refusal(search, _solved("optimal", {"passed": False}))
    assert asked == [(30, True, "corners")]
    assert (got is answer) is refused
    if refused:
        assert got.diagnosis["intervals"] == 30 and "on N = 30" in got.diagnosis["message"]
        assert road.refused_with_evidence(got) and search.evidence == [got.diagnosis]


def test_no_coarse_refusal_without_a_time_limit_or_from_a_zero_violation(wb62):
    search, asked = _coarse_search(wb62, None, None)
    assert road.coarse_refusal(search, _solved("optimal", {"passed": False})) is None and asked == []
    search, asked = _coarse_search(wb62, 60.0, _solved("validation_failed", {"passed": False}, slack=1e-9))
    assert road.coarse_refusal(search, _solved("optimal", {"passed": False})) is None and len(asked) == 1


def test_the_wb67_in_a_40_m_ring_is_refused_on_half_the_grid():
    """The design table's WB-67 at ICD 40 m without apron: its trailer metres over the island on N = 30 already
    (measured 3.70 m; 3.62 m on N = 60), so the search ends there with that evidence."""
    import tomllib

    from model.problem.scenario import parse_scenario
    from model.studies.roads import cell_document

    template = tomllib.loads((ROOT / "workflows" / "scenarios" / "roads" / "left-turn.toml").read_text())
    ocp = parse_scenario(cell_document(template, "WB-67", 40, 0, 60)).ocp
    sol = multistart.solve_ocp(ocp, intervals=60, time_limit=60.0, clock="cpu")
    assert not sol.ok and sol.diagnosis["intervals"] == 30
    assert sol.diagnosis["body"] == "trailer" and sol.diagnosis["node_encroachment_m"] > 2.0
    routes = [a.get("route", "") for a in sol.attempts]
    assert any(r.startswith("geometry continuation, minimal violation on N = 30") for r in routes)
