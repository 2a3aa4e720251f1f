"""Drawing a behaviour tree for ``marknav tree``: unicode text and Graphviz dot.

- :func:`unicode_tree`: box-drawing lines and one symbol per node kind (legend:
  :data:`UNICODE_LEGEND`); py_trees' own ``unicode_tree`` differs from its ``ascii_tree`` only in
  the status marks of a ticked tree, so a tree that has not run looked the same either way.
- :func:`dot_tree`: Graphviz dot with node ids ``n0, n1, ...`` and the names as quoted labels.
  py_trees' ``dot_tree`` uses the names as node ids, so a ``:`` in one ("Waypoint 1: red") reads
  as a *port* in edge statements (Graphviz warns and draws the wrong node); repeated names get
  ``*`` appended; composites with memory get a circled M many fonts lack. Here a repeated name is
  told apart by its nearest uniquely named ancestor ("Passed?" / "in Waypoint 2: green"), and the
  labels are plain text (memory and policy spelt out).
"""

from __future__ import annotations

from collections import Counter

import py_trees
import pydot
from py_trees.behaviour import Behaviour

__all__ = ["UNICODE_LEGEND", "dot_tree", "unicode_tree"]

UNICODE_LEGEND = ("→ sequence  ? selector  ⇉ parallel  ◇ decorator  • behaviour  "
                  "Ⓜ with memory (resumes at the running child)")


def _children(node: Behaviour) -> list[Behaviour]:
    return list(node.children)


def _memory(node: Behaviour) -> bool:
    return bool(getattr(node, "memory", False))


def kind_of(node: Behaviour) -> str:
    """What a node is: ``sequence``, ``selector``, ``parallel``, ``decorator`` or ``leaf``."""
    if isinstance(node, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(node, py_trees.composites.Selector):
        return "selector"
    if isinstance(node, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(node, py_trees.decorators.Decorator):
        return "decorator"
    return "leaf"


_SYMBOLS = {"sequence": "→", "selector": "?", "parallel": "⇉", "decorator": "◇", "leaf": "•"}


def _symbol(node: Behaviour) -> str:
    return _SYMBOLS[kind_of(node)]


def _unicode_label(node: Behaviour) -> str:
    label = f"{_symbol(node)} {node.name}"
    if isinstance(node, py_trees.composites.Composite) and _memory(node):
        label += " Ⓜ"
    return label


def unicode_tree(root: Behaviour) -> str:
    """The tree drawn with box-drawing characters, one node a line."""
    lines = [_unicode_label(root)]

    def walk(node: Behaviour, prefix: str) -> None:
        kids = _children(node)
        for i, child in enumerate(kids):
            last = i == len(kids) - 1
            lines.append(f"{prefix}{'└── ' if last else '├── '}{_unicode_label(child)}")
            walk(child, prefix + ("    " if last else "│   "))

    walk(root, "")
    return "\n".join(lines) + "\n"


# --- dot ------------------------------------------------------------------------------------

_STYLE: tuple[tuple[type, str, str], ...] = (
    (py_trees.composites.Selector, "octagon", "cyan"),
    (py_trees.composites.Sequence, "box", "orange"),
    (py_trees.composites.Parallel, "parallelogram", "gold"),
    (py_trees.decorators.Decorator, "ellipse", "ghostwhite"),
)


def _style(node: Behaviour) -> tuple[str, str]:
    for cls, shape, colour in _STYLE:
        if isinstance(node, cls):
            return shape, colour
    return "ellipse", "gray"


def _kind_line(node: Behaviour) -> str | None:
    if isinstance(node, py_trees.composites.Parallel):
        return f"parallel, {type(node.policy).__name__}"
    if isinstance(node, py_trees.composites.Sequence):
        return "sequence, memory" if _memory(node) else "sequence, reactive"
    if isinstance(node, py_trees.composites.Selector):
        return "selector, memory" if _memory(node) else "selector, reactive"
    return None


def _quote(text: str) -> str:
    """A dot double-quoted string (backslashes and quotes escaped, newlines as \\n)."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


def dot_tree(root: Behaviour) -> str:
    """The tree as Graphviz dot text (render: ``dot -Tpng FILE -o tree.png``)."""
    nodes: list[tuple[Behaviour, Behaviour | None]] = []

    def collect(node: Behaviour, parent: Behaviour | None) -> None:
        nodes.append((node, parent))
        for child in _children(node):
            collect(child, node)

    collect(root, None)
    counts = Counter(n.name for n, _ in nodes)
    parent_of = {n.id: p for n, p in nodes}
    ids = {n.id: f"n{i}" for i, (n, _) in enumerate(nodes)}

    def label(node: Behaviour) -> str:
        lines = [node.name]
        if counts[node.name] > 1:  # say where it is: its nearest uniquely named ancestor
            up = parent_of[node.id]
            while up is not None and counts[up.name] > 1:
                up = parent_of[up.id]
            if up is not None:
                where = up.name.split(" (", 1)[0]  # "Waypoint 2: green (pass on its right)"
                lines.append(f"in {where}")
        kind = _kind_line(node)
        if kind is not None:
            lines.append(kind)
        return "\n".join(lines)

    graph = pydot.Dot(graph_type="digraph", graph_name="marknav", ordering="out")
    graph.set_node_defaults(fontname="Helvetica", fontsize="10", style="filled")
    for node, parent in nodes:
        shape, colour = _style(node)
        graph.add_node(pydot.Node(ids[node.id], label=_quote(label(node)), shape=shape,
                                  fillcolor=colour))
        if parent is not None:
            graph.add_edge(pydot.Edge(ids[parent.id], ids[node.id]))
    return str(graph.to_string())
