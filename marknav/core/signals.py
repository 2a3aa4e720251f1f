"""One signal policy for the whole life of a ``marknav`` process.

:func:`install` (called first thing by :func:`marknav.cli.main.main`, before the sub-commands
are even imported) routes SIGINT and SIGTERM to one handler:

- The **first** signal raises :class:`Interrupted` (a ``KeyboardInterrupt``) in the main thread,
  wherever it is — importing, loading, connecting, in the control loop, plotting. The code on
  the way out stops the wheels and writes the report and the event log; the CLI exits 130.
- Inside a :func:`deferred` block (the clean-up that stops the wheels and writes the report)
  the first signal is only noted, and raised when the block ends: the clean-up cannot be cut in
  half, and a signal that comes after the loop ended still ends the process with 130.
- **Every later signal** is noted on stderr and otherwise ignored: the clean-up it would
  interrupt is exactly what must not be lost (a second Ctrl-C 0.1 s after the first used to
  leave no report). The clean-up is bounded (joins and port writes have timeouts).

Library code that runs outside the CLI (tests, evaluation workers) gets the same policy for the
duration of a run from :func:`interrupting`.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

__all__ = ["Interrupted", "deferred", "install", "installed", "interrupting", "uninstall"]

log = logging.getLogger(__name__)

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived; ``str()`` is the signal's name."""

    def __init__(self, signame: str = "SIGINT") -> None:
        super().__init__(signame)
        self.signame = signame


class _State:
    def __init__(self) -> None:
        self.installed = False
        self.previous: dict[int, Any] = {}
        self.first: str | None = None
        self.pending: str | None = None
        self.deferring = 0


_state = _State()


def _handler(signum: int, frame: FrameType | None) -> None:
    name = signal.Signals(signum).name
    if _state.first is not None:
        # os.write, not print: a print here could land inside another print (reentrant call).
        os.write(2, f"marknav: {name} again: still stopping (wheels, report, event log)\n"
                    .encode())
        return
    _state.first = name
    if _state.deferring:
        _state.pending = name
        return
    raise Interrupted(name)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def install() -> bool:
    """Route SIGINT and SIGTERM to the policy for the rest of the process (main thread only;
    False elsewhere). Resets what an earlier :func:`install` noted."""
    if not _main_thread():
        return False
    _state.first = _state.pending = None
    _state.deferring = 0
    if not _state.installed:
        _state.previous = {int(s): signal.signal(s, _handler) for s in _SIGNALS}
        _state.installed = True
    return True


def uninstall(*, exiting: bool = False) -> None:
    """Give the signals back to whoever had them before :func:`install` — or, when the process
    is ``exiting`` (the command line's own entry point), ignore them: a second Ctrl-C that
    arrives while the interpreter shuts down must not turn exit 130 into death by signal."""
    if _state.installed and _main_thread():
        for s, previous in _state.previous.items():
            signal.signal(s, signal.SIG_IGN if exiting else previous)
        _state.installed = False
        _state.previous = {}


def installed() -> bool:
    return _state.installed


@contextmanager
def deferred() -> Iterator[None]:
    """A block that a signal cannot cut short: one that arrives inside is raised at its end."""
    _state.deferring += 1
    try:
        yield
    finally:
        _state.deferring -= 1
        if _state.deferring == 0 and _state.pending is not None:
            name, _state.pending = _state.pending, None
            raise Interrupted(name)


@contextmanager
def interrupting() -> Iterator[None]:
    """The policy for the duration of the block, if :func:`install` has not set it up for the
    whole process (outside the main thread: signals are left alone)."""
    if _state.installed or not _main_thread():
        yield
        return
    install()
    try:
        yield
    finally:
        uninstall()
