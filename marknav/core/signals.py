"""One signal policy for the whole life of a ``marknav`` process.

:func:`install` (called first thing by the entry point, :mod:`marknav.__main__`, before the
command line is even imported; again by :func:`marknav.cli.main.main`) routes every signal that
would otherwise end the process at once (:data:`ENDING_SIGNALS`: SIGHUP — a closed terminal or a
dropped SSH session —, SIGINT, SIGQUIT, SIGTERM, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM, SIGPROF,
SIGXCPU) to one handler, so each leaves the robot stopped and the report written:

- The **first** signal raises :class:`Interrupted` (a ``KeyboardInterrupt``) in the main thread,
  wherever it is — importing, loading, connecting, in the control loop, plotting. The code on
  the way out stops the wheels and writes the report and the event log; the CLI exits 130.
- Inside a :func:`deferred` block (the clean-up that stops the wheels and writes the report)
  the first signal is only noted, and raised when the block ends: the clean-up cannot be cut in
  half, and a signal that comes after the loop ended still ends the process with 130.
- **Every later signal** is noted on stderr and otherwise ignored: the clean-up it would
  interrupt is exactly what must not be lost (a second Ctrl-C 0.1 s after the first used to
  leave no report). The clean-up is bounded (joins and port writes have timeouts).

- A signal's exception raised inside a **callback from C** (a ctypes callback such as
  llvmlite's while numba compiles, an object's finaliser) cannot leave it: Python reports it
  as unraisable and the C code goes on. The policy's :data:`sys.unraisablehook` takes such an
  ``Interrupted`` (or any ``KeyboardInterrupt`` named for one of :data:`ENDING_SIGNALS`) and
  delivers the signal to the main thread again, from a helper thread, so it is raised at the
  next Python line outside the callback (a Ctrl-C during numba's first compilation of a run
  used to be lost: the run went on and the command exited 1, not 130).

- **After the command returned** (its files written and closed), the entry point ends the
  process itself with :func:`exit_process`: a signal then is noted, not raised, and the exit
  code becomes 130 — the interpreter's own teardown, during which Python handles no signal
  (a Ctrl-C there used to be ignored: exit 0), never runs.

Every one of them exits 130 (the CLI's one "interrupted" code; the report, the event log and
stderr name the signal). SIGPIPE and SIGXFSZ stay ignored, as Python sets them: a closed pipe or
a file over the size limit is an ``OSError`` where it happens, not an end of the process.
SIGKILL and SIGSTOP cannot be caught: after SIGKILL the Create keeps its last wheel command (see
the safety explanation in the documentation for what stops it then).

Library code that runs outside the CLI (tests, evaluation workers) gets the same policy for the
duration of a run from :func:`interrupting`.

This module imports nothing heavy (no ``logging``): it is loaded in the first milliseconds.
"""

from __future__ import annotations

import _thread
import atexit
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, NoReturn

from marknav.core.errors import EXIT_INTERRUPTED

__all__ = ["ENDING_SIGNALS", "Interrupted", "deferred", "exit_process", "install", "installed",
           "interrupting", "signalled", "uninstall"]

#: The signals whose default action ends the process and that come from outside it (a terminal,
#: ``kill``, a timer, a resource limit): the faults of a bad instruction or address (SIGSEGV,
#: SIGBUS, SIGILL, SIGFPE, SIGABRT) cannot be handled in Python and are left to ``faulthandler``.
ENDING_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGHUP", "SIGINT", "SIGQUIT", "SIGTERM", "SIGUSR1",
                                       "SIGUSR2", "SIGALRM", "SIGVTALRM", "SIGPROF", "SIGXCPU")
    if hasattr(signal, name))
_SIGNALS = ENDING_SIGNALS
#: How often the helper that delivers a swallowed signal again looks whether the hook that
#: started it has returned, s (the hook returns within microseconds).
_AGAIN_POLL_S = 0.0005


class Interrupted(KeyboardInterrupt):
    """One of :data:`ENDING_SIGNALS` arrived; ``str()`` is the signal's name."""

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
        self.late: str | None = None  # a signal after the command returned
        self.unraisable: Any = None  # sys.unraisablehook before install()
        self.in_hook = False  # _unraisable is running (its signal waits till it returns)


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


def _swallowed_signal(exc: BaseException | None) -> signal.Signals | None:
    """The ending signal a ``KeyboardInterrupt`` stands for (its ``str()`` names it; a bare one
    is SIGINT), or None for any other exception."""
    if not isinstance(exc, KeyboardInterrupt):
        return None
    name = str(exc) or "SIGINT"
    return next((s for s in _SIGNALS if s.name == name), None)


def _unraisable(info: Any) -> None:
    """:data:`sys.unraisablehook` while the policy is installed (see the module docstring)."""
    sig = _swallowed_signal(info.exc_value)
    if sig is None:
        hook = _state.unraisable or sys.__unraisablehook__
        hook(info)
        return
    if _state.first == sig.name and _state.pending is None:
        _state.first = None  # not raised where it arrived: the handler raises it again
    # Delivered from another thread once this hook has returned: a handler run inside the
    # hook would be lost again, or reported as the hook's own failure. (A low-level thread:
    # threading.Thread.start() waits for it, and the handler would run in that wait.)
    _state.in_hook = True
    _thread.start_new_thread(_deliver_again, (sig,))
    _state.in_hook = False


def _deliver_again(sig: signal.Signals) -> None:
    while _state.in_hook:
        time.sleep(_AGAIN_POLL_S)
    _thread.interrupt_main(sig)


def _late_handler(signum: int, frame: FrameType | None) -> None:
    if _state.late is None:
        _state.late = signal.Signals(signum).name


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def install() -> bool:
    """Route :data:`ENDING_SIGNALS` to the policy for the rest of the process (main thread only;
    False elsewhere). Resets what an earlier :func:`install` noted."""
    if not _main_thread():
        return False
    _state.first = _state.pending = None
    _state.deferring = 0
    if not _state.installed:
        _state.previous = {int(s): signal.signal(s, _handler) for s in _SIGNALS}
        _state.unraisable = sys.unraisablehook
        sys.unraisablehook = _unraisable
        _state.installed = True
    return True


def uninstall(*, exiting: bool = False) -> None:
    """Give the signals back to whoever had them before :func:`install` — or, when the process
    is ``exiting`` (the command line's own entry point, which ends with :func:`exit_process`),
    only note them: nothing may be raised once the command has returned, and a signal then
    still ends the process with 130."""
    if _state.installed and _main_thread():
        for s, previous in _state.previous.items():
            signal.signal(s, _late_handler if exiting else previous)
        if sys.unraisablehook is _unraisable:
            sys.unraisablehook = _state.unraisable or sys.__unraisablehook__
        _state.installed = False
        _state.previous = {}


def installed() -> bool:
    return _state.installed


def signalled() -> str | None:
    """The first signal received since :func:`install`, or None."""
    return _state.first


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


def exit_process(code: int) -> NoReturn:
    """End the process now: non-daemon threads joined (a signal ends the wait), ``atexit``
    handlers run, stdout and stderr flushed, then ``os._exit`` — with ``code``, or 130 if a
    signal arrived after the command returned. The command's files are already complete: this
    skips only the interpreter's teardown of its modules (a fraction of a second, during which
    Python runs no signal handler)."""
    if _main_thread():
        for s in _SIGNALS:  # the command line's uninstall() did this; a library caller too
            if signal.getsignal(s) is not _late_handler:
                signal.signal(s, _late_handler)
    me = threading.current_thread()
    for t in threading.enumerate():
        while t is not me and not t.daemon and t.is_alive() and _state.late is None:
            t.join(0.1)
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                if stream is not None:
                    stream.flush()
            except (OSError, ValueError):  # a closed pipe or stream: nothing more to say
                pass
        if _state.late is not None and code != EXIT_INTERRUPTED:
            code = EXIT_INTERRUPTED
        os._exit(code)
