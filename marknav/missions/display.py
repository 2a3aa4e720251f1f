"""The live view of a running tree: print it only when it changes, plus one status line.

Uses py_trees' :class:`~py_trees.visitors.SnapshotVisitor` so only the visited branch is marked,
and renders with :func:`py_trees.display.ascii_tree` or ``unicode_tree``. The tree is printed when
a node's status changes or another branch is visited — not every tick, and not when only a
feedback message moves (a distance counting down would reprint it every tick); the status line
under it carries the live figures. Colours: py_trees uses them only when stdout is a terminal;
``PY_TREES_DISABLE_COLORS=1`` turns them off.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TextIO

import py_trees

STYLES = ("ascii", "unicode", "none")


class TreeView:
    """Prints the tree to ``out`` whenever its rendering changes."""

    def __init__(
        self,
        tree: py_trees.trees.BehaviourTree,
        out: TextIO,
        *,
        style: str = "ascii",
        status_line: Callable[[], str] | None = None,
    ) -> None:
        if style not in STYLES:
            raise ValueError(f"tree style must be one of {', '.join(STYLES)}, got {style!r}")
        self.tree = tree
        self.out = out
        self.style = style
        self.status_line = status_line
        self.snapshot = py_trees.visitors.SnapshotVisitor()
        self._last: tuple[tuple[str, str], ...] | None = None
        self.prints = 0
        if style != "none":
            tree.add_visitor(self.snapshot)

    def render(self) -> str:
        display = py_trees.display
        fn = display.unicode_tree if self.style == "unicode" else display.ascii_tree
        text: str = fn(
            self.tree.root,
            show_status=True,
            visited=self.snapshot.visited,
            previously_visited=self.snapshot.previously_visited,
        )
        return text

    def update(self) -> bool:
        """Call after each tick; prints and returns True when the tree looks different."""
        if self.style == "none":
            return False
        key = tuple(sorted((str(k), v.value) for k, v in self.snapshot.visited.items()))
        if key == self._last:
            return False
        self._last = key
        text = self.render()
        status = self.status_line() if self.status_line else ""
        self.out.write(text.rstrip("\n") + "\n")
        if status:
            self.out.write(status + "\n")
        self.out.write("\n")
        self.out.flush()
        self.prints += 1
        return True
