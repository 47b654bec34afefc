"""Progress of a command on stderr: its phases, each start, and a line at least every 10 s.

The search reports each phase and each start through a callable (``Progress`` is one);
Ipopt's long runs log their iterations (INFO on ``roundabout.ipopt``) and the solve layer
names what it is doing (DEBUG on ``roundabout.solve``). A watcher prints what is being done
whenever nothing has been printed for ``quiet_seconds``. It is a small forked process, not a
thread: Ipopt's linear solves hold the interpreter lock for tens of seconds on large grids,
where no thread of this process could print. ``quiet=True`` prints nothing.

Ctrl-C raises KeyboardInterrupt as usual; where a C extension swallows it (a callback of
cyipopt's that cannot raise drops the exception), the watcher sends SIGINT again a second
later, so one SIGINT always ends the command.
"""

from __future__ import annotations

import logging
import mmap
import os
import select
import signal
import struct
import sys
import threading
import time
from typing import TextIO

LOGGER = "roundabout"
_STATE = struct.Struct("ddB")  # last line printed, SIGINT received (monotonic s; 0: none), stop
_TEXT = 256  # bytes of the activity kept after the state


class Progress(logging.Handler):
    """Prints progress lines to a stream; also a logging handler for the ``roundabout`` loggers.

    Parameters
    ----------
    stream : text stream
        Where the lines go (stderr); it must have a file descriptor.
    quiet : bool
        Print nothing at all.
    quiet_seconds : float
        The watcher prints a line after this long without one (below 10 s).
    """

    def __init__(self, stream: TextIO | None = None, quiet: bool = False, quiet_seconds: float = 6.0) -> None:
        super().__init__(level=logging.DEBUG)
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.quiet_seconds = quiet_seconds
        self.started = time.monotonic()
        self._shared = mmap.mmap(-1, _STATE.size + _TEXT)
        self._watcher: int | None = None
        self._wake: int | None = None  # the write end of the pipe that ends the watcher's wait at once
        self._sigint = None
        self._logger = logging.getLogger(LOGGER)
        self._level = self._logger.level
        self._lock = threading.Lock()
        self.activity = "starting"
        self._set_state(last=self.started)

    @property
    def activity(self) -> str:
        """What is being done now (the watcher's lines name it)."""
        raw = self._shared[_STATE.size :]
        return raw[1 : 1 + raw[0]].decode(errors="replace")

    @activity.setter
    def activity(self, text: str) -> None:
        data = text.encode()[: _TEXT - 1]
        self._shared[_STATE.size : _STATE.size + 1 + len(data)] = bytes([len(data)]) + data

    @property
    def interrupted(self) -> float | None:
        """When SIGINT arrived (monotonic seconds), or None."""
        return _STATE.unpack_from(self._shared)[1] or None

    @interrupted.setter
    def interrupted(self, when: float | None) -> None:
        self._set_state(interrupted=when or 0.0)

    def say(self, line: str) -> None:
        """Print one line (indented under the command's first line) and restart the silence clock."""
        with self._lock:
            self._set_state(last=time.monotonic())
            if not self.quiet:
                print("  " + line, file=self.stream, flush=True)

    __call__ = say  # the search's progress callable

    def emit(self, record: logging.LogRecord) -> None:
        """INFO and above are printed; DEBUG only names the current activity for the watcher."""
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
        self.stream.flush()
        parent = os.getpid()
        wait_end, self._wake = os.pipe()
        self._watcher = os.fork()
        if self._watcher == 0:
            os.close(self._wake)
            self._watch(parent, wait_end)  # never returns
        os.close(wait_end)
        return self

    def __exit__(self, *exc) -> None:
        self._set_state(stop=1)
        if self._wake is not None:  # wakes the watcher now, not at the end of its sleep (up to 0.5 s a command)
            try:
                os.write(self._wake, b"x")
            except BrokenPipeError:  # the watcher has ended already
                pass
            os.close(self._wake)
            self._wake = None
        if self._watcher:
            os.waitpid(self._watcher, 0)
            self._watcher = None
        if self._sigint is not None:
            signal.signal(signal.SIGINT, self._sigint)
        self._logger.removeHandler(self)
        self._logger.setLevel(self._level)

    def _on_sigint(self, signum, frame) -> None:
        self.interrupted = time.monotonic()
        raise KeyboardInterrupt

    def _set_state(self, **values) -> None:
        last, interrupted, stop = _STATE.unpack_from(self._shared)
        state = {"last": last, "interrupted": interrupted, "stop": stop, **values}
        _STATE.pack_into(self._shared, 0, state["last"], state["interrupted"], state["stop"])

    def _watch(self, parent: int, wait_end: int) -> None:
        """The watcher process: heartbeat lines and a repeated SIGINT; ends with the command (at once when
        ``__exit__`` writes to the pipe whose read end is ``wait_end``)."""
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            fd = self.stream.fileno()
            while True:
                woken, _, _ = select.select([wait_end], [], [], min(0.5, self.quiet_seconds / 3))
                last, interrupted, stop = _STATE.unpack_from(self._shared)
                if woken or stop or os.getppid() != parent:
                    break
                now = time.monotonic()
                if interrupted and now - interrupted >= 1.0:  # the first one was swallowed
                    self._set_state(interrupted=now)
                    os.kill(parent, signal.SIGINT)
                elif now - last >= self.quiet_seconds:
                    self._set_state(last=now)
                    if not self.quiet:
                        line = f"  ... {self.activity} ({now - self.started:.0f} s since the start)\n"
                        os.write(fd, line.encode())
        finally:
            os._exit(0)


__all__ = ["LOGGER", "Progress"]
