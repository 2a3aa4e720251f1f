"""ROS 2 message types without ROS: definitions as ``ros2 bag`` stores them, and CDR encoders.

The ``.msg`` texts live in ``ros2_msgs/`` beside this module (see its README for their origin
and licence). :func:`definition` gives a type's text followed by the texts of every type it
uses, each after a line of 80 ``=`` and ``MSG: package/Name`` — the ``ros2msg`` schema
encoding of MCAP, which Foxglove, Lichtblick, Rerun, ``rosbags`` and ``ros2 bag`` read.
:func:`encoder` turns a message given as nested dicts into its CDR bytes
(``mcap-ros2-support``'s dynamic serializer, the one its own writer uses).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

MSG_DIR = Path(__file__).with_name("ros2_msgs")
#: What separates the definitions of a type's dependencies in a ``ros2msg`` schema.
SEPARATOR = "=" * 80
_PRIMITIVES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring"})
_FIELD = re.compile(r"^\s*([A-Za-z0-9_/]+)(?:\[[^\]]*\])?(?:<=\d+)?\s+[A-Za-z0-9_]+")


def _short(name: str) -> str:
    """``pkg/msg/Name`` -> ``pkg/Name`` (how one .msg file names another)."""
    pkg, _, leaf = name.split("/")
    return f"{pkg}/{leaf}"


def _full(short: str) -> str:
    pkg, leaf = short.split("/")
    return f"{pkg}/msg/{leaf}"


@functools.cache
def own_text(name: str) -> str:
    """The ``.msg`` text of ``pkg/msg/Name`` alone (KeyError for a type marknav does not ship)."""
    pkg, kind, leaf = name.split("/")
    path = MSG_DIR / pkg / kind / f"{leaf}.msg"
    if not path.is_file():
        raise KeyError(f"no ROS 2 definition for {name} in {MSG_DIR}")
    return path.read_text(encoding="utf-8").strip()


def dependencies(name: str) -> list[str]:
    """Every type ``name`` uses, depth first, each once, without ``name`` itself."""
    seen: list[str] = []

    def visit(type_name: str) -> None:
        for line in own_text(type_name).splitlines():
            m = _FIELD.match(line)  # constants (int32 ADD=0) have primitive types
            if m is None or m.group(1) in _PRIMITIVES:
                continue
            dep = _full(m.group(1))
            if dep != name and dep not in seen:
                seen.append(dep)
                visit(dep)

    visit(name)
    return seen


@functools.cache
def definition(name: str) -> str:
    """The concatenated definition of ``pkg/msg/Name`` (an MCAP ``ros2msg`` schema's data)."""
    parts = [own_text(name)]
    for dep in dependencies(name):
        parts.append(f"{SEPARATOR}\nMSG: {_short(dep)}\n{own_text(dep)}")
    return "\n".join(parts) + "\n"


@functools.cache
def encoder(name: str) -> Callable[[Any], bytes]:
    """CDR encoder of ``pkg/msg/Name``: a dict (nested dicts, lists, bytes) -> the message."""
    from mcap_ros2._dynamic import serialize_dynamic

    encoders = serialize_dynamic(name, definition(name))
    fn: Callable[[Any], bytes] = encoders[name]
    return fn
