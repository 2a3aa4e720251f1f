"""Where marknav writes: one policy for every output path, checked before anything starts.

- A name taken from a file (the mission ``name``) never becomes a path: :func:`safe_file_name`
  keeps letters, digits, ``.``, ``-`` and ``_``, replaces everything else (``/``, ``..``
  components, spaces, NUL, newline, ESC) by ``_`` and shortens it, so the default report folder
  :func:`default_run_dir` is always one folder directly under ``runs/``.
- A path the user gives (``--report``, ``--events``, ``--plot``, ``--dot``) is used as given, but
  :func:`check_output_file` refuses it *before the run* (exit 2) if it is a directory, its folder
  does not exist (no folder is created silently) or it cannot be written.
- Text that came from the user is shown through :func:`printable`, which escapes control
  characters instead of sending them raw to the terminal.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import time
from pathlib import Path

from marknav.core.errors import InputError

__all__ = ["RUNS_DIR", "check_output_file", "default_run_dir", "printable", "safe_file_name"]

RUNS_DIR = Path("runs")
#: Longest file-name stem made from a name (the time stamp comes on top).
MAX_STEM = 64

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def safe_file_name(name: str, default: str = "mission") -> str:
    """``name`` as one safe path component (never empty, ``.`` or ``..``, no separators)."""
    stem = _UNSAFE.sub("_", name).strip("._-")[:MAX_STEM].strip("._-")
    return stem or default


def printable(text: str) -> str:
    """``text`` with control characters (newline and ESC included; TAB kept) escaped as
    ``\\n``, ``\\x1b``…, for one-line messages."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], text.replace("\n", "\\n"))


def default_run_dir(name: str, *, root: Path = RUNS_DIR) -> Path:
    """A new folder ``runs/NAME-YYYYmmdd-HHMMSS`` (``-2``, ``-3``… if taken), created now."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = f"{safe_file_name(name)}-{stamp}"
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the runs folder: {exc.strerror or exc}",
                         file=str(root)) from None
    for n in range(1, 1000):
        path = root / (base if n == 1 else f"{base}-{n}")
        try:
            path.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(f"cannot create the run folder: {exc.strerror or exc}",
                             file=str(path)) from None
        return path
    raise InputError("too many runs in the same second", file=str(root / base))


def check_output_file(path: Path, *, option: str) -> None:
    """Refuse (``InputError``, exit 2) an output path that cannot be written, before use.

    The file itself is not created or truncated: an existing file is opened for appending and
    closed; for a new one, a probe file is created in its folder and removed.
    """
    name = str(path)
    if "\x00" in name:
        raise InputError("the path contains a NUL character", field=option)
    try:
        st = os.stat(name)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise InputError(f"cannot write: {exc.strerror or exc}", file=name, field=option) from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise InputError("is a directory; give a file name", file=name, field=option)
        try:
            fd = os.open(name, os.O_WRONLY | os.O_APPEND | getattr(os, "O_NONBLOCK", 0))
        except OSError as exc:
            why = "a pipe with no reader" if exc.errno == errno.ENXIO else exc.strerror or exc
            raise InputError(f"cannot write: {why}", file=name, field=option) from None
        os.close(fd)
        return
    folder = path.parent
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist (it is not created)"
        raise InputError(f"the folder {printable(str(folder))} {what}", file=name, field=option)
    probe = folder / f".marknav-probe-{os.getpid()}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return
    except OSError as exc:
        raise InputError(f"cannot write in {printable(str(folder))}: {exc.strerror or exc}",
                         file=name, field=option) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
