"""The search's time budget: ``roundabout solve --time-limit SECONDS`` and ``solve_ocp(..., time_limit=...)``."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from model.direct.solve import wall_time_options
from model.problem.scenario import load_scenario
from tests.conftest import EXAMPLE, ROOT

ROAD = ROOT / "examples" / "roundabout-truck.toml"
STOP_LINE = "reached: the search stops"


def cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "model.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT)  # fmt: skip


@pytest.mark.parametrize("value", ["0", "-1", "-0.5", "abc", "nan", ""])
def test_a_time_limit_that_is_not_a_positive_number_exits_2_with_one_line(tmp_path, value):
    out = tmp_path / "out"
    res = cli("solve", EXAMPLE, "--out", out, f"--time-limit={value}")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "--time-limit" in lines[0] and "Traceback" not in res.stderr
    assert not out.exists()


def test_the_default_budget_is_in_the_help():
    assert "--time-limit SECONDS" in cli("solve", "--help").stdout
    assert "default 300" in cli("solve", "--help").stdout.replace("\n", " ").replace("  ", " ")


def test_a_tiny_budget_on_a_road_ends_near_it_with_a_marked_answer_or_a_diagnosis(tmp_path):
    """1 s for a search that takes about 6 s (N = 30): the answer so far, marked, or exit 1 with the evidence.

    The margin covers what is not interrupted: the one model built before the budget ran out and
    the validation of its answers (1.0 s over at a load average of 5 on 2 cores); Ipopt's own time
    stays within the budget (``max_wall_time``).
    """
    out = tmp_path / "out"
    t0 = time.perf_counter()
    res = cli("solve", ROAD, "--out", out, "--intervals", 30, "--time-limit", 1)
    wall = time.perf_counter() - t0
    assert res.returncode in (0, 1), res.stderr
    summary = json.loads((out / "summary.json").read_text())
    search = summary["search"]
    assert search["time_limit"] == 1.0 and search["stopped_by_time_limit"] is True
    assert search["starts_skipped"] + len(search["steps_skipped"]) >= 1
    assert summary["timings"]["all_starts"]["ipopt"] <= 1.0 + 0.5
    assert summary["solve_seconds"] <= 1.0 + 10.0, summary["timings"]
    assert wall < 60.0
    assert res.stderr.count(STOP_LINE) == 1
    if res.returncode == 0:
        assert summary["valid"] is True
        assert "the time limit of 1 s stopped the search" in res.stdout
    else:
        diagnosis = summary["diagnosis"]
        assert diagnosis["kind"] == "time limit" and diagnosis["attempts_by_status"]
        assert "within the time limit of 1 s" in diagnosis["message"]


def test_a_generous_budget_changes_nothing():
    """With time to spare the search is the same: same attempts, same objective, not marked as stopped."""
    from model.problem.scenario import load_scenario

    ocp = load_scenario(EXAMPLE).ocp
    free = ocp.solve(intervals=30)
    timed = ocp.solve(intervals=30, time_limit=300.0)
    assert timed.ok and timed.objective == pytest.approx(free.objective, rel=1e-9)
    assert [a["route"] for a in timed.attempts] == [a["route"] for a in free.attempts]
    assert timed.search["stopped_by_time_limit"] is False and timed.search["time_limit"] == 300.0
    assert free.search["time_limit"] is None
    with pytest.raises(ValueError, match="time_limit"):
        ocp.solve(intervals=30, time_limit=0)


def test_each_ipopt_run_gets_the_time_left():
    assert wall_time_options({"tol": 1e-8}, None) == {"tol": 1e-8}
    assert wall_time_options({}, time.monotonic() - 1.0) is None
    assert wall_time_options({}, time.monotonic() - 1.0, floor=0.1) == {"max_wall_time": 0.1}
    left = wall_time_options({}, time.monotonic() + 50.0)["max_wall_time"]
    assert 49.0 < left <= 50.0
    assert wall_time_options({"max_wall_time": 5.0}, time.monotonic() + 50.0)["max_wall_time"] == 5.0


def test_a_batch_gives_each_scenario_its_own_budget(tmp_path):
    res = cli("solve", EXAMPLE, ROAD, "--out", tmp_path / "b", "--intervals", 30, "--time-limit", 2, "--quiet")
    assert res.returncode in (0, 1), res.stderr
    for name in ("format-example", "roundabout-truck"):
        summary = json.loads((tmp_path / "b" / name / "summary.json").read_text())
        assert summary["search"]["time_limit"] == 2.0
        assert summary["solve_seconds"] <= 2.0 + 10.0
        assert summary["attempts"]  # the second scenario's search ran: the first one's clock is not its clock


def test_a_proof_of_infeasibility_stands_when_the_budget_runs_out():
    """Tf below the Reeds-Shepp bound (tests/test_diagnosis.py): the proof, not "time limit", is the diagnosis."""
    import math

    from model import OCP, Energy, Truck

    ocp = OCP(vehicle=Truck(wheelbase=0.5), cost=Energy(), final_time=1.2,
              bounds={"u1": (-1.0, 1.0), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)},
              initial={"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0},
              final={"x": 1.0, "y": 0.0, "theta": math.pi})  # fmt: skip
    sol = ocp.solve(intervals=30, time_limit=0.05)
    assert not sol.ok and sol.search["stopped_by_time_limit"] is True
    assert sol.diagnosis["kind"] == "proven bound"


class _Answer:
    """A stand-in analysed solution of a given status."""

    def __init__(self, status: str):
        self.status, self.validation, self.ok = status, {"passed": status == "optimal"}, status == "optimal"


def test_the_search_counts_what_the_budget_left_out_and_says_so_once(monkeypatch):
    """Search.solve: the first answer always comes (with a floor on its wall time), later starts are counted."""
    import model.search.context as context
    from model.problem.scenario import load_scenario

    calls = []

    def fake_solve_starts(ocp, n, passing, starts, verbose, options, relax, analyse, formulation, deadline, first,
                          clock="wall", **_):
        calls.append((len(starts), first))
        return [_Answer("wall_time_limit")] if first else []  # past the deadline only a floored first start runs

    monkeypatch.setattr(context, "solve_starts", fake_solve_starts)
    lines = []
    search = context.Search(load_scenario(EXAMPLE).ocp, 20, progress=context.Reporter(lines.append), time_limit=1e-3)
    time.sleep(0.01)
    assert search.expired() and not search.skip("screening")  # nothing answered yet: never skipped
    assert len(search.solve(20, "ccw", [None, None, None])) == 1
    assert search.solve(20, "cw", [None, None]) == []
    assert search.skip("smooth routes", 4)
    assert calls == [(3, context.MIN_WALL_TIME), (2, None)]
    record = search.record_of_search("default")
    assert record["stopped_by_time_limit"] is True and record["starts_skipped"] == 2 + 2 + 4
    assert record["steps_skipped"] == ["smooth routes"]
    assert sum("reached: the search stops" in line for line in lines) == 1


def test_the_final_time_walk_stops_at_the_time_limit(monkeypatch):
    """The homotopy's warm re-solves get the budget's options, and none is begun once it is spent."""
    import model.search.continuation as continuation

    solved = []

    class FakeResolver:
        def __init__(self, solution):
            pass

        def solve(self, final_time, options=None):
            solved.append((final_time, options))
            return _Answer("optimal")

    class Easy:
        ok, final_time = True, 8.0

    monkeypatch.setattr(continuation, "Resolver", FakeResolver)
    lines = []
    assert continuation._walk_down(Easy(), 4.0, lines.append, lambda: None) is None
    assert solved == [] and "time limit" in lines[-1]
    found = continuation._walk_down(Easy(), 4.0, lines.append, lambda: {"max_wall_time": 7.0})
    assert found is not None and len(solved) == continuation.STEPS
    assert {options["max_wall_time"] for _, options in solved} == {7.0}


def test_the_callers_own_ipopt_wall_time_is_not_the_search_time_limit():
    """--ipopt max_wall_time ends runs as before; without --time-limit nothing is marked as stopped by it."""
    from model.problem.scenario import load_scenario

    sol = load_scenario(EXAMPLE).ocp.solve(intervals=20, options={"max_wall_time": 1e-3}, search="quick",
                                           continuation=False)  # fmt: skip
    assert sol.status == "wall_time_limit"
    assert sol.search["time_limit"] is None and sol.search["stopped_by_time_limit"] is False


def test_a_cpu_clock_counts_the_process_time_and_bounds_ipopt_by_max_cpu_time():
    """With ``clock="cpu"`` sleeping spends none of the budget, and a run gets ``max_cpu_time``, not the wall's."""
    from model.search import context

    search = context.Search(load_scenario(EXAMPLE).ocp, 20, time_limit=0.05, clock="cpu")
    time.sleep(0.1)  # wall time passes, hardly any CPU
    assert not search.expired()
    wall = context.Search(load_scenario(EXAMPLE).ocp, 20, time_limit=0.05)
    time.sleep(0.1)
    assert wall.expired()
    capped = wall_time_options({}, time.process_time() + 5.0, clock="cpu")
    assert set(capped) == {"max_cpu_time"} and 4.0 < capped["max_cpu_time"] <= 5.0
    assert search.record_of_search("default")["clock"] == "cpu"
    with pytest.raises(ValueError, match="clock"):
        context.Search(load_scenario(EXAMPLE).ocp, 20, clock="sundial")


def test_the_search_keeps_the_first_converged_minimal_violation_as_its_evidence():
    from model.search import context

    search = context.Search(load_scenario(EXAMPLE).ocp, 20)
    assert search.best_evidence() is None
    cut = {"kind": "minimal violation", "relaxed_status": "wall_time_limit", "message": "cut"}
    search.evidence.append(cut)
    assert search.best_evidence() is cut  # the only one, though its solve was cut
    done = {"kind": "minimal violation", "relaxed_status": "validation_failed", "message": "converged"}
    search.evidence += [done, {"kind": "minimal violation", "relaxed_status": "optimal", "message": "later"}]
    assert search.best_evidence() is done
