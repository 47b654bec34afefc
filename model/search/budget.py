"""One search's time budget: its clock, its deadline, what is left, and when a step is skipped.

Both search drivers, the roundabout search (``model.search.context.Search``) and the map search
(``model.search.maps.MapSearch``), keep time with a ``Budget``: ``limit`` seconds of ``clock`` ("wall":
``time.monotonic()``, "cpu": the process's ``time.process_time()``, ``model.direct.solve.CLOCKS``) from
``started``, ``reserve`` of them kept at the end (no run begins or continues in them). Each Ipopt run gets the
time left as its ``max_wall_time`` or ``max_cpu_time`` (``run_options``). The skip rule: a step is skipped once the
deadline has passed, but never before the search has something to show (an answer or the evidence of a failure).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from model.direct.solve import CLOCKS, expired, time_left, wall_time_options


@dataclass(frozen=True)
class Budget:
    """A time limit on one clock (see the module docstring).

    Parameters
    ----------
    limit : float, optional
        Seconds of ``clock`` for the whole search from ``started`` (None: no limit).
    clock : str
        "wall" or "cpu" (``model.direct.solve.CLOCKS``); ValueError otherwise.
    started : float, optional
        The clock's reading at the search's start (None: now).
    reserve : float
        Seconds at the end of ``limit`` kept for analysing the last run and writing the results: the
        ``deadline`` is that much earlier.
    """

    limit: float | None = None
    clock: str = "wall"
    started: float | None = None
    reserve: float = 0.0

    def __post_init__(self) -> None:
        if self.clock not in CLOCKS:
            raise ValueError(f"clock must be one of {', '.join(CLOCKS)}, got {self.clock!r}")
        if self.started is None:
            object.__setattr__(self, "started", self.now())

    def now(self) -> float:
        """The clock's reading (``time.monotonic()`` or ``time.process_time()``)."""
        return CLOCKS[self.clock][0]()

    @property
    def deadline(self) -> float | None:
        """The clock's instant the budget ends, ``reserve`` before the limit (None: no limit)."""
        return None if self.limit is None else self.started + self.limit - self.reserve

    @property
    def run_option(self) -> str:
        """The Ipopt option that bounds one run on this clock: ``max_wall_time`` or ``max_cpu_time``."""
        return CLOCKS[self.clock][1]

    def remaining(self) -> float | None:
        """Seconds left (negative once over; None: no limit)."""
        return time_left(self.deadline, self.clock)

    def expired(self) -> bool:
        """Whether the deadline has passed (``model.direct.solve.expired``)."""
        return expired(self.deadline, self.clock)

    def skips(self, begun: bool) -> bool:
        """The skip rule: whether a step is to be skipped, the deadline passed and the search ``begun`` (it has an
        answer or the evidence of a failure; before that nothing is skipped)."""
        return begun and self.expired()

    def skip(self, step: str, begun: bool, skipped: list[str], stop: Callable[[], None]) -> bool:
        """The skip rule applied by a search: if ``skips(begun)``, ``stop()`` (the search's first stop prints
        ``reached``), ``step`` appended to ``skipped`` and True; else False and nothing done.

        Parameters
        ----------
        step : str
            The step's name, as summary.json's ``steps_skipped`` lists it.
        begun : bool
            Whether the search has something to show (an answer or the evidence of a failure).
        skipped : list of str
            The search's skipped steps (appended to).
        stop : callable
            Marks the search as stopped by its limit (prints ``reached`` the first time).
        """
        if not self.skips(begun):
            return False
        stop()
        skipped.append(step)
        return True

    def run_options(self, options: dict, floor: float | None = None) -> dict | None:
        """``options`` with the time left as the run's ``run_option`` (at least ``floor``; ``wall_time_options``);
        None if no time is left."""
        return wall_time_options(options, self.deadline, floor, self.clock)

    def reached(self, who: str) -> str:
        """The progress line of a search that stops at its limit (``who``: "the search", "the map search")."""
        return f"time limit of {self.limit:g} s reached: {who} stops with what it has found"


__all__ = ["Budget"]
