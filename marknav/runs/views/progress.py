"""Progress of long commands (evaluate, tune, bench, calibrate) and the status of a slow start.

:class:`Progress` counts steps towards a total. On a terminal it is a rich progress bar with
the elapsed time and an ETA, redrawn in place; anywhere else (a pipe, CI, a log file) it writes
one plain line when the work starts, one every ``every_s`` seconds while it goes on (also when
no step finished: a silent pipe looks hung) and one at the end:

    evaluate slalom: 12/20 done, 11 successes, 1:02 elapsed, ETA 0:43

:func:`slow_status` shows a message while a block runs, but only when the block takes longer
than ``after_s`` (a spinner on a terminal, one line otherwise): "preparing the simulator (first
run only)…" while the compiled loops are built on a cold cache, nothing on a warm one.

Both write to the stream the command line hands them (stderr), never to stdout, so a command's
own output (``--json``) stays clean.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

__all__ = ["Progress", "clock_text", "is_terminal", "slow_status"]

#: A piped progress line at least this often (s): often enough that a log shows the command is
#: alive, seldom enough that a 10-minute evaluation writes ~60 lines, not thousands.
PIPED_EVERY_S = 10.0
#: A block shorter than this (s) shows no status: a warm start (loading the compiled loops from
#: the cache, 0.1–0.3 s; more on a busy machine) stays quiet.
STATUS_AFTER_S = 1.0


def is_terminal(out: TextIO) -> bool:
    """Whether ``out`` is an interactive terminal that can redraw in place."""
    isatty = getattr(out, "isatty", None)
    return bool(isatty is not None and isatty()) and os.environ.get("TERM") != "dumb"


def clock_text(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``)."""
    s = max(0, round(seconds))
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


class Progress:
    """``done`` of ``total`` steps, with a ``note`` (e.g. "11 successes"), drawn on ``out``.

    Use as a context manager or call :meth:`start` and :meth:`finish`. :meth:`update` may be
    called from any thread. ``terminal`` overrides the detection (tests); ``clock`` is the
    time source (seconds, monotonic)."""

    def __init__(self, label: str, out: TextIO, *, total: int = 0, unit: str = "done",
                 every_s: float = PIPED_EVERY_S, terminal: bool | None = None,
                 clock: Callable[[], float] = time.monotonic, redraws_per_s: float = 4.0
                 ) -> None:
        self.label = label
        self.out = out
        self.total = total
        self.unit = unit
        self.every_s = every_s
        self.terminal = is_terminal(out) if terminal is None else terminal
        self.clock = clock
        self.redraws_per_s = redraws_per_s
        self.done = 0
        self.base = 0  # steps done before this start (a resumed study): not in the pace
        self.note = ""
        self.t0 = clock()
        self._t_step = self.t0  # when ``done`` last changed
        self._last_line = -float("inf")
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None
        self._bar: Any = None
        self._task: Any = None
        self.started = False

    # -- the text --------------------------------------------------------------------------
    def eta_s(self) -> float | None:
        """Seconds left at the mean pace of the steps done so far (None before the first
        step); between steps it counts down rather than growing with the wait."""
        if self.done - self.base <= 0 or self.total <= 0:
            return None
        pace = (self._t_step - self.t0) / (self.done - self.base)
        return max(self.t0 + pace * (self.total - self.base) - self.clock(), 0.0)

    def line(self) -> str:
        """The state as one plain line."""
        elapsed = self.clock() - self.t0
        eta = self.eta_s()
        total = f"/{self.total}" if self.total else ""
        note = f", {self.note}" if self.note else ""
        return (f"{self.label}: {self.done}{total} {self.unit}{note}, "
                f"{clock_text(elapsed)} elapsed, ETA {'—' if eta is None else clock_text(eta)}")

    # -- life cycle ------------------------------------------------------------------------
    def start(self, total: int | None = None, *, done: int = 0) -> Progress:
        """The work starts now (the clock of the ETA starts too), ``done`` steps already
        done."""
        if total is not None:
            self.total = total
        self.done = self.base = done
        self._t_step = self.t0
        self.t0 = self.clock()
        self.started = True
        if self.terminal:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.progress import Progress as RichProgress

            self._bar = RichProgress(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("{task.fields[note]}"), TimeElapsedColumn(),
                TextColumn("ETA"), TimeRemainingColumn(),
                console=Console(file=self.out), transient=False,
                refresh_per_second=self.redraws_per_s)
            self._task = self._bar.add_task(self.label, total=self.total or None, note="",
                                            completed=done)
            self._bar.start()
        else:
            self._write_line()
            self._ticker = threading.Thread(target=self._tick, name="marknav-progress",
                                            daemon=True)
            self._ticker.start()
        return self

    def update(self, done: int | None = None, *, total: int | None = None,
               note: str | None = None, advance: int = 0) -> None:
        """Set (or ``advance``) the steps done, the total and the note."""
        with self._lock:
            if total is not None:
                self.total = total
            before = self.done
            if done is not None:
                self.done = done
            self.done += advance
            if self.done != before:
                self._t_step = self.clock()
            if note is not None:
                self.note = note
            if self._bar is not None:
                self._bar.update(self._task, completed=self.done, total=self.total or None,
                                 note=self.note)
        if self._bar is None and self.started:
            self.tick()

    def log(self, text: str) -> None:
        """A line of its own: above the bar on a terminal, between the progress lines
        elsewhere."""
        if self._bar is not None:
            self._bar.console.print(text, highlight=False, markup=False)
            return
        with self._lock:
            try:
                self.out.write(text + "\n")
                self.out.flush()
            except (OSError, ValueError):
                pass

    def tick(self) -> None:
        """Piped: write a line if ``every_s`` has passed since the last one."""
        if self._bar is None and self.clock() - self._last_line >= self.every_s:
            self._write_line()

    def _write_line(self) -> None:
        with self._lock:
            self._last_line = self.clock()
            try:
                self.out.write(self.line() + "\n")
                self.out.flush()
            except (OSError, ValueError):  # the pipe went away: progress is not worth a crash
                pass

    def _tick(self) -> None:
        # checks a few times per period, so a line is late by at most a tenth of it
        while not self._stop.wait(max(self.every_s / 10.0, 0.01)):
            self.tick()

    def finish(self) -> None:
        """The work ended (or was interrupted): the last state stays on screen."""
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
            self._ticker = None
            if self.started:
                self._write_line()
        if self._bar is not None:
            self._bar.refresh()
            self._bar.stop()
            self._bar = None
        self.started = False

    def __enter__(self) -> Progress:
        if not self.started:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.finish()


@contextmanager
def slow_status(text: str, out: TextIO, *, after_s: float = STATUS_AFTER_S,
                terminal: bool | None = None,
                make_timer: Callable[[float, Callable[[], None]], Any] = threading.Timer
                ) -> Iterator[None]:
    """Show ``text`` while the block runs, if it runs longer than ``after_s``: a rich spinner
    on a terminal (cleared at the end), one line elsewhere. ``make_timer`` makes the timer
    that shows it after ``after_s`` (:class:`threading.Timer`; tests: one they fire)."""
    term = is_terminal(out) if terminal is None else terminal
    shown: dict[str, Any] = {}  # the rich status, once shown on a terminal
    lock = threading.Lock()
    done = threading.Event()

    def show() -> None:
        with lock:
            if done.is_set():
                return
            if term:
                from rich.console import Console

                status = Console(file=out).status(text)
                status.start()
                shown["status"] = status
                threading.Thread(target=count, args=(status,), daemon=True).start()
            else:
                try:
                    out.write(text + "\n")
                    out.flush()
                except (OSError, ValueError):
                    pass

    t0 = time.monotonic()

    def count(status: Any) -> None:  # the seconds so far, so that it visibly goes on
        while not done.wait(1.0):
            status.update(f"{text} {time.monotonic() - t0:.0f} s")

    timer = make_timer(after_s, show)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        with lock:
            done.set()
            timer.cancel()
            status = shown.get("status")
            if status is not None:
                status.stop()
