"""Compiling a loop with numba, its machine code cached where numba can write.

Used by the simulator's projection (:mod:`marknav.sim.projection`): loops whose cost as NumPy
or OpenCV calls was the calls, not the arithmetic. (The detector has none since it became a
pipeline of whole-image OpenCV stages, decision 0031.)
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, TypeVar

from numba import njit

if TYPE_CHECKING:
    from numba.core.dispatcher import Dispatcher

__all__ = ["compiled", "compiled_ieee"]

log = logging.getLogger("marknav")

_F = TypeVar("_F", bound=Callable[..., Any])


def _compile(fn: _F, error_model: Literal["python", "numpy"]) -> Dispatcher[_F]:
    try:
        loop = njit(cache=True, nogil=True, error_model=error_model)(fn)
    except RuntimeError as exc:  # numba: "cannot cache function …: no locator available"
        log.info("compiled loops not cached (%s): compiling %s in this process", exc,
                 fn.__name__)
        loop = njit(nogil=True, error_model=error_model)(fn)
    return loop


def compiled(fn: _F) -> Dispatcher[_F]:
    """``fn`` compiled, its machine code cached beside its module (or in the user's cache
    folder, or ``NUMBA_CACHE_DIR``). An installation where none of them can be written (a
    read-only file system) compiles the loops once per process instead (a few seconds at
    set-up). A float division by zero raises ``ZeroDivisionError``, as in Python."""
    return _compile(fn, "python")


def compiled_ieee(fn: _F) -> Dispatcher[_F]:
    """:func:`compiled`, but a float division by zero gives ±inf or nan, as in NumPy."""
    return _compile(fn, "numpy")
