"""``--set KEY=VALUE``: change one mission setting from the command line.

``KEY`` is a dotted path into the mission (``navigation.clearance_mm``, ``camera.range.a``,
``route.2`` for a list item); ``VALUE`` is read as YAML (``350``, ``true``, ``[red, green]``,
``{model: pinhole, focal_px: 590}``), with the same safe loader as mission files. The settings are
applied to the loaded file before it is checked, so they are validated exactly like the file;
a problem in a setting is reported at the setting (``--set navigation.clearance_mm=-5:
navigation.clearance_mm: Input should be greater than 0``) rather than at a line of the file.
Missing mappings on the way are created (``--set sim.seed=3`` on a mission without ``sim:``).
"""

from __future__ import annotations

import copy
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from marknav.core.errors import InputError
from marknav.core.yamlio import Loc, YamlDocument, load_yaml_text

_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*(\.([A-Za-z_][A-Za-z0-9_-]*|[0-9]+))*$")


@dataclass(frozen=True)
class Override:
    """One ``--set KEY=VALUE``."""

    key: str
    loc: Loc
    value: Any
    text: str  # as given: KEY=VALUE

    @property
    def field(self) -> str:
        """The key in the notation of error messages (``route[2]``, ``camera.range.a``)."""
        out = ""
        for part in self.loc:
            out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + part
        return out


def parse_override(text: str) -> Override:
    """``KEY=VALUE`` as an :class:`Override`; :class:`InputError` (field ``--set``) if malformed."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"expected KEY=VALUE (e.g. navigation.clearance_mm=350), got {text!r}",
                         field="--set")
    if not _KEY.match(key):
        raise InputError(f"{key!r} is not a dotted key such as navigation.clearance_mm",
                         field="--set")
    loc: Loc = tuple(int(p) if p.isdigit() else p for p in key.split("."))
    if raw.strip() == "":
        raise InputError(f"no value for {key} (write {key}=VALUE)", field="--set")
    try:
        value = load_yaml_text(raw, f"--set {key}").data
    except InputError as exc:
        raise InputError(f"the value of {key} is not valid YAML: {exc.message}",
                         field="--set") from None
    return Override(key=key, loc=loc, value=value, text=f"{key}={raw}")


def parse_overrides(texts: Iterable[str] | None) -> tuple[Override, ...]:
    """Every ``--set`` of a command line, in order (a later one wins)."""
    return tuple(parse_override(t) for t in texts or ())


def apply_overrides(doc: YamlDocument, overrides: Sequence[Override]) -> YamlDocument:
    """A copy of ``doc`` with the overrides applied; :class:`InputError` if a key cannot be
    reached (an index past the end of a list, a key below a number...)."""
    if not overrides:
        return doc
    data = copy.deepcopy(doc.data)
    if not isinstance(data, dict):
        return doc  # the mission itself is malformed: reported by the loader
    for o in overrides:
        node: Any = data
        for depth, part in enumerate(o.loc):
            last = depth == len(o.loc) - 1
            where = ".".join(str(p) for p in o.loc[:depth]) or "the mission"
            if isinstance(node, list):
                if not isinstance(part, int):
                    raise InputError(f"{where} is a list: use an index (e.g. {where}.0)",
                                     file=f"--set {o.text}", field=o.field)
                if not 0 <= part < len(node):
                    raise InputError(f"{where} has {len(node)} entries: no index {part}",
                                     file=f"--set {o.text}", field=o.field)
            elif isinstance(node, dict):
                part = str(part)
                if not last and not isinstance(node.get(part), (dict, list)):
                    if part in node and node[part] is not None:
                        inner = ".".join(str(p) for p in o.loc[:depth + 1])
                        raise InputError(f"{inner} is not a mapping",
                                         file=f"--set {o.text}", field=o.field)
                    node[part] = {}
            else:
                raise InputError(f"{where} is not a mapping", file=f"--set {o.text}",
                                 field=o.field)
            if last:
                node[part] = copy.deepcopy(o.value)
            else:
                node = node[part]
    return YamlDocument(path=doc.path, data=data, positions=doc.positions,
                        key_positions=doc.key_positions)


def _under(field: str | None, prefix: str) -> bool:
    if field is None:
        return False
    return field == prefix or field.startswith(prefix + ".") or field.startswith(prefix + "[")


def relabel(errors: Iterable[InputError], overrides: Sequence[Override]) -> list[InputError]:
    """Errors in a field a ``--set`` gave (or below it) located at that setting, not the file."""
    out: list[InputError] = []
    for e in errors:
        for o in reversed(overrides):  # the last setting of a key is the one in effect
            if _under(e.field, o.field):
                e = InputError(e.message, file=f"--set {o.text}", field=e.field)
                break
        out.append(e)
    return out
