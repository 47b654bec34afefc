"""What the steps of one search share: the problem and grid, the solver's settings, what was tried, the clock.

``solve_ocp`` (``model.search.multistart``) makes one ``Search`` and hands it to each step
(screening, cold starts, smooth routes, the road's steps, continuation, accuracy). Every Ipopt
run of the search goes through ``Search.solve``: the body formulation and the Ipopt options are
the search's, and with a time limit (its ``Budget``, ``model.search.budget``, which the map search
keeps too) each run gets the time left as ``max_wall_time`` (``max_cpu_time``) and the
starts not begun in time are counted as skipped (``Search.record_of_search`` is summary.json's
``search``). The first validated (analysed) start of a search always runs, for at least
``MIN_WALL_TIME``, so even a budget too small for anything leaves an answer or the evidence of a
failure; screening solves (guesses only) get no such grace.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from model.analysis.columns import Columns
from model.direct.bodies import DEFAULT_FORMULATION
from model.direct.solution import Solution
from model.direct.solve import NOT_BELOW, Start, solve_starts
from model.problem.ocp import OCP
from model.search.accuracy import CONVERGED
from model.search.budget import Budget
from model.search.starts import distinct_starts, passes_to_try, start_values

MIN_WALL_TIME = 0.1  # s: the first start of a search runs at least this long whatever the budget left
CAP_SLACK = 1.0  # s: a timed-out run with less than this left was ended by the time limit, not by run_cap
TIMED_OUT = ("time_limit", "wall_time_limit")  # Ipopt's words for a run its time limit ended


class Reporter:
    """The search's progress: phase lines as given, start lines numbered as they are printed."""

    def __init__(self, sink: Callable[[str], None] | None) -> None:
        self.sink, self.count = sink, 0

    def __call__(self, line: str) -> None:
        if self.sink is not None:
            self.sink(line)

    def start(self, sol: Solution, passing: str, scale, route: str) -> None:
        """One line for a solved start: its number, pass, route, and its outcome."""
        self.count += 1
        below = sol.validation.get("skipped") == NOT_BELOW
        unchecked = " (not validated: not below the best)" if below else " (not validated)"
        outcome = (f"objective {sol.objective:.8g}" + ("" if sol.ok else unchecked)
                   if sol.status in ("optimal", "acceptable") else "no answer")  # fmt: skip
        self(f"[{self.count}] pass {passing}, start {route} x{scale:g}: {sol.status}, {outcome}, "
             f"{sol.iterations} iterations, {sol.timings['ipopt']:.2f} s in Ipopt")  # fmt: skip


def reporter(progress: Callable[[str], None] | Reporter | None) -> Reporter:
    """``progress`` as a Reporter (wrapped once: an inner search shares the outer one's numbering)."""
    return progress if isinstance(progress, Reporter) else Reporter(progress)


@dataclass
class Search:
    """One search's shared state (see the module docstring).

    Parameters
    ----------
    ocp, intervals : the problem and N.
    verbose : show Ipopt's iteration log.
    options : the caller's Ipopt options (they override every step's own).
    formulation : the bodies' NLP formulation on a road (``model.direct.bodies.FORMULATIONS``).
    progress : the progress lines.
    time_limit : seconds for the whole search from ``started`` (None: no limit).
    run_cap : seconds one Ipopt run may take at most (None: the time left); set by ``solve_ocp`` on a
        tight road so that a first start cannot spend the whole budget before the geometry continuation.
    reserve : seconds at the end of the time limit no run begins or continues in (``deadline`` is that
        much earlier): the last run's analysis and the output files of a road with bodies take them.
    clock : what ``time_limit`` counts (``model.direct.solve.CLOCKS``): "wall" seconds (the default) or the
        process's "cpu" seconds (a study's cells on shared cores: the same budget whatever the load).
    """

    ocp: OCP
    intervals: int
    verbose: bool = False
    options: dict = field(default_factory=dict)
    formulation: str = DEFAULT_FORMULATION
    progress: Reporter = field(default_factory=lambda: Reporter(None))
    time_limit: float | None = None
    started: float | None = None  # the clock's reading at the start (None: now)
    attempts: list[dict] = field(default_factory=list)
    solutions: list[Solution] = field(default_factory=list)
    starts_skipped: int = 0
    steps_skipped: list[str] = field(default_factory=list)
    stopped: bool = False  # the time limit cut something short
    run_cap: float | None = None  # s: no one Ipopt run of the search takes longer (None: only the time limit)
    reserve: float = 0.0  # s of the time limit kept for analysing the last run and writing the results
    clock: str = "wall"
    evidence: list[dict] = field(default_factory=list)  # the minimal-violation diagnoses computed (shared by copies)
    models: dict = field(default_factory=dict)  # the models built, reused by later steps (``solve_starts``' models)

    def __post_init__(self) -> None:
        self.started = Budget(self.time_limit, self.clock, self.started, self.reserve).started  # (checks the clock)

    @property
    def budget(self) -> Budget:
        """The search's time budget (``model.search.budget``): ``time_limit`` of ``clock`` from ``started``, less
        ``reserve``. Made from those fields whenever asked, so that a copy of the search (``dataclasses.replace``)
        or a changed field never keeps a stale one."""
        return Budget(self.time_limit, self.clock, self.started, self.reserve)

    def now(self) -> float:
        """The search clock's reading (``time.monotonic()`` or ``time.process_time()``)."""
        return self.budget.now()

    @property
    def deadline(self) -> float | None:
        """The clock's instant the budget ends, ``reserve`` before the limit (None: no limit)."""
        return self.budget.deadline

    def remaining(self) -> float | None:
        """Seconds left (negative once over; None: no limit)."""
        return self.budget.remaining()

    def expired(self) -> bool:
        """Whether the time limit has passed."""
        return self.budget.expired()

    def skip(self, step: str, starts: int = 0) -> bool:
        """True (and ``step`` and its ``starts`` noted as skipped) if the time limit has passed.

        Never before the search's first analysed start (it always runs: ``Search.solve``): ``Budget.skip``, the rule
        the map search applies too.
        """
        if not self.budget.skip(step, self.answered(), self.steps_skipped, self.stop):
            return False
        self.starts_skipped += starts
        return True

    def best_evidence(self) -> dict | None:
        """The evidence of a failure the search computed (``evidence``): the first minimal violation whose
        solve converged, else the last one (None if none), so that a refusal keeps it whatever ended the search."""
        converged = [e for e in self.evidence if e.get("relaxed_status") in CONVERGED]
        if converged:
            return converged[0]
        return self.evidence[-1] if self.evidence else None

    def answered(self) -> bool:
        """Whether a start has been solved and analysed (validated): an answer or the evidence of a failure."""
        return any(sol.validation.get("skipped") is None for sol in self.solutions)

    def stop(self) -> None:
        """Mark the search as cut short by its time limit; the first time, one progress line.

        Without a time limit nothing (a run ended by the caller's own Ipopt ``max_wall_time`` is no stop).
        """
        if not self.stopped and self.time_limit is not None:
            self.stopped = True
            self.progress(self.budget.reached("the search"))

    def solve(
        self,
        intervals: int,
        passing: str,
        starts: Sequence[Start],
        extra: dict | None = None,
        relax: bool = False,
        analyse: bool = True,
        formulation: str | None = None,
        skip_worse: bool = False,
    ) -> list[Solution]:
        """``model.direct.solve_starts`` with the search's settings; the starts the budget left out are skipped.

        ``extra``: a step's own Ipopt options (the caller's ``options`` override them).
        ``formulation``: another body formulation than the search's for this call.
        ``skip_worse``: a start that does not end below the best validated objective on this grid so far
        is not analysed (``solve_starts``' ``analyse_below``; for the steps that only choose the best).
        """
        first = MIN_WALL_TIME if analyse and not self.answered() else None  # the search's first answer always comes
        capped = {self.budget.run_option: self.run_cap} if self.run_cap is not None else {}
        distinct, index = distinct_starts(list(starts))  # a start equal to an earlier one gets its answer
        solved = solve_starts(self.ocp, intervals, passing, distinct, self.verbose,
                              {**capped, **(extra or {}), **self.options}, relax, analyse,
                              formulation or self.formulation, self.deadline, first, self.clock,
                              analyse_below=self.least_validated(intervals) if skip_worse and not relax else None,
                              models=self.models)  # fmt: skip
        answered = next((k for k, i in enumerate(index) if i >= len(solved)), len(index))  # those the budget left
        sols = [solved[i] for i in index[:answered]]
        if len(sols) < len(starts):
            self.starts_skipped += len(starts) - len(sols)
            self.stop()
        if any(sol.status in TIMED_OUT for sol in sols) and (self.run_cap is None or self.remaining() < CAP_SLACK):
            self.stop()  # (a run ended by run_cap alone is no stop of the search)
        self.solutions.extend(solved)
        return sols

    def least_validated(self, intervals: int) -> float | None:
        """The least objective of a validated answer to the search's own problem on N = ``intervals`` (inf: none)."""
        return min((s.objective for s in self.solutions if s.ok and s.ocp is self.ocp and s.intervals == intervals),
                   default=math.inf)  # fmt: skip

    def record(self, sol: Solution, passing: str, scale, route: str) -> None:
        """An attempt of the summary and a progress line for a solved start."""
        self.attempts.append({"pass": passing, "tf_guess_scale": scale, "route": route, "status": sol.status,
                              "valid": sol.ok, "objective": sol.objective})  # fmt: skip
        self.progress.start(sol, passing, scale, route)

    def values(
        self, passing: str, guess: Columns | None = None, scale: float = 1.0, route: str = "arc",
        intervals: int | None = None,
    ) -> Start:  # fmt: skip
        """``start_values`` on ``intervals`` (default the search's N)."""
        return start_values(self.ocp, intervals or self.intervals, passing, guess, scale, route)

    def absorb(self, inner: dict) -> None:
        """Count what an inner search (continuation) skipped for lack of time (its ``record_of_search``)."""
        self.starts_skipped += int(inner.get("starts_skipped", 0))
        if inner.get("stopped_by_time_limit"):
            self.stop()

    def record_of_search(self, level: str) -> dict:
        """summary.json's ``search``: the level, the time limit and whether it cut the search short."""
        return {"level": level, "time_limit": self.time_limit, "clock": self.clock,
                "stopped_by_time_limit": self.stopped, "starts_skipped": self.starts_skipped,
                "steps_skipped": list(self.steps_skipped)}  # fmt: skip


def better(a: Solution, b: Solution) -> bool:
    """``a`` before ``b``: validated before not, then the lower objective."""
    if a.ok != b.ok:
        return a.ok
    return a.objective is not None and (b.objective is None or a.objective < b.objective)


SAME_OPTIMUM = 1e-6  # relative: a later step's answer replaces the one so far only if better by more


def clearly_better(sol: Solution | None, best: Solution | None) -> bool:
    """``sol`` replaces ``best``: better (``better``), and by more than SAME_OPTIMUM where both validate
    (the same optimum found again leaves the earlier answer standing)."""
    if sol is None:
        return False
    if best is None:
        return True
    if not better(sol, best):
        return False
    return not (best.ok and sol.objective > best.objective * (1 - SAME_OPTIMUM))


def cold_starts(
    search: Search, starts: Sequence[tuple[float, str]], guess: Columns | None, best: Solution | None
) -> Solution | None:
    """Every start of every pass direction at N; the best so far (``best`` may be None)."""
    for passing in passes_to_try(search.ocp):
        if search.skip(f"cold starts (pass {passing})", len(starts)):
            continue
        values = [search.values(passing, guess, scale, route) for scale, route in starts]
        solved = search.solve(search.intervals, passing, values, skip_worse=True)
        for (scale, route), sol in zip(starts, solved, strict=False):
            search.record(sol, passing, scale, route)
            if best is None or better(sol, best):
                best = sol
    return best


__all__ = ["MIN_WALL_TIME", "SAME_OPTIMUM", "Reporter", "Search", "better", "clearly_better", "cold_starts",
           "reporter"]  # fmt: skip
