"""benchmarks/curve_skip.py: the smooth-route skip rule read from a search's attempts (issue 22, point 3)."""

from __future__ import annotations

import json

import pytest

from benchmarks.curve_skip import outcome, study


def attempt(route: str, objective: float, valid: bool, status: str = "optimal") -> dict:
    return {"pass": "ccw", "route": route, "status": status, "valid": valid, "objective": objective}


COLD_AGREE = [attempt("arc", 3.0, True), attempt("reeds-shepp", 3.0 * (1 + 1e-8), False), attempt("arc", 5.0, False)]
SMOOTH = [attempt("screening N=40: hermite-x1", 2.7, None), attempt("refined from N=40", 2.7, True)]


def test_agreeing_cold_starts_and_a_better_smooth_route_is_a_lost_optimum():
    o = outcome(COLD_AGREE + SMOOTH, 1e-6)
    assert o["agree"] == 2 and o["fires"] and o["lost"] and o["gain"] == pytest.approx(-0.1)


def test_one_route_at_the_best_does_not_fire_and_no_smooth_search_is_not_counted():
    alone = [attempt("arc", 3.0, True), attempt("reeds-shepp", 3.1, False)]
    o = outcome(alone + SMOOTH, 1e-6)
    assert o["agree"] == 1 and not o["fires"] and not o["lost"]
    assert outcome(COLD_AGREE, 1e-6) is None  # no smooth route ran
    assert outcome([attempt("arc", 3.0, False, "infeasible")] + SMOOTH, 1e-6) is None  # no validated cold start
    worse = [attempt("screening N=40: sides-L", 3.5, None), attempt("refined from N=40", 3.5, True)]
    assert not outcome(COLD_AGREE + worse, 1e-6)["lost"]  # fires, but the smooth routes found nothing better


def test_the_study_counts_the_folders(tmp_path):
    for name, attempts in (("a", COLD_AGREE + SMOOTH), ("b", COLD_AGREE), ("c", COLD_AGREE[:1] + SMOOTH)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(json.dumps({"attempts": attempts}))
    s = study(tmp_path)
    assert s["scenarios"] == 3 and s["smooth_routes_ran"] == 2 and s["fires"] == 1
    assert set(s["lost"]) == {"a"} and set(s["smooth_routes_better"]) == {"a", "c"}
