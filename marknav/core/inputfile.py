"""One bounded way in for every file marknav reads (missions, worlds, tables, images).

Whatever the user names, :func:`read_bytes` reads at most ``limit`` bytes of a *regular file*:
a FIFO, a character device (``/dev/zero``, ``/dev/urandom``), a directory or a socket is refused
before a byte is read — the file is opened non-blocking, so even a FIFO with no writer does not
hang the open — and a file larger than the limit is refused without reading the rest.
:func:`read_text` adds UTF-8 decoding (a leading byte-order mark, as spreadsheets write it, is
dropped) and refuses control characters, naming the line and column of the first one.
Every refusal is an :class:`~marknav.core.errors.InputError` (exit 2) naming the file.
"""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path

from marknav.core.errors import InputError

__all__ = ["MAX_IMAGE_BYTES", "MAX_TABLE_BYTES", "MAX_YAML_BYTES", "read_bytes", "read_text"]

#: Missions and worlds: a 50-waypoint mission is ~3 kB, a generated world ~20 kB (PyYAML reads
#: about 100 kB a second on a slow machine, so this bounds the time too).
MAX_YAML_BYTES = 256 * 1024
#: Calibration tables: a few dozen rows.
MAX_TABLE_BYTES = 1024 * 1024
#: Encoded images (a 12-megapixel PNG is ~20 MB).
MAX_IMAGE_BYTES = 64 * 1024 * 1024

_BOM = "\ufeff"
# C0 controls except TAB, LF, CR; DEL; C1 controls. (YAML and CSV text never needs them.)
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _size(n: int) -> str:
    return f"{n / (1024 * 1024):g} MiB" if n >= 1024 * 1024 else f"{n} bytes"


def read_bytes(path: str | Path, *, limit: int, what: str = "a file") -> bytes:
    """The whole content of the regular file ``path`` (at most ``limit`` bytes)."""
    name = str(path)
    if "\x00" in name:
        raise InputError("the file name contains a NUL character", file=name.replace("\x00",
                                                                                      "\\0"))
    try:
        st = os.stat(name)
    except FileNotFoundError:
        raise InputError("no such file", file=name) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", file=name) from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"is {_kind(st.st_mode)}, expected {what}", file=name)
    if st.st_size > limit:
        raise InputError(f"too large for {what}: {_size(st.st_size)} (limit {_size(limit)})",
                         file=name)
    try:
        fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", file=name) from None
    try:
        st = os.fstat(fd)  # the file opened, not a name swapped in since the stat above
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"is {_kind(st.st_mode)}, expected {what}", file=name)
        chunks: list[bytes] = []
        total = 0
        while True:
            try:
                chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            except OSError as exc:
                if exc.errno == errno.EINTR:
                    continue
                raise InputError(f"cannot read: {exc.strerror or exc}", file=name) from None
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:  # the file grew while we read it
                raise InputError(f"too large for {what} (limit {_size(limit)})", file=name)
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text(path: str | Path, *, limit: int, what: str = "a file") -> str:
    """:func:`read_bytes` decoded as UTF-8, without a leading BOM and free of control
    characters (TAB, LF and CR allowed)."""
    name = str(path)
    data = read_bytes(path, limit=limit, what=what)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputError(f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                         f"{exc.start})", file=name, line=line) from None
    if text.startswith(_BOM):
        text = text[1:]
    check_no_control(text, name)
    return text


def check_no_control(text: str, name: str) -> None:
    """:class:`InputError` at the first control character (other than TAB, LF, CR)."""
    m = _CONTROL.search(text)
    if m is None:
        return
    start = m.start()
    line = text.count("\n", 0, start) + 1
    column = start - (text.rfind("\n", 0, start) + 1) + 1
    raise InputError(f"control character U+{ord(m.group()):04X} is not allowed",
                     file=name, line=line, column=column)
