"""Loading a mission file: the YAML document checked as a :class:`Mission`, with the ``--set``
overrides applied first and the mission's ``plugins`` registered, and every problem reported
at once as ``FILE:LINE:COLUMN: field.path: message`` (a problem of a ``--set`` setting at the
setting, an unknown key at the key).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from marknav.core.errors import InputError, InputErrors
from marknav.core.yamlio import Loc, YamlDocument, load_yaml_file, validation_errors
from marknav.missions.overrides import Override, apply_overrides, relabel
from marknav.missions.plugins import default_registry, registry_with_plugins
from marknav.missions.registry import UNKNOWN_KEY, NodeRegistry
from marknav.missions.schema_mission import Mission
from marknav.missions.schema_problems import field_path

__all__ = ["load_mission", "parse_mission"]


def parse_mission(
    doc: YamlDocument,
    registry: NodeRegistry | None = None,
    overrides: Sequence[Override] = (),
) -> Mission:
    """Validate a parsed YAML document as a mission; raise :class:`InputErrors` with every
    problem. ``registry`` (default: :func:`default_registry`) decides which tree node types exist;
    the mission's own ``plugins`` modules are added to a copy of it. ``overrides`` (``--set``)
    are applied first; problems in them are reported at the setting. ``sim.world`` is resolved
    relative to the document's file."""
    if not isinstance(doc.data, dict):
        pos = doc.position(())
        raise InputError(
            "a mission is a mapping of keys (name: ..., route: [...], marks: {...}), "
            f"not {_kind(doc.data)}",
            file=doc.path, line=pos.line if pos else 1, column=pos.column if pos else 1,
        )
    doc = apply_overrides(doc, overrides)
    base = registry or default_registry()
    registry, plugin_errors = _with_plugins(doc, base)
    context = {"registry": registry}
    try:
        mission = Mission.model_validate(doc.data, context=context)
    except ValidationError as exc:
        errors = [*plugin_errors, *_mission_errors(exc, doc).errors]
        errors = relabel(errors, overrides)
        raise InputErrors(sorted(errors, key=_error_order)) from None
    if plugin_errors:
        raise InputErrors(relabel(plugin_errors, overrides))
    mission._document = doc
    mission._source_path = Path(doc.path)
    mission._registry = registry if registry is not base else None
    mission._overrides = tuple(o.text for o in overrides)
    if mission.sim is not None and mission.sim.world is not None:
        mission.sim.world = Path(doc.path).parent / mission.sim.world
    return mission


def _error_order(e: InputError) -> tuple[int, int, int]:
    # File errors by position; errors of --set settings (no line) after them.
    return (1 if e.line is None else 0, e.line or 0, e.column or 0)


def _with_plugins(doc: YamlDocument, base: NodeRegistry) -> tuple[NodeRegistry, list[InputError]]:
    """``base`` plus the mission's ``plugins`` (when it lists valid module names), and one error
    per plugin that failed, at its line."""
    modules = doc.data.get("plugins") if isinstance(doc.data, dict) else None
    if not isinstance(modules, list) or not modules:
        return base, []
    names = [m if isinstance(m, str) and m else "" for m in modules]
    registry, problems = registry_with_plugins(
        [n for n in names if n], Path(doc.path).resolve().parent, base)
    valid = [i for i, n in enumerate(names) if n]  # positions of the names tried
    errors: list[InputError] = []
    for j, message in problems:
        loc: Loc = ("plugins", valid[j])
        pos = doc.position(loc)
        errors.append(InputError(message, file=doc.path, line=pos.line if pos else None,
                                 column=pos.column if pos else None, field=field_path(loc)))
    return registry, errors


def _kind(value: Any) -> str:
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    return "null" if value is None else type(value).__name__


def load_mission(
    path: str | Path,
    registry: NodeRegistry | None = None,
    overrides: Sequence[Override] = (),
) -> Mission:
    """Load and check a mission file, with ``--set`` ``overrides`` applied. Bad input raises
    :class:`InputError` (one problem) or :class:`InputErrors` (all of them), each
    ``FILE:LINE:COLUMN: field: message``."""
    return parse_mission(load_yaml_file(path), registry, overrides)


def _mission_errors(exc: ValidationError, doc: YamlDocument) -> InputErrors:
    mapped = validation_errors(exc, doc, Mission)
    # Unknown keys found by model_problems: point at the key, as yamlio does for the others.
    for err in exc.errors(include_url=False):
        if err["type"] != UNKNOWN_KEY:
            continue
        loc = tuple(err["loc"])
        key_pos = doc.key_positions.get(loc)
        if key_pos is None:
            continue
        for e in mapped.errors:
            if e.field == field_path(loc) and e.message == err["msg"]:
                e.line, e.column = key_pos.line, key_pos.column
    errors = sorted(mapped.errors, key=lambda e: (e.line or 0, e.column or 0))
    return InputErrors(errors)
