"""Progress lines on stderr, one per stage, for every command (``--quiet`` turns them off).

On a terminal a stage is one line that ends when the stage does (``label ... done (1.2 s)``); elsewhere (a pipe, a CI
log) a stage prints a start line and a done line with the time, so a log shows what is running::

    from hillsim import progress
    progress.start("simulating the load rejection")
    ...
    progress.done("max speed rise 44 %")

:func:`configure` (called by ``hillsim.cli``) enables it; library code calling :func:`start` / :func:`done` prints
nothing unless a command enabled it, so Python users see no progress lines.
"""

from __future__ import annotations

import sys
import time


class Stages:
    """Start/done progress lines.

    Parameters
    ----------
    enabled : bool
    stream : text stream, default ``sys.stderr`` (looked up at print time, so pytest's capture sees it)
    total : int or None
        With a total, labels are numbered ``[k/total]``.
    terminal : bool or None
        Whether the stream is a terminal (one line per stage); None: ask the stream.
    """

    def __init__(self, enabled: bool = True, stream=None, total: int | None = None, terminal: bool | None = None):
        self.enabled = enabled
        self._stream = stream
        self.total = total
        self._terminal = terminal
        self.index = 0
        self._label = ""
        self._start = None

    @property
    def stream(self):
        return self._stream if self._stream is not None else sys.stderr

    def _is_terminal(self) -> bool:
        if self._terminal is not None:
            return self._terminal
        isatty = getattr(self.stream, "isatty", None)
        return bool(isatty and isatty())

    def start(self, label: str) -> None:
        """Begin a stage (ends the previous one without a note if it is still open)."""
        if self._start is not None:
            self.done()
        self.index += 1
        self._label = f"[{self.index}/{self.total}] {label}" if self.total else label
        self._start = time.perf_counter()
        if self.enabled:
            end = "" if self._is_terminal() else "\n"
            print(f"{self._label} ...", end=end, file=self.stream, flush=True)

    def done(self, note: str = "") -> float:
        """End the current stage; returns its duration in seconds."""
        if self._start is None:
            return 0.0
        elapsed = time.perf_counter() - self._start
        self._start = None
        if self.enabled:
            extra = f", {note}" if note else ""
            text = f" done ({elapsed:.1f} s{extra})"
            print(text if self._is_terminal() else f"{self._label}:{text}", file=self.stream, flush=True)
        return elapsed


    def abort(self, word: str = "stopped") -> None:
        """End the current stage without a time (an error follows): on a terminal, finish its line."""
        if self._start is None:
            return
        self._start = None
        if self.enabled and self._is_terminal():
            print(f" {word}", file=self.stream, flush=True)


_current = Stages(enabled=False)


def configure(enabled: bool, *, total: int | None = None, stream=None) -> Stages:
    """Make the module-level :func:`start` / :func:`done` print (``hillsim.cli`` calls this per command)."""
    global _current
    _current = Stages(enabled=enabled, stream=stream, total=total)
    return _current


def current() -> Stages:
    return _current


def start(label: str) -> None:
    """Begin a stage of the running command (see :class:`Stages`)."""
    _current.start(label)


def done(note: str = "") -> float:
    """End the running command's current stage."""
    return _current.done(note)
