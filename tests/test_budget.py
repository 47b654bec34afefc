"""One time budget for both search drivers (issue 44): ``model.search.budget.Budget``.

The roundabout search (``Search``) and the map search (``MapSearch``) keep time with the same ``Budget`` (clock,
deadline, reserve, the skip rule: ``Budget.skip``), every Ipopt run of either takes its time from
``wall_time_options`` and every deadline test is ``model.direct.solve.expired``. Before, the map search kept its own
deadline on the wall clock and ``solve_map_route`` dropped ``clock`` (``**_ignored``): a CPU-time budget became wall
time on a map; now it names the options it does not use and refuses unknown ones.
"""

from __future__ import annotations

import inspect
import time
from types import SimpleNamespace

import pytest

from model.direct.solve import expired, wall_time_options
from model.problem.scenario import load_scenario
from model.search.budget import Budget
from model.search.context import Search, reporter
from model.search.maps import ROUNDABOUT_ONLY, MapSearch, solve_map_route
from model.search.multistart import solve_ocp
from tests.conftest import EXAMPLE, ROOT

KACKERT = ROOT / "examples" / "map-kackertstrasse-truck.toml"  # SU-30, left turn, objective "time"


def test_a_cpu_budget_does_not_count_sleep_and_a_wall_budget_does():
    cpu, wall = Budget(0.05, "cpu"), Budget(0.05)
    time.sleep(0.1)
    assert not cpu.expired() and cpu.remaining() > 0.0
    assert wall.expired() and wall.remaining() < 0.0


def test_the_deadline_is_the_reserve_before_the_limit_and_no_limit_never_expires():
    budget = Budget(100.0, started=5.0, reserve=20.0)
    assert budget.deadline == 85.0
    endless = Budget()
    assert endless.deadline is None and endless.remaining() is None and not endless.expired()
    assert endless.run_options({"tol": 1e-8}) == {"tol": 1e-8}


def test_the_skip_rule_skips_nothing_before_the_search_has_begun():
    over = Budget(1.0, started=time.monotonic() - 2.0)
    assert over.expired()
    assert not over.skips(False) and over.skips(True)
    assert not Budget(1e6).skips(True)


@pytest.mark.parametrize(("clock", "key"), [("wall", "max_wall_time"), ("cpu", "max_cpu_time")])
def test_a_run_gets_the_time_left_on_the_budgets_clock(clock, key):
    budget = Budget(10.0, clock)
    options = budget.run_options({"tol": 1e-8})
    assert budget.run_option == key and 9.0 < options[key] <= 10.0 and options["tol"] == 1e-8
    assert budget.run_options({key: 2.0})[key] == 2.0  # the caller's own smaller limit stands
    over = Budget(1.0, clock, started=budget.now() - 5.0)
    assert over.run_options({}) is None  # no time left: no run
    assert over.run_options({}, floor=0.5) == {key: 0.5}  # a run that must run gets the floor
    assert over.run_options({}) == wall_time_options({}, over.deadline, clock=clock)  # the one helper


def test_a_clock_that_is_not_wall_or_cpu_is_refused():
    with pytest.raises(ValueError, match="clock must be one of wall, cpu, got 'sundial'"):
        Budget(1.0, "sundial")


def test_the_roundabout_search_keeps_time_with_a_budget():
    search = Search(load_scenario(EXAMPLE).ocp, 10, time_limit=100.0, reserve=20.0, clock="cpu")
    assert search.budget == Budget(100.0, "cpu", search.started, 20.0)
    assert search.deadline == search.budget.deadline == pytest.approx(search.started + 80.0, abs=1e-9)
    search.reserve = 30.0  # the budget is the fields', never a stale copy
    assert search.deadline == pytest.approx(search.started + 70.0, abs=1e-9)


@pytest.fixture(scope="module")
def kackertstrasse():
    pytest.importorskip("commonroad")
    return load_scenario(KACKERT).ocp


@pytest.mark.parametrize("clock", ["cpu", "wall"])
def test_a_cpu_budget_is_honoured_on_a_map(kackertstrasse, clock):
    """A map search of 2.5 s whose progress sleeps 3 s before the first solve (wall time passes, no CPU time):
    on the wall clock the limit has passed when the first solve ends, so nothing more runs; on the CPU clock the
    sleep counts nothing and the centre-line sequence goes on past its first solve (about 0.6 s of CPU each)."""
    lines: list[str] = []

    def progress(line: str) -> None:
        if not lines:
            time.sleep(3.0)
        lines.append(line)

    sol = kackertstrasse.solve(intervals=20, time_limit=2.5, clock=clock, progress=progress)
    search = sol.search
    assert search["clock"] == clock and search["time_limit"] == 2.5
    solves = [len(s["solves"]) for s in search["sequences"]]
    if clock == "wall":
        assert solves == [1] and search["stopped_by_time_limit"]
        assert any("time limit of 2.5 s reached: the map search stops" in line for line in lines)
    else:
        assert solves[0] > 1 or len(solves) > 1, solves


def test_one_expiry_test_for_the_budget_the_starts_and_the_strip_solves():
    """``model.direct.solve.expired`` is the one deadline test: ``Budget.expired`` asks it, and so do ``solve_starts``
    (no start begins after the deadline) and ``solve_map`` (no strip solve but the first begins after it)."""
    assert not expired(None) and not expired(time.monotonic() + 10.0)
    assert expired(time.monotonic() - 1e-3) and not expired(time.process_time() + 10.0, "cpu")
    over = Budget(1.0, "cpu", started=time.process_time() - 2.0)
    assert over.expired() == expired(over.deadline, "cpu") is True


def test_both_drivers_skip_by_the_budgets_skip_and_report_the_stop_once():
    stops: list[str] = []
    over, skipped = Budget(1.0, started=time.monotonic() - 2.0), []
    assert not over.skip("screening", False, skipped, lambda: stops.append("stop"))  # not begun: nothing skipped
    assert over.skip("screening", True, skipped, lambda: stops.append("stop")) and skipped == ["screening"]
    assert not Budget(1e6).skip("continuation", True, skipped, lambda: stops.append("stop"))
    assert stops == ["stop"] and skipped == ["screening"]
    lines: list[str] = []
    search = Search(
        load_scenario(EXAMPLE).ocp, 10, time_limit=1.0, started=time.monotonic() - 2.0, progress=lines.append
    )
    search.solutions.append(SimpleNamespace(validation={}))  # an analysed start: the search has begun
    assert search.skip("screening", starts=3) and search.skip("continuation")
    assert search.steps_skipped == ["screening", "continuation"] and search.starts_skipped == 3 and search.stopped
    assert lines == ["time limit of 1 s reached: the search stops with what it has found"]
    runs: list[str] = []
    maps = MapSearch(None, 10, None, {}, reporter(runs.append), Budget(1.0, started=time.monotonic() - 2.0))
    assert not maps.skip("minimal violation")  # no sequence yet
    maps.sequences.append({})
    assert maps.skip("minimal violation") and maps.skip("arclength grid")
    assert maps.steps_skipped == ["minimal violation", "arclength grid"]
    assert runs == ["time limit of 1 s reached: the map search stops with what it has found"]


def test_the_map_search_names_the_roundabout_options_it_does_not_use_and_refuses_unknown_ones():
    """``solve_map_route`` took ``**_ignored`` and dropped whatever it was given (``clock`` too, before the Budget).
    Now the roundabout search's options are named (``ROUNDABOUT_ONLY``, the difference of the two signatures) and
    anything else is a TypeError, before any work."""
    ocp = load_scenario(EXAMPLE).ocp
    theirs = set(inspect.signature(solve_ocp).parameters) - set(inspect.signature(solve_map_route).parameters)
    assert theirs == set(ROUNDABOUT_ONLY)
    with pytest.raises(TypeError, match="unexpected keyword arguments: clocks, time_limt"):
        solve_map_route(ocp, 10, time_limt=5.0, clocks="cpu", formulation="corners")


def test_a_map_search_says_which_options_it_leaves_unused(kackertstrasse):
    lines: list[str] = []
    sol = solve_map_route(kackertstrasse, 12, time_limit=0.01, progress=lines.append, formulation="corners", guess=None)
    assert lines[0] == "map search: not used on a map: formulation, guess"
    assert sol.search["stopped_by_time_limit"] and len(sol.search["sequences"]) == 1
