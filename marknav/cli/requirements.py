"""What each option needs installed, checked before a command does anything.

An option that needs an optional extra (``--plot`` matplotlib, ``--viewer`` the Rerun SDK,
``--record`` the MCAP writer, ``--foxglove`` the Foxglove SDK, ``--engine mujoco`` MuJoCo and
its off-screen OpenGL library, ``marknav view`` Rerun) is refused with exit 2 before the command
starts: a run is never driven to its end only to fail at drawing its picture, and no run folder
is left behind. :data:`OPTION_NEEDS` is the one table of them; :func:`check_requirements` walks
it for the parsed command line, and :func:`require` checks one need where it is known only later
(a mission's own ``sim.engine: mujoco``).

Presence is looked up without importing (``importlib.util.find_spec``, a shared library by
``ctypes``), so the check costs milliseconds; the code that uses the package still turns a
failing import into the same message.
"""

from __future__ import annotations

import argparse
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass

from marknav.core.errors import InputError

__all__ = ["FOXGLOVE", "GROOT2", "MATPLOTLIB", "MCAP", "MUJOCO", "OPTION_NEEDS", "RERUN", "Need",
           "check_requirements", "missing", "require"]


@dataclass(frozen=True)
class Need:
    """Something an option needs: Python packages (import names), an install command, and
    optionally a check of a system library (``None`` when it is there, else how to get it)."""

    what: str
    modules: tuple[str, ...]
    install: str
    system: Callable[[], str | None] | None = None


def _module_present(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):  # a parent package missing, or a broken entry
        return False


def _mujoco_gl() -> str | None:
    """How to install the OpenGL library MuJoCo will render with, when it is missing."""
    from marknav.sim.mujoco.gl import missing_library

    return missing_library()


MATPLOTLIB = Need("matplotlib", ("matplotlib",), "pip install 'marknav[plot]'")
RERUN = Need("the Rerun SDK", ("rerun",), "pip install 'marknav[viewer]'")
MCAP = Need("the MCAP writer", ("mcap", "mcap_ros2"), "pip install 'marknav[record]'")
GROOT2 = Need("pyzmq", ("zmq",), "pip install 'marknav[groot2]'")
FOXGLOVE = Need("the Foxglove SDK", ("foxglove", "mcap_ros2"), "pip install 'marknav[foxglove]'")
MUJOCO = Need("MuJoCo", ("mujoco",), "pip install 'marknav[mujoco]'", system=_mujoco_gl)


def missing(need: Need) -> str | None:
    """What is missing of ``need`` and how to install it, or ``None`` when all is there."""
    absent = [m for m in need.modules if not _module_present(m)]
    if absent:
        return f"needs {need.what}, which is not installed: {need.install}"
    if need.system is not None:
        problem = need.system()
        if problem is not None:
            return f"needs {need.what}: {problem}"
    return None


def require(need: Need, option: str) -> None:
    """Raise :class:`InputError` (exit 2) naming ``option`` when ``need`` is not met."""
    problem = missing(need)
    if problem is not None:
        raise InputError(problem, field=option)


#: (command or ``None`` for every command, argument name, when it applies, the option as the
#: user wrote it, what it needs). An argument a command does not have never applies.
OPTION_NEEDS: tuple[tuple[str | None, str, Callable[[object], bool], str, Need], ...] = (
    (None, "plot", lambda v: v is not None, "--plot", MATPLOTLIB),
    ("run", "viewer", bool, "--viewer", RERUN),
    ("run", "record", lambda v: v is not None, "--record", MCAP),
    ("run", "foxglove", lambda v: v is not None, "--foxglove", FOXGLOVE),
    ("run", "groot2", lambda v: v is not None, "--groot2", GROOT2),
    (None, "engine", lambda v: v == "mujoco", "--engine mujoco", MUJOCO),
    ("view", "run", lambda v: True, "view", RERUN),
    ("palette", "annotate", lambda v: v is not None, "--annotate", MATPLOTLIB),
)


def check_requirements(args: argparse.Namespace) -> None:
    """Every need of the options given on the command line, before the command runs."""
    command = getattr(args, "command", None)
    for only, name, applies, option, need in OPTION_NEEDS:
        if only is not None and only != command:
            continue
        if not hasattr(args, name) or not applies(getattr(args, name)):
            continue
        require(need, option)
