"""A behaviour tree as plain data, and its compact drawing (live view, run log and replay).

:class:`TreeState` holds each node's name, kind, parent, status and feedback message. It is
captured from a running py_trees tree (:meth:`TreeState.capture` returns what changed since the
last capture, which the run log stores per tick) or rebuilt from a run log
(:meth:`TreeState.apply`), so the live view and ``marknav replay`` draw the same picture.

The drawing is compact: a composite that is not running is folded to one line (a finished
waypoint shows what it ended with), the running branch is open, and runs of folded siblings are
grouped when the tree would not fit ``max_rows``. Status and composite kind use different
symbols (py_trees draws ``[o]`` for both a selector and a success): see :func:`legend`. A
node that was not ticked shows no message, so nothing stale stays on screen.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import py_trees

from marknav.missions.tree_display import kind_of

RUNNING, SUCCESS, FAILURE, INVALID = "RUNNING", "SUCCESS", "FAILURE", "INVALID"

STATUS_SYMBOLS = {
    "unicode": {RUNNING: "▶", SUCCESS: "✔", FAILURE: "✘", INVALID: "·"},
    "ascii": {RUNNING: "RUN ", SUCCESS: "ok  ", FAILURE: "FAIL", INVALID: "-   "},
}
KIND_SYMBOLS = {
    "unicode": {"sequence": "→ ", "selector": "? ", "parallel": "⇉ ", "decorator": "◇ ",
                "leaf": ""},
    "ascii": {"sequence": "-> ", "selector": "?? ", "parallel": "=> ", "decorator": "<> ",
              "leaf": ""},
}
FOLD = {"unicode": "▸", "ascii": "::"}
#: A failure its selector is handling (a condition that is simply false, e.g. ``Passed?``).
HANDLED = "HANDLED"
#: rich styles per status (the live view and replay; plain text ignores them).
STATUS_STYLE = {RUNNING: "bold yellow", SUCCESS: "green", FAILURE: "bold red", INVALID: "dim",
                HANDLED: "dim red"}


def legend(style: str = "unicode") -> str:
    """One line explaining the symbols."""
    s, k = STATUS_SYMBOLS[style], KIND_SYMBOLS[style]
    status = "  ".join(f"{s[v].strip()} {w}" for v, w in (
        (RUNNING, "running"), (SUCCESS, "success"), (FAILURE, "failure"), (INVALID, "idle")))
    kinds = "  ".join(f"{k[v].strip()} {v}" for v in ("sequence", "selector", "parallel"))
    return f"{status}  |  {kinds}  |  {FOLD[style]} folded"


@dataclass
class TreeState:
    """Names, kinds and parents of a tree's nodes (pre-order), with their current status."""

    names: list[str]
    kinds: list[str]
    parents: list[int]
    status: list[str] = field(default_factory=list)
    message: list[str] = field(default_factory=list)
    children: list[list[int]] = field(default_factory=list)
    _nodes: list[py_trees.behaviour.Behaviour] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        n = len(self.names)
        if not self.status:
            self.status = [INVALID] * n
        if not self.message:
            self.message = [""] * n
        self.children = [[] for _ in range(n)]
        for i, p in enumerate(self.parents):
            if p >= 0:
                self.children[p].append(i)

    @classmethod
    def of_tree(cls, root: py_trees.behaviour.Behaviour) -> TreeState:
        nodes = _preorder(root)
        index = {id(n): i for i, n in enumerate(nodes)}
        parents = [index.get(id(n.parent), -1) if n.parent is not None else -1 for n in nodes]
        state = cls(names=[n.name for n in nodes], kinds=[kind_of(n) for n in nodes],
                    parents=parents)
        state._nodes = nodes
        return state

    def structure(self) -> dict[str, Any]:
        """The JSON form of the shape (names, kinds, parents), for the run log's start record."""
        return {"names": self.names, "kinds": self.kinds, "parents": self.parents}

    @classmethod
    def from_structure(cls, d: dict[str, Any]) -> TreeState:
        return cls(names=list(d["names"]), kinds=list(d["kinds"]), parents=list(d["parents"]))

    def capture(self) -> dict[str, list[str]]:
        """Read the live tree; return ``{index: [status, message]}`` for the nodes that changed.

        An idle (INVALID) node's message is recorded as empty: it is not current.
        """
        changed: dict[str, list[str]] = {}
        status, message = self.status, self.message
        for i, node in enumerate(self._nodes):
            st = node.status.value
            msg = node.feedback_message if st != INVALID else ""
            if st != status[i] or msg != message[i]:
                status[i], message[i] = st, msg
                changed[str(i)] = [st, msg]
        return changed

    def apply(self, changes: dict[str, list[str]]) -> None:
        for key, (st, msg) in changes.items():
            i = int(key)
            self.status[i], self.message[i] = st, msg

    def active_path(self) -> str:
        """Names from the root down to the running leaf."""
        names = [self.names[0]] if self.names else []
        i = 0
        while self.names:
            running = [c for c in self.children[i] if self.status[c] == RUNNING]
            if not running:
                break
            i = running[0]
            names.append(self.names[i])
        return " / ".join(names)

    # -- drawing ---------------------------------------------------------------------------
    def summary(self, i: int) -> str:
        """What a folded node ended with: its own message, else the last message below it that
        has the same status."""
        if self.message[i]:
            return self.message[i]
        st = self.status[i]
        if st == INVALID:
            return ""
        found = ""
        stack = list(reversed(self.children[i]))
        while stack:
            j = stack.pop()
            if self.status[j] == st and self.message[j]:
                found = self.message[j]
            stack.extend(reversed(self.children[j]))
        return found

    def lines(self, *, style: str = "unicode", max_rows: int = 25) -> list[tuple[str, str]]:
        """The drawing as ``(text, status)`` rows, at most ``max_rows`` of them (``status`` is
        :data:`HANDLED` for a failure its selector is handling)."""
        if not self.names:
            return []
        rows = self._draw(style, group=False)
        if len(rows) > max_rows:
            rows = self._draw(style, group=True)
        if len(rows) > max_rows:
            hidden = len(rows) - (max_rows - 1)
            rows = [*rows[:max_rows - 1], (f"… {hidden} more rows", INVALID)]
        return rows

    def text(self, *, style: str = "unicode", max_rows: int = 25) -> str:
        return "\n".join(t for t, _ in self.lines(style=style, max_rows=max_rows))

    def _line(self, i: int, depth: int, style: str, folded: bool) -> tuple[str, str]:
        st = self.status[i]
        kind = self.kinds[i]
        head = (f"{'  ' * depth}{STATUS_SYMBOLS[style][st]} {KIND_SYMBOLS[style][kind]}"
                f"{self.names[i]}")
        if folded:
            msg = self.summary(i)
            head += f" {FOLD[style]}"
        else:
            msg = self.message[i]
        dash = " — " if style == "unicode" else " -- "
        p = self.parents[i]
        if (st == FAILURE and p >= 0 and self.kinds[p] == "selector"
                and self.status[p] != FAILURE):
            st = HANDLED  # drawn dim: the selector goes on with its next child
        return (head + (dash + msg if msg else ""), st)

    def _draw(self, style: str, *, group: bool) -> list[tuple[str, str]]:
        rows: list[tuple[str, str]] = []

        def walk(i: int, depth: int) -> None:
            finished = self.status[0] in (SUCCESS, FAILURE)
            open_ = (i == 0 or (self.children[i] and self.status[i] == RUNNING)
                     or (finished and depth == 1 and len(self.children[i]) > 2))
            rows.append(self._line(i, depth, style, folded=bool(self.children[i]) and not open_))
            if not open_:
                return
            kids = self.children[i]
            k = 0
            while k < len(kids):
                c = kids[k]
                if group and self.children[c] and self.status[c] != RUNNING:
                    run = [c]
                    while (k + len(run) < len(kids) and self.children[kids[k + len(run)]]
                           and self.status[kids[k + len(run)]] == self.status[c]):
                        run.append(kids[k + len(run)])
                    if len(run) > 2:
                        st = self.status[c]
                        rows.append((f"{'  ' * (depth + 1)}{STATUS_SYMBOLS[style][st]} "
                                     f"{len(run)} × {FOLD[style]} {self.names[run[0]]} … "
                                     f"{self.names[run[-1]]}", st))
                        k += len(run)
                        continue
                walk(c, depth + 1)
                k += 1

        walk(0, 0)
        return rows


def _preorder(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    out: list[py_trees.behaviour.Behaviour] = []
    stack = [root]
    while stack:
        node = stack.pop()
        out.append(node)
        stack.extend(reversed(node.children))
    return out

