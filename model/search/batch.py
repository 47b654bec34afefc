"""A batch of scenario files solved in one process: the imports and derivation caches are paid once.

``load_batch`` checks every file before anything is solved (a bad file or two scenarios of the
same name: ``InputError`` naming the file); ``solve_many`` then solves each with its default
method (as ``roundabout solve`` does) and writes ``OUT/<scenario name>/`` for each, the files a
single solve writes (``Solution.files`` and the scenario file as ``scenario.toml``), each folder
complete when its scenario ends (``model.outputs.run_folder``). ``roundabout solve A.toml B.toml
... --out DIR`` is the same loop with progress lines (``model.cli``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from model.errors import InputError
from model.outputs import run_folder, write_files
from model.problem.scenario import Scenario, load_scenario

if TYPE_CHECKING:  # the solver's imports only when a scenario is solved: a bad file is refused at once
    from model.direct.solution import Solution


def load_batch(paths: Sequence[str | Path]) -> list[Scenario]:
    """Every scenario of a batch, each checked as a single solve checks it.

    Parameters
    ----------
    paths : sequence of str or Path
        The scenario files (TOML).

    Returns
    -------
    list of Scenario
        In the order given.

    Raises
    ------
    InputError
        Its key is the file at fault: an invalid scenario, or a name (``name``, default the file's
        stem) that an earlier file of the batch has too, since both would write ``OUT/<name>/``.
    """
    scenarios, names = [], {}
    for path in map(Path, paths):
        try:
            scenario = load_scenario(path)
            scenario.ocp.check_solvable()
        except InputError as err:
            raise InputError(str(path), str(err)) from None
        if scenario.ocp.name in names:
            raise InputError(str(path), f"its name {scenario.ocp.name!r} is also that of {names[scenario.ocp.name]}")
        names[scenario.ocp.name] = path
        scenarios.append(scenario)
    return scenarios


def run_files(scenario: Scenario) -> dict[str, bytes]:
    """The files every run folder holds besides the results: the scenario as given (for ``plot``)."""
    return {"scenario.toml": Path(scenario.path).read_bytes()} if scenario.path is not None else {}


def solve_many(
    paths: Sequence[str | Path],
    out: str | Path,
    intervals: int | None = None,
    on_solved: Callable[[Scenario, Solution], None] | None = None,
    **options: Any,
) -> list[Solution]:
    """Solve scenario files one after another in this process; write ``out/<scenario name>/`` for each.

    Parameters
    ----------
    paths : sequence of str or Path
        The scenario files; all are checked (``load_batch``) before the first is solved.
    out : str or Path
        The batch's folder; each scenario's files go to ``out/<its name>/``.
    intervals : int, optional
        N for every scenario (default: each file's ``problem.intervals``).
    on_solved : callable, optional
        Called with (scenario, solution) after each scenario's folder is written.
    **options
        Passed to each ``OCP.solve``: ``search``, ``time_limit``, ``options`` (Ipopt), ``progress``, ...

    Returns
    -------
    list of Solution
        One per file, in order; ``ok`` says whether it was solved and validated (a failed solve's
        folder holds its summary.json with the diagnosis, as a single solve's does).

    Raises
    ------
    InputError
        A bad file (named), before anything is solved or written.

    Examples
    --------
    >>> from model.search.batch import solve_many                  # doctest: +SKIP
    >>> sols = solve_many(["a.toml", "b.toml"], "out", search="default")  # doctest: +SKIP
    >>> [s.ok for s in sols]                                        # doctest: +SKIP
    """
    scenarios = load_batch(paths)
    if intervals is not None and intervals < 1:
        raise InputError("intervals", f"must be >= 1, got {intervals}")
    solutions = []
    for scenario in scenarios:
        sol = scenario.ocp.solve(intervals=intervals or scenario.intervals, **options)
        with run_folder(Path(out) / scenario.ocp.name) as stage:
            write_files(stage, {**sol.files(), **run_files(scenario)})
        solutions.append(sol)
        if on_solved is not None:
            on_solved(scenario, sol)
    return solutions


__all__ = ["load_batch", "run_files", "solve_many"]
