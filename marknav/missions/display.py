"""The live view of a running tree: print it only when it changes, plus one status line.

Uses py_trees' :class:`~py_trees.visitors.SnapshotVisitor` so only the visited branch is marked,
and renders with :func:`py_trees.display.ascii_tree` or ``unicode_tree``. The tree is printed when
its rendered text changes (which also catches feedback-message changes that ``snap.changed``
ignores), not every tick. Colours: py_trees decides at import whether the output is a terminal;
``PY_TREES_DISABLE_COLORS=1`` turns them off (set by the CLI when stdout is not a terminal).
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
        self._last = ""
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
        text = self.render()
        if text == self._last:
            return False
        self._last = text
        status = self.status_line() if self.status_line else ""
        self.out.write(text.rstrip("\n") + "\n")
        if status:
            self.out.write(status + "\n")
        self.out.write("\n")
        self.out.flush()
        self.prints += 1
        return True
