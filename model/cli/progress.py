"""Progress of a command on stderr: its phases, each start, and a line at least every 10 s.

The search reports each phase and each start through a callable (``Progress`` is one);
Ipopt's long runs log their iterations (INFO on ``roundabout.ipopt``) and the solve layer
names what it is doing (DEBUG on ``roundabout.solve``). A heartbeat thread prints what is
being done whenever nothing has been printed for ``quiet_seconds``, so no phase of a
long run is silent for more than 10 s. ``quiet=True`` prints nothing.

Ctrl-C raises KeyboardInterrupt as usual; where a C extension swallows it (a callback of
cyipopt's that cannot raise drops the exception), the same thread raises it again in the
main thread a second later, so one SIGINT always ends the command.
"""

from __future__ import annotations

import logging
import signal
import sys
import threading
import time
from typing import TextIO

LOGGER = "roundabout"


class Progress(logging.Handler):
    """Prints progress lines to a stream; also a logging handler for the ``roundabout`` loggers.

    Parameters
    ----------
    stream : text stream
        Where the lines go (stderr).
    quiet : bool
        Print nothing at all.
    quiet_seconds : float
        The heartbeat prints a line after this long without one (below 10 s).
    """

    def __init__(self, stream: TextIO | None = None, quiet: bool = False, quiet_seconds: float = 6.0) -> None:
        super().__init__(level=logging.DEBUG)
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.quiet_seconds = quiet_seconds
        self.activity = "starting"
        self.started = self.last = time.monotonic()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._logger = logging.getLogger(LOGGER)
        self._level = self._logger.level
        self._sigint = None
        self.interrupted: float | None = None

    def say(self, line: str) -> None:
        """Print one line (indented under the command's first line) and restart the silence clock."""
        with self._lock:
            self.last = time.monotonic()
            if not self.quiet:
                print("  " + line, file=self.stream, flush=True)

    __call__ = say  # the search's progress callable

    def emit(self, record: logging.LogRecord) -> None:
        """INFO and above are printed; DEBUG only names the current activity for the heartbeat."""
        message = record.getMessage()
        if record.levelno >= logging.INFO:
            self.say(message)
        else:
            self.activity = message

    def __enter__(self) -> Progress:
        self._logger.addHandler(self)
        self._logger.setLevel(logging.DEBUG)
        if threading.current_thread() is threading.main_thread():
            self._sigint = signal.signal(signal.SIGINT, self._on_sigint)
        self._thread = threading.Thread(target=self._beat, name="progress", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        if self._sigint is not None:
            signal.signal(signal.SIGINT, self._sigint)
        self._logger.removeHandler(self)
        self._logger.setLevel(self._level)

    def _on_sigint(self, signum, frame) -> None:
        self.interrupted = time.monotonic()
        raise KeyboardInterrupt

    def _beat(self) -> None:
        while not self._stop.wait(min(0.5, self.quiet_seconds / 3)):
            now = time.monotonic()
            if self.interrupted is not None and now - self.interrupted >= 1.0:  # the first one was swallowed
                self.interrupted = now
                signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
            elif now - self.last >= self.quiet_seconds and not self.quiet:
                self.say(f"... {self.activity} ({now - self.started:.0f} s since the start)")


__all__ = ["LOGGER", "Progress"]
