"""A signal whose exception is raised inside a callback from C (here a ctypes comparator that
libc's qsort calls; in the field llvmlite's callbacks while numba compiles) cannot leave the
callback: the policy delivers it again, and it is raised at the next Python line outside, with
nothing printed about an ignored exception."""

from __future__ import annotations

import ctypes
import signal
import time
from typing import Any

import pytest

from marknav.core import signals

_CMP = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))


def _sort_with_a_signal_inside(sig: signal.Signals) -> None:
    """libc's qsort over 8 ints, its comparator raising ``sig`` the first time it is called."""
    fired: list[int] = []

    def compare(a: Any, b: Any) -> int:
        if not fired:
            fired.append(1)
            signal.raise_signal(sig)  # the policy's handler raises here, inside the callback
        return int(a[0] - b[0])

    values = (ctypes.c_int * 8)(*range(8, 0, -1))
    libc = ctypes.CDLL(None)
    libc.qsort(values, len(values), ctypes.sizeof(ctypes.c_int), _CMP(compare))
    assert list(values) == list(range(1, 9))  # the C code went on to the end
    assert fired


@pytest.mark.parametrize("sig", [signal.SIGUSR1, signal.SIGHUP, signal.SIGINT])
def test_a_signal_raised_inside_a_c_callback_is_raised_again_outside(
        sig: signal.Signals, capfd: pytest.CaptureFixture[str]) -> None:
    signals.install()
    try:
        with pytest.raises(signals.Interrupted) as caught:
            _sort_with_a_signal_inside(sig)
            deadline = time.monotonic() + 5.0  # the run going on, as it did when it was lost
            while time.monotonic() < deadline:
                time.sleep(0.01)
        assert caught.value.signame == sig.name
        assert signals.signalled() == sig.name
    finally:
        signals.uninstall()
    err = capfd.readouterr().err
    assert "Exception ignored" not in err and "Traceback" not in err, err


def test_other_unraisable_exceptions_still_reach_the_previous_hook() -> None:
    seen: list[BaseException | None] = []
    previous = signals.sys.unraisablehook
    signals.sys.unraisablehook = lambda info: seen.append(info.exc_value)
    try:
        signals.install()
        try:
            class Broken:
                def __del__(self) -> None:
                    raise ValueError("from a finaliser")

            Broken()  # collected at once: its exception is unraisable
        finally:
            signals.uninstall()
        assert [type(e) for e in seen] == [ValueError]
        assert signals.sys.unraisablehook is not signals._unraisable
    finally:
        signals.sys.unraisablehook = previous
