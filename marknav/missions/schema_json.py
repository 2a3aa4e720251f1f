"""The mission file's JSON Schema, for editors and the reference pages: every key with its
description, and the tree node types a registry knows, with each type's params.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from marknav.core.errors import InputError, InputErrors
from marknav.missions.plugins import default_registry, registry_with_plugins
from marknav.missions.registry import NodeRegistry
from marknav.missions.schema_mission import Mission

__all__ = ["mission_json_schema"]


def mission_json_schema(
    registry: NodeRegistry | None = None, plugins: Sequence[str] = ()
) -> dict[str, Any]:
    """JSON Schema of mission files, for editors: every key with its description, the tree node
    types of ``registry`` (plus the ``plugins`` modules) as suggestions, and each node type's
    params and required keys."""
    registry = registry or default_registry()
    if plugins:
        registry, problems = registry_with_plugins(plugins, Path.cwd(), registry)
        if problems:
            raise InputErrors([InputError(message, field=f"--plugin {plugins[i]}")
                               for i, message in problems])
    schema = Mission.model_json_schema()
    defs: dict[str, Any] = schema.setdefault("$defs", {})
    node = defs["TreeNode"]
    node["properties"]["type"]["examples"] = registry.names()
    node["allOf"] = registry.json_schema_conditions(defs)
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
