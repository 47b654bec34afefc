"""The search for map scenarios: sequences of corridor strip solves from several starts (docs/map-corridor.md).

``solve_map_route`` is ``OCP.solve``'s default method when the problem has a ``map_route``. One
*sequence* is ``model.direct.map_corridor.solve_map``: fixed-projection strip solves, re-projected
until the projections move less than 5 cm (at most 8 solves). The search runs, until one validates:

1. **centre line**: the sequence from the reference point driven along the route's centre line at
   half the speed bound (the first cut's only start; where it validates the answer is the same);
2. **finer grid**: where the answer fails only between the nodes (``BETWEEN_NODES``), the
   sequence on 2N from it (interpolated);
3. **minimal violation, then the strips**: the strip rows get slacks whose sum is minimised (the
   sequence of ``relax=True`` from the centre line: a continuation in the corridor's width that is
   always feasible); where its violation vanishes (< ``ZERO_VIOLATION``) or is small (< ``NEAR``
   m at most), the plain sequence from its answer; a positive minimum is the diagnosis;
3b. **the arclength grid** (``grid = "time+arclength"``, the default; not with ``search = "quick"``): where
   steps 1-3 validated nothing, the same on nodes fixed to equal steps of the route frame's arclength, the time
   free per interval (``solve_map(arclength=True)``, docs/map-corridor.md): the centre line, then for an answer
   failing only between the nodes the mid-interval rows and the finer grid, then the strips as an exact
   penalty (``PENALTY``); any validated solve of these sequences counts (``grid = "arclength"``: these steps
   alone, then step 3; ``"time"``: steps 1-4 as before the arclength grid);
3c. **tight strips** (after 3b's penalty sequence, where it converged needing at most ``TIGHT_NEAR`` m of slack
   and nothing validated): the penalty sequence again from its answer on strips measured tighter
   (``tight_strips``: the cover discs and the bounds' rounding smaller than the default's conservatism), and for
   an answer failing only between the nodes with the mid-interval rows, then (failing so still) on 2N from it,
   then backed off (``back_offs``: the node rows next to each interval whose integrated motion leaves the corridor
   narrowed by that depth + 5 mm);
4. **other speeds** (``search = "thorough"`` only): the centre-line start at other fractions of the
   speed bound (other Tf guesses), each a sequence. With a free Tf they reach the same fixed point
   as step 1 (measured on Thiergarten 21 -> 90, SU-30: the same eight Tf to 4 digits from 0.3, 0.5
   and 0.8), so the default search leaves them out;
5. **once more round the ring** (not with ``search = "quick"``): where steps 1-4 validated nothing and the route
   meets a cycle of successors (a roundabout's ring), steps 1-4 again on the route going once more round it
   (``MapRoute.looped``: the same corridor, the goal heading 2 pi further; ``looped_problem``). Kackertstrasse
   104 -> 85, EU semitrailer: the direct right turn converges 0.15-0.20 m outside the lanelets, once round the
   ring it validates (benchmarks/map-routes.md). Its answer is taken only where it validates (``route_loops`` in
   summary.json, a note on the command line); a refusal's diagnosis says what the loop reached.

The best validated answer (the lowest objective) is returned; with none, the failed answer whose
bodies leave the corridor least, with ``diagnosis``: which body leaves it where and by how much
(``model.analysis.maps``), the failed checks, and the minimal violation of step 3. ``time_limit``
(s of ``clock``, "wall" or "cpu") is honoured with the roundabout search's ``Budget`` (``model.search.budget``): each
Ipopt run gets the time left, no solve begins after it, and ``search`` says what it cut short. ``progress`` gets one
line per step and per strip solve.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from model.analysis.maps import corridor_diagnosis
from model.analysis.validation import failed_checks, fails_only_between_nodes
from model.direct.map_corridor import (
    Iterate,
    Result,
    Strips,
    answer_start,
    back_offs,
    centre_line_start,
    largest_back_off,
    solve_map,
    strips,
)
from model.direct.solution import Solution
from model.direct.solve import Start
from model.problem.ocp import OCP
from model.search.budget import Budget
from model.search.context import Reporter, reporter

ITERATIONS = 8  # at most this many strip solves in a sequence
TOLERANCE = 0.05  # m: a sequence stops when no projection moved more than this
ZERO_VIOLATION = 1e-4  # m: summed strip slack below which the minimal-violation answer lies in the strips
NEAR = 0.3  # m: the largest slack of a minimal-violation answer from which the plain strips are still tried
SPEEDS = {"quick": (), "default": (), "thorough": (0.3, 0.8)}  # step 4's speed fractions (thorough only)
TIGHT_NEAR = 0.1  # m: the penalty answer's largest slack up to which the tight strips are tried (``_tight_step``)
TIGHT_SLACK = 0.01  # the tight strips' cover discs: at most 1 % of the half-width beyond the sides (default 3 %)
TIGHT_RESOLUTION = 0.01  # m: the tight strips' bounds are multiples of this (default 0.05)
PENALTY = 100.0  # per m of strip slack (s/m for the time objective): the arclength grid's penalty sequence
GRIDS = {"time": ("time",), "arclength": ("arclength",), "time+arclength": ("time", "arclength")}  # ``grid``'s
ARCLENGTH = "arclength"  # the grid of node k fixed to the frame's arclength s_k (``solve_map(arclength=True)``)
CONVERGED = ("optimal", "acceptable", "validation_failed")  # Ipopt converged (a check may have failed)
ROUNDABOUT_ONLY = ("guess", "starts", "continuation", "screen", "accuracy", "formulation")
"""``model.search.multistart.solve_ocp``'s options that the map search has no use for: ``solve_map_route`` accepts
them (a caller may hand one set of options to either search) and names those given in a progress line; any other
keyword it does not take is a TypeError."""


@dataclass
class MapSearch:
    """One map search's state: the problem, strips, Ipopt options, time budget, the sequences run.

    Each step gets its grid as an argument (``sequence``'s ``grid``, ``GRIDS``), none is kept here.
    """

    ocp: OCP
    intervals: int
    st: Strips
    options: dict
    progress: Reporter
    budget: Budget = field(default_factory=Budget)  # the time limit on its clock (``model.search.budget``)
    started: float = field(default_factory=time.monotonic)  # wall clock: the record's ``seconds``
    sequences: list[dict] = field(default_factory=list)
    steps_skipped: list[str] = field(default_factory=list)
    best: Solution | None = None
    violation: tuple[float, float] | None = None  # step 3's minimum: (sum, largest) of the slacks, m
    best_clearance: float = -np.inf  # m: the best answer's least exact clearance at the nodes
    best_sequence: int = -1  # the index in ``sequences`` of the best answer's sequence
    tight: Strips | None = None  # the tight strips of ``_tight_step``, measured when first needed
    penalty_answer: dict | None = None  # the last converged penalty sequence's evidence (``_converged_penalty``)
    loop: dict | None = None  # step 5's outcome (``_loop_step``): loops, valid, least exact clearance at the nodes

    def skip(self, step: str) -> bool:
        """True (and ``step`` noted as skipped) if the time limit has passed (never before the first sequence:
        ``Budget.skip``, the rule the roundabout search applies too)."""
        return self.budget.skip(step, bool(self.sequences), self.steps_skipped, self.stop)

    def stop(self) -> None:
        """Mark the search as cut short by its time limit: the first time (no step skipped yet), one progress line."""
        if not self.steps_skipped:
            self.progress(self.budget.reached("the map search"))

    def sequence(self, label: str, grid: str, start: Start | None = None, intervals: int | None = None,
                 relax: bool = False, penalty: float | None = None, between: bool = False,
                 st: Strips | None = None, margins: dict[str, np.ndarray] | None = None) -> Result:  # fmt: skip
        """One sequence of strip solves (``solve_map``) on ``grid`` ("time": equal steps of a free Tf, or
        "arclength"; ``st``: these strips instead of ``self.st``), recorded and reported; the best answer kept: the
        sequence's last (not of a minimal-violation sequence); on the arclength grid any of its solves
        (``penalty``: of a penalty sequence too) that validates, else the last."""
        n = intervals or self.intervals
        solves: list[dict] = []

        def report(it: Iterate) -> None:
            sol = it.solution
            extra = f", violation {it.violation[0]:.4f} m (largest {it.violation[1]:.4f} m)" if it.violation else ""
            solves.append({"status": sol.status, "final_time": sol.final_time, "moved": it.moved,
                           "exact_clearance": it.exact_clearance, "seconds": it.seconds,
                           **({"violation": list(it.violation)} if it.violation else {})})  # fmt: skip
            self.progress(f"[{label}, solve {len(solves)}] N = {n}: {sol.status}, Tf {sol.final_time:.4f} s, "
                          f"moved {it.moved:.3f} m, exact clearance {it.exact_clearance:+.3f} m{extra}, "
                          f"{it.seconds:.1f} s")  # fmt: skip

        arclength = grid == ARCLENGTH
        result = solve_map(self.ocp, n, iterations=ITERATIONS, tol=TOLERANCE, options=self.options, st=st or self.st,
                           relax=relax or penalty is not None, start=start, deadline=self.budget.deadline,
                           arclength=arclength, penalty=penalty, between=between, on_iterate=report,
                           margins=margins, clock=self.budget.clock)  # fmt: skip
        last = result.iterates[-1]
        self.sequences.append({"start": label, "intervals": n, "relaxed": relax, "grid": grid, "solves": solves,
                               "converged": last.moved < TOLERANCE and last.solution.status in CONVERGED,
                               "valid": bool(last.solution.ok),
                               **({"penalty": penalty} if penalty is not None else {}),
                               **({"between": True} if between else {}),
                               **({"backed_off": largest_back_off(margins)} if margins else {}),
                               **({"strips": "tight"} if st is not None else {})})  # fmt: skip
        if relax:
            return result
        candidates = [last]
        if arclength:  # any validated solve of the sequence (its answer passed every check), else the last
            candidates = [it for it in result.iterates if it.solution.ok] or ([last] if penalty is None else [])
        for it in candidates:
            if _before(it, self.best, self.best_clearance):
                self.best = it.solution
                self.best.search = {"converged": it is last and self.sequences[-1]["converged"],
                                    "solve": result.iterates.index(it) + 1}  # fmt: skip
                self.best_clearance = it.exact_clearance
                self.best_sequence = len(self.sequences) - 1
                self.sequences[-1]["valid"] = self.sequences[-1]["valid"] or bool(it.solution.ok)
        return result


def _before(it: Iterate, best: Solution | None, clearance: float) -> bool:
    """Whether ``it``'s answer replaces ``best`` (whose least exact clearance is ``clearance``): validated
    first, then the lower objective (validated) or the larger exact clearance (failed, converged first)."""
    sol = it.solution
    if best is None:
        return True
    if sol.ok != best.ok:
        return sol.ok
    if sol.ok:
        return sol.objective < best.objective * (1 - 1e-6)
    converged, was = sol.status in CONVERGED, best.status in CONVERGED
    if converged != was:
        return converged
    return it.exact_clearance > clearance


def solve_map_route(ocp: OCP, intervals: int = 100, options: dict | None = None, verbose: bool = False,
                    progress=None, time_limit: float | None = None, search: str = "default",
                    grid: str = "time+arclength", clock: str = "wall", **roundabout: Any) -> Solution:  # fmt: skip
    """Solve a route through a lanelet map by the steps of the module docstring.

    Parameters
    ----------
    ocp : OCP
        A problem with a ``map_route``.
    intervals : int
        N, the trapezoid steps of each solve (the finer-grid step uses 2N).
    options : dict, optional
        Ipopt options (``verbose`` adds ``print_level`` 5).
    progress : callable, optional
        Receives the search's progress lines.
    time_limit : float, optional
        Seconds of ``clock`` for the whole search (None: no limit).
    clock : str
        What ``time_limit`` counts (``model.search.budget.Budget``): "wall" seconds, or the process's "cpu"
        seconds (each strip solve's Ipopt ``max_cpu_time``), as the roundabout search's ``clock``.
    search : str
        "quick" (steps 1-2), "default" (steps 1-3) or "thorough" (steps 1-4).
    grid : str
        "time": the nodes are equal steps of a free Tf; "arclength": node k fixed to the arclength s_k of
        the route's frame and the time free per interval (``solve_map(arclength=True)``); "time+arclength":
        the time grid's steps 1-3, then, where none validated, the arclength grid's (not with "quick").
    **roundabout
        The roundabout search's other options (``ROUNDABOUT_ONLY``: ``guess``, ``starts``, ``formulation``, ...),
        accepted so that one set of options serves either search, not used here, and named in a progress line
        (``clock`` is used: a CPU budget stays one on a map).

    Raises
    ------
    TypeError
        A keyword that is neither this function's nor in ``ROUNDABOUT_ONLY``: no option is dropped silently.

    Returns
    -------
    Solution
        The best answer; ``search`` records each sequence (start, N, each solve's status, Tf, how far
        the projections moved, the exact clearance at the nodes) and the time limit and its clock; ``diagnosis`` is
        set unless ``ok``.
    """
    ipopt = dict(options or {})
    if verbose:
        ipopt.setdefault("print_level", 5)
    if search not in SPEEDS:
        raise ValueError(f"search must be one of {', '.join(SPEEDS)}, got {search!r}")
    if grid not in GRIDS:
        raise ValueError(f"grid must be one of {', '.join(GRIDS)}, got {grid!r}")
    unknown = sorted(set(roundabout) - set(ROUNDABOUT_ONLY))
    if unknown:
        raise TypeError(f"solve_map_route() got unexpected keyword arguments: {', '.join(unknown)}")
    run = MapSearch(ocp, intervals, strips(ocp), ipopt, reporter(progress), Budget(time_limit, clock))
    if roundabout:
        run.progress(f"map search: not used on a map: {', '.join(sorted(roundabout))}")
    run.progress("map search: the strip sequence from the centre line")
    _steps(run, search, grid)
    if not run.best.ok and search != "quick" and not run.skip("loop round the ring"):
        _loop_step(run, search, grid)
    return _finished(run)


def _steps(run: MapSearch, search: str, grid: str) -> None:
    """Steps 1-4 of the module docstring on ``run``'s problem."""
    first, *then = GRIDS[grid]
    run.sequence("centre line x0.5", first)
    _refine(run, first)
    if first == ARCLENGTH:
        _tight_step(run, _penalty_step(run))
    if not run.best.ok and search != "quick" and not run.skip("minimal violation"):
        _minimal_violation_step(run, first)
    if then and not run.best.ok and search != "quick" and not run.skip("arclength grid"):
        run.progress("no sequence validated on the time grid: the arclength grid (nodes fixed to the frame)")
        run.sequence("arclength grid, centre line x0.5", ARCLENGTH)
        _refine(run, ARCLENGTH)
        _tight_step(run, _penalty_step(run))
    for speed in SPEEDS[search]:  # step 4 on the first grid, as before
        if run.best.ok or run.skip(f"centre line x{speed:g}"):
            break
        run.progress(f"no sequence validated: the centre line at {speed:g} of the speed bound")
        run.sequence(f"centre line x{speed:g}", first, centre_line_start(run.ocp, run.intervals, run.st, speed))
        _refine(run, first)


def looped_problem(ocp: OCP) -> OCP | None:
    """``ocp`` on its route going once more round the ring (``MapRoute.looped``): the same corridor, the goal
    heading 2 pi further (None: the route meets no cycle)."""
    route = ocp.map_route.looped()
    if route is None:
        return None
    heading = ocp.vehicle.roles.heading
    return dataclasses.replace(ocp, map_route=route, final={**ocp.final, heading: route.goal()[2]})


def _loop_step(run: MapSearch, search: str, grid: str) -> None:
    """Step 5: where nothing validated, steps 1-4 again on the route once more round the ring, in the time left
    (Kackertstrasse 104 -> 85, EU semitrailer: the right turn's direct path converges 0.15-0.20 m outside the
    lanelets, once round the ring it validates). Its sequences are recorded with ``loops``; its answer replaces
    the direct route's only where it validates."""
    looped = looped_problem(run.ocp)
    if looped is None:
        return
    run.progress("no sequence validated on the route: the same once more round the ring (a loop)")
    inner = MapSearch(looped, run.intervals, strips(looped), run.options, run.progress, run.budget, run.started)
    _steps(inner, search, grid)
    offset = len(run.sequences)
    run.sequences += [{**s, "loops": looped.map_route.loops} for s in inner.sequences]
    run.steps_skipped += inner.steps_skipped
    run.loop = {"loops": looped.map_route.loops, "valid": bool(inner.best.ok),
                "exact_clearance": float(inner.best_clearance),
                "failed_checks": failed_checks(inner.best.validation)}  # fmt: skip
    if inner.best.ok:
        run.best, run.best_clearance, run.best_sequence = inner.best, inner.best_clearance, offset + inner.best_sequence
        run.violation, run.penalty_answer = inner.violation, inner.penalty_answer


def _penalty_step(run: MapSearch) -> Iterate | None:
    """The arclength grid's penalty step: the strips as an exact L1 penalty (``PENALTY`` per m of slack) from
    the centre line (Thiergarten 51 -> 108, SU-30: the plain strips Ipopt-infeasible, the minimal violation
    0.2 mm; the penalty answer validates). Returns its last solve (None where it did not run)."""
    if run.best.ok or run.skip("penalty"):
        return None
    run.progress(f"no solve validated: the strips as an exact penalty ({PENALTY:g} per m of slack)")
    last = run.sequence("centre line x0.5, penalty", ARCLENGTH, penalty=PENALTY).iterates[-1]
    _converged_penalty(run, last, "default")
    return last


def _converged_penalty(run: MapSearch, last: Iterate, kind: str) -> None:
    """Keep a converged penalty sequence's last solve as the refusal's evidence (``diagnosis``'s ``penalty_answer``):
    its least exact clearance at the nodes and its strip slack (``kind``: the strips, "default" or "tight")."""
    if last.violation is None or last.moved >= TOLERANCE or last.solution.status not in CONVERGED:
        return
    run.penalty_answer = {"exact_clearance": last.exact_clearance, "largest_slack": last.violation[1],
                          "summed_slack": last.violation[0], "strips": kind}  # fmt: skip


def _tight_step(run: MapSearch, last: Iterate | None) -> None:
    """Where the penalty sequence converged needing at most ``TIGHT_NEAR`` m of slack and nothing validated:
    the penalty sequence again from its answer on tighter strips (cover discs ``TIGHT_SLACK`` of the half-width
    beyond the sides, bounds in steps of ``TIGHT_RESOLUTION`` m, ``tight_strips``), then, for an answer failing
    only between the nodes, with the mid-interval rows, and for one still failing so, the same on 2N from it
    (Thiergarten 21 -> 23, SU-30: the free steps' one-step error 0.056 m on N, every check passing on 2N). The
    default strips' conservatism (discs 3 % wider, bounds rounded down to 5 cm) is then the same size as the
    slack (Thiergarten 106 -> 90, SU-30: 0.062 m of slack, the rectangles 0.013 m outside; on the tight strips
    8 mm of slack and the rectangles inside)."""
    if run.best.ok or last is None or last.violation is None or last.violation[1] > TIGHT_NEAR:
        return
    if last.moved >= TOLERANCE or last.solution.status not in CONVERGED or run.skip("tight strips"):
        return
    run.progress(f"the penalty answer needs {last.violation[1]:.3f} m of slack at most: the same on tighter strips")
    run.tight = run.tight or tight_strips(run.ocp)
    result = run.sequence("tight strips, penalty", ARCLENGTH, answer_start(run.ocp, last.solution), penalty=PENALTY,
                          st=run.tight)  # fmt: skip
    _converged_penalty(run, result.iterates[-1], "tight")
    sol = result.iterates[-1].solution
    if not _still_between(run, sol, "tight strips, mid-interval rows"):
        return
    run.progress("the tight answer leaves the corridor only between the nodes: mid-interval strip rows from it")
    sol = run.sequence("tight strips, penalty, mid-interval rows", ARCLENGTH, answer_start(run.ocp, sol),
                       penalty=PENALTY, between=True, st=run.tight).iterates[-1].solution  # fmt: skip
    if not _still_between(run, sol, "tight strips, finer grid"):
        return
    n = 2 * run.intervals
    run.progress(f"the tight answer still leaves the corridor between the nodes: the same on N = {n} from it")
    sol = run.sequence("tight strips, penalty, mid-interval rows, finer grid", ARCLENGTH,
                       interpolated(run.ocp, sol, n, True), n, penalty=PENALTY, between=True,
                       st=run.tight).iterates[-1].solution  # fmt: skip
    margins = back_offs(run.ocp, sol.columns) if fails_only_between_nodes(sol.validation) else {}
    if run.best.ok or not margins or run.skip("tight strips, backed off"):
        return
    run.progress(f"the motion between the nodes still leaves the corridor: the rows next to it narrowed by up to "
                 f"{largest_back_off(margins):.3f} m")  # fmt: skip
    run.sequence("tight strips, penalty, mid-interval rows, finer grid, backed off", ARCLENGTH,
                 answer_start(run.ocp, sol), n, penalty=PENALTY, between=True, st=run.tight,
                 margins=margins)  # fmt: skip


def _still_between(run: MapSearch, sol: Solution, step: str) -> bool:
    """Whether ``step``, a remedy for an answer failing only between the nodes, is to run on ``sol``: nothing
    validated yet, ``sol`` failing only between the nodes, and ``step`` not skipped (time, ``run.skip``)."""
    return not run.best.ok and fails_only_between_nodes(sol.validation) and not run.skip(step)


def tight_strips(ocp: OCP) -> Strips:
    """The strips of ``_tight_step``: cover slack ``TIGHT_SLACK``, bounds in steps of ``TIGHT_RESOLUTION`` m."""
    return strips(ocp, slack=TIGHT_SLACK, resolution=TIGHT_RESOLUTION)


def _refine(run: MapSearch, grid: str) -> None:
    """Step 2 on ``grid``: the sequence on 2N from an answer that fails only between the nodes."""
    best = run.best
    if best.intervals != run.intervals or not _still_between(run, best, "finer grid"):
        return
    if grid == ARCLENGTH:  # first the strip rows also at each interval's mid-state, on the same N
        run.progress("the answer leaves the corridor only between the nodes: mid-interval strip rows from it")
        run.sequence(f"mid-interval rows from {run.sequences[-1]['start']}", grid, answer_start(run.ocp, best),
                     between=True)  # fmt: skip
        best = run.best
        if not _still_between(run, best, "finer grid"):
            return
    n = 2 * run.intervals
    run.progress(f"the answer leaves the corridor only between the nodes: the strips on N = {n} from it")
    start = interpolated(run.ocp, best, n, grid == ARCLENGTH)
    run.sequence(f"finer grid from {run.sequences[-1]['start']}", grid, start, n)


def interpolated(ocp: OCP, sol: Solution, intervals: int, by_node: bool = False) -> Start:
    """``sol``'s states and controls interpolated linearly onto ``intervals`` equal steps of its Tf
    (``by_node``: of its node index, with the node times: the equal arclength steps of an arclength grid)."""
    t = np.asarray(sol.columns["t"], float)
    tau = np.linspace(0.0, 1.0, len(t)) if by_node else (t - t[0]) / (t[-1] - t[0])
    new = np.linspace(0.0, 1.0, intervals + 1)
    names = [k for k in ocp.vehicle.states + ocp.vehicle.controls if k in sol.columns]
    return Start(values={k: np.interp(new, tau, np.asarray(sol.columns[k], float)) for k in names},
                 final_time=sol.final_time, times=np.interp(new, tau, t) if by_node else None)  # fmt: skip


def _minimal_violation_step(run: MapSearch, grid: str) -> None:
    """Step 3 on ``grid``: the minimal-violation sequence from the centre line; the plain strips from its answer."""
    run.progress("no sequence validated: the strips with slacks (minimal violation), then the strips from it")
    relaxed = run.sequence("minimal violation", grid, relax=True).iterates[-1]
    if relaxed.violation is None or relaxed.solution.status not in CONVERGED:
        return
    run.violation = relaxed.violation
    if relaxed.violation[1] > NEAR or run.skip("strips from the minimal violation"):
        return
    run.sequence("from the minimal violation", grid, answer_start(run.ocp, relaxed.solution))
    _refine(run, grid)


def _finished(run: MapSearch) -> Solution:
    """The best answer with the search's record (and its diagnosis unless it validated)."""
    sol = run.best
    if any(s["grid"] == "arclength" for s in run.sequences):
        last = run.sequences[run.best_sequence]
    else:
        last = next(s for s in reversed(run.sequences) if not s["relaxed"] and s["valid"] == sol.ok)
    sol.search = {
        "method": "map corridor strips (fixed projections), several starts",
        "solves": last["solves"],  # the sequence of the answer
        "converged": sol.search.get("converged", False),
        "sequences": run.sequences,
        "time_limit": run.budget.limit, "clock": run.budget.clock, "stopped_by_time_limit": bool(run.steps_skipped),
        "starts_skipped": len(run.steps_skipped), "steps_skipped": run.steps_skipped,
        "seconds": time.monotonic() - run.started,
        **({"loop": run.loop} if run.loop else {}),
    }  # fmt: skip
    seconds = sum(x["seconds"] for s in run.sequences for x in s["solves"])
    sol.timings = {**sol.timings, "solves_seconds": float(seconds)}
    if not sol.ok:
        sol.diagnosis = diagnosis(sol, run.violation, run.penalty_answer, run.loop)
    return sol


def diagnosis(sol: Solution, violation: tuple[float, float] | None = None, penalty: dict | None = None,
              loop: dict | None = None) -> dict:  # fmt: skip
    """Why a map solve failed: the bodies that leave the corridor (where and by how much), the failed checks,
    the minimal violation of the strips (``violation``: sum and largest slack, m) where it was solved, and
    ``penalty`` (``MapSearch.penalty_answer``): the converged penalty answer's exact clearance and slack, m (the
    answer reported is a plain sequence's: its bodies' excess may be far smaller than the penalty answer's);
    ``loop`` (``MapSearch.loop``): step 5's outcome where it ran."""
    ocp = sol.ocp
    states = {k: np.asarray(sol.columns[k]) for k in ("t", *ocp.vehicle.states)}
    bodies = corridor_diagnosis(ocp, states)
    failed = list(failed_checks(sol.validation))
    parts = [f"the {b['body']} body leaves the corridor by {b['outside']:.3f} m ({b['where']}, t = {b['t']:.2f} s, "
             f"reference point ({b['x']:.2f}, {b['y']:.2f}), lanelets {b['lanelets']})" for b in bodies]  # fmt: skip
    if sol.status not in ("optimal", "validation_failed"):  # validation_failed: Ipopt converged, a check failed
        parts.insert(0, f"Ipopt: {sol.status}")
    if not sol.search.get("converged", True):
        parts.append(f"the projections did not converge in {len(sol.search['solves'])} solves")
    if violation is not None and violation[0] > ZERO_VIOLATION:
        parts.append(f"the strips with slacks need {violation[1]:.3f} m at most ({violation[0]:.3f} m summed over "
                     "the discs and nodes) beyond the corridor")  # fmt: skip
    if penalty is not None:
        parts.append(f"the arclength grid's penalty sequence ({penalty['strips']} strips) converged with the bodies' "
                     f"least exact clearance {penalty['exact_clearance']:+.3f} m at the nodes and "
                     f"{penalty['largest_slack']:.3f} m of strip slack at most")  # fmt: skip
    if loop is not None:
        failing = ", ".join(f"{k} {v:.3f}" for k, v in loop.get("failed_checks", {}).items())
        parts.append(f"once more round the ring nothing validated either (least exact clearance "
                     f"{loop['exact_clearance']:+.3f} m at the nodes{'; failing ' + failing if failing else ''})")
    out = {"kind": "map corridor", "message": "; ".join(parts) or "validation failed: " + ", ".join(failed),
           "bodies": bodies, "failed_checks": failed}  # fmt: skip
    if violation is not None:
        out["minimal_violation"] = {"sum": violation[0], "largest": violation[1]}
    if penalty is not None:
        out["penalty_answer"] = dict(penalty)
    if loop is not None:
        out["loop"] = dict(loop)
    return out
