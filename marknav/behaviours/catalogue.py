"""marknav's own node types for a mission's ``tree:``: the built-ins
(:mod:`marknav.behaviours.builtin_nodes`: py_trees' composites and decorators, ``Pause``,
``Timeout``) and marknav's behaviours (:mod:`marknav.behaviours.nodes`).

The registry (:mod:`marknav.missions.registry`) sits below the behaviours and knows no node type.
marknav registers its own the way a user's package does: :func:`register` is the target of
marknav's entry point in the group ``marknav.nodes`` (``pyproject.toml``), which
:func:`marknav.missions.plugins.default_registry` loads with every other installed package's.
"""

from __future__ import annotations

from marknav.behaviours import builtin_nodes, nodes
from marknav.missions.registry import NodeRegistry


def register(registry: NodeRegistry) -> None:
    """Add the built-in node types and marknav's behaviours to ``registry``."""
    builtin_nodes.register_builtins(registry)
    nodes.register(registry)


def builtin_registry() -> NodeRegistry:
    """A fresh registry holding only the built-in node types (no marknav behaviours)."""
    registry = NodeRegistry()
    builtin_nodes.register_builtins(registry)
    return registry
