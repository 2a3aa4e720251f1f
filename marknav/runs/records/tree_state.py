"""A behaviour tree as plain data, and its one drawing: ``marknav tree``, the live view, the run
log, ``marknav replay`` and ``marknav tree --dot`` all use this notation and legend.

:class:`TreeState` holds each node's name, kind, memory, parent, status and feedback message.
It is captured from a running py_trees tree (:meth:`TreeState.capture` returns what changed
since the last capture, which the run log stores per tick) or rebuilt from a run log
(:meth:`TreeState.apply`), so the live view and ``marknav replay`` draw the same picture;
:meth:`TreeState.of_tree` of a tree that has not run is what ``marknav tree`` draws
(``full=True``: every node, nothing folded).

One line per node: indentation, status, kind, name, ``(m)`` for a composite with memory (it
resumes at its running child; without, it starts again from its first child every tick), and
the node's message. Status and composite kind use different symbols (py_trees draws ``[o]`` for
both a selector and a success): see :func:`legend`. Unicode symbols where the output can encode
them, ASCII otherwise (and in dot files, whose fonts may lack the glyphs).

The live drawing is compact: a composite that is not running is folded to one line (a finished
waypoint shows what it ended with), the running branch is open, and runs of folded siblings are
grouped when the tree would not fit ``max_rows``; if it still does not fit, the finished
siblings before the running branch and the idle ones after it are folded into one line each,
from the root down, so the running node is always on screen. An idle node shows no message.

Every message on screen is current or says when it is from: :class:`TickedNodes` (a py_trees
visitor the runner adds) sees which nodes the last tick reached, and a node it did not reach
(``SelectTarget`` under a sequence with memory that has moved on to its next child, a finished
waypoint) keeps its message prefixed with the time it was last ticked (``at t=9.90 s: ...``):
its words describe that moment, not this one.

:func:`dot_tree` writes Graphviz dot with node ids ``n0, n1, ...`` and the same labels as the
text (ASCII). py_trees' ``dot_tree`` uses the names as node ids, so a ``:`` in one ("Waypoint 1:
red") reads as a *port* in edge statements (Graphviz warns and draws the wrong node); here a
repeated name is told apart by its nearest uniquely named ancestor ("Passed?" / "in Waypoint 2:
green").
"""

from __future__ import annotations

import uuid
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import py_trees
import py_trees.visitors
from py_trees.behaviour import Behaviour

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
#: After the name of a composite with memory (both styles: plain letters every font has).
MEMORY = " (m)"
#: A failure its selector is handling (a condition that is simply false, e.g. ``Passed?``).
HANDLED = "HANDLED"
#: rich styles per status (the live view and replay; plain text ignores them).
STATUS_STYLE = {RUNNING: "bold yellow", SUCCESS: "green", FAILURE: "bold red", INVALID: "dim",
                HANDLED: "dim red"}


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


def has_memory(node: Behaviour) -> bool:
    """A composite that resumes at its running child (py_trees' ``memory=True``)."""
    return isinstance(node, py_trees.composites.Composite) and bool(
        getattr(node, "memory", False))


def legend_groups(style: str = "unicode", *, short: bool = False) -> list[str]:
    """The legend's parts (statuses, kinds, memory, folding), each kept on one line;
    ``short``: the memory mark without its explanation."""
    s, k = STATUS_SYMBOLS[style], KIND_SYMBOLS[style]
    status = "  ".join(f"{s[v].strip()} {w}" for v, w in (
        (RUNNING, "running"), (SUCCESS, "success"), (FAILURE, "failure"), (INVALID, "idle")))
    kinds = "  ".join(f"{k[v].strip()} {v}"
                      for v in ("sequence", "selector", "parallel", "decorator"))
    memory = f"{MEMORY.strip()} memory" + ("" if short else ": resumes its running child")
    return [status, kinds, memory, f"{FOLD[style]} folded"]


def legend(style: str = "unicode", width: int | None = None) -> str:
    """The symbols explained: one line, or (``width``) lines of at most ``width`` characters,
    shortened to fit where it helps; a part wider than ``width`` alone on its line."""
    full = "  |  ".join(legend_groups(style))
    if width is None or len(full) <= width:
        return full
    lines: list[str] = []
    for part in legend_groups(style, short=True):
        if lines and len(lines[-1]) + len("  |  ") + len(part) <= width:
            lines[-1] += "  |  " + part
        else:
            lines.append(part)
    return "\n".join(lines)


class TickedNodes(py_trees.visitors.VisitorBase):
    """The nodes the last tick reached (py_trees visits exactly the ticked ones); add it to the
    ``BehaviourTree`` with ``add_visitor``. ``ticks`` counts the ticks it saw."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.ids: set[uuid.UUID] = set()
        self.ticks = 0

    def initialise(self) -> None:
        self.ids = set()
        self.ticks += 1

    def run(self, behaviour: Behaviour) -> None:
        self.ids.add(behaviour.id)


def dated(message: str, t: float) -> str:
    """A message from an earlier tick, with the run time it was last current."""
    return f"at t={t:.2f} s: {message}"


@dataclass
class TreeState:
    """Names, kinds and parents of a tree's nodes (pre-order), with their current status."""

    names: list[str]
    kinds: list[str]
    parents: list[int]
    status: list[str] = field(default_factory=list)
    message: list[str] = field(default_factory=list)
    children: list[list[int]] = field(default_factory=list)
    #: per node: a composite with memory (run logs written before it was kept: all False)
    memory: list[bool] = field(default_factory=list)
    _nodes: list[py_trees.behaviour.Behaviour] = field(default_factory=list, repr=False)
    #: Which nodes each tick reached (a live tree's; the runner adds it to the tree).
    ticked: TickedNodes = field(default_factory=TickedNodes, repr=False)
    _last_ticked: list[float | None] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        n = len(self.names)
        if not self.status:
            self.status = [INVALID] * n
        if not self.message:
            self.message = [""] * n
        if not self.memory:
            self.memory = [False] * n
        self.children = [[] for _ in range(n)]
        self._last_ticked = [None] * n
        for i, p in enumerate(self.parents):
            if p >= 0:
                self.children[p].append(i)

    @classmethod
    def of_tree(cls, root: py_trees.behaviour.Behaviour) -> TreeState:
        nodes = _preorder(root)
        index = {id(n): i for i, n in enumerate(nodes)}
        parents = [index.get(id(n.parent), -1) if n.parent is not None else -1 for n in nodes]
        state = cls(names=[n.name for n in nodes], kinds=[kind_of(n) for n in nodes],
                    parents=parents, memory=[has_memory(n) for n in nodes])
        state._nodes = nodes
        return state

    def structure(self) -> dict[str, Any]:
        """The JSON form of the shape (names, kinds, parents, memory), for the run log's start
        record."""
        return {"names": self.names, "kinds": self.kinds, "parents": self.parents,
                "memory": self.memory}

    @classmethod
    def from_structure(cls, d: dict[str, Any]) -> TreeState:
        return cls(names=list(d["names"]), kinds=list(d["kinds"]), parents=list(d["parents"]),
                   memory=[bool(m) for m in d.get("memory", ())])

    def capture(self, now: float | None = None) -> dict[str, list[str]]:
        """Read the live tree; return ``{index: [status, message]}`` for the nodes that changed.

        An idle (INVALID) node's message is recorded as empty: it is not current. With the run
        time ``now`` and :attr:`ticked` on the tree, the message of a node this tick did not
        reach is :func:`dated` with the last tick that did.
        """
        changed: dict[str, list[str]] = {}
        status, message = self.status, self.message
        reached = self.ticked.ids if now is not None and self.ticked.ticks else None
        for i, node in enumerate(self._nodes):
            st = node.status.value
            msg = node.feedback_message if st != INVALID else ""
            if reached is not None:
                last = self._last_ticked[i]
                if node.id in reached:
                    self._last_ticked[i] = now
                elif msg and last is not None:
                    msg = dated(msg, last)
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

    def lines(self, *, style: str = "unicode", max_rows: int = 25,
              full: bool = False) -> list[tuple[str, str]]:
        """The drawing as ``(text, status)`` rows, at most ``max_rows`` of them (``status`` is
        :data:`HANDLED` for a failure its selector is handling); ``full``: every node, none
        folded, however many rows.

        Too many rows: runs of folded siblings are grouped; then, along the running branch
        from the root down, the finished composites before it are folded into one line, then
        the idle siblings after it, then every sibling before it (:data:`_FOLDINGS`); what
        still does not fit is cut from the top, the running branch kept."""
        if not self.names:
            return []
        if full:
            return [(t, st) for t, st, _ in self._draw(style, group=False, full=True)]
        rows = self._draw(style, group=False)
        if len(rows) > max_rows:
            rows = self._draw(style, group=True)
        spine = self._spine()
        folded: dict[int, set[str]] = {}
        for how in _FOLDINGS:
            for node in spine[:-1]:
                if len(rows) <= max_rows:
                    break
                folded.setdefault(node, set()).add(how)
                rows = self._draw(style, group=True, folded=folded)
        if len(rows) > max_rows:
            return self._cut(rows, max_rows, set(spine))
        return [(t, st) for t, st, _ in rows]

    def _spine(self) -> list[int]:
        """The running branch: the root and, at each level, its first running child."""
        path = [0]
        while True:
            running = [c for c in self.children[path[-1]] if self.status[c] == RUNNING]
            if not running:
                return path
            path.append(running[0])

    @staticmethod
    def _cut(rows: list[tuple[str, str, int]], max_rows: int,
             spine: set[int]) -> list[tuple[str, str]]:
        """At most ``max_rows`` rows: rows off the running branch dropped from the top, how
        many said on the first line."""
        drop = len(rows) - (max_rows - 1)
        out: list[tuple[str, str]] = []
        dropped = 0
        for text, st, node in rows:
            if dropped < drop and node not in spine:
                dropped += 1
                continue
            out.append((text, st))
        if dropped < drop:  # the running branch alone is longer than the screen
            hidden = len(out) - (max_rows - 1)
            return [*out[:max_rows - 1], (f"… {hidden} more rows", INVALID)]
        return [(f"… {dropped} rows not shown", INVALID), *out]

    def text(self, *, style: str = "unicode", max_rows: int = 25, full: bool = False) -> str:
        return "\n".join(t for t, _ in self.lines(style=style, max_rows=max_rows, full=full))

    def label(self, i: int, style: str) -> str:
        """Node ``i``'s kind, name and memory mark (the text lines' and the dot labels')."""
        return (f"{KIND_SYMBOLS[style][self.kinds[i]]}{self.names[i]}"
                f"{MEMORY if self.memory[i] else ''}")

    def _line(self, i: int, depth: int, style: str, folded: bool) -> tuple[str, str]:
        st = self.status[i]
        head = f"{'  ' * depth}{STATUS_SYMBOLS[style][st]} {self.label(i, style)}"
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

    def _draw(self, style: str, *, group: bool, full: bool = False,
              folded: dict[int, set[str]] | None = None) -> list[tuple[str, str, int]]:
        """Rows as (text, status, node index; -1 for a line standing for several nodes)."""
        rows: list[tuple[str, str, int]] = []
        folds = folded or {}

        def walk(i: int, depth: int) -> None:
            finished = self.status[0] in (SUCCESS, FAILURE)
            open_ = (full or i == 0 or (self.children[i] and self.status[i] == RUNNING)
                     or (finished and depth == 1 and len(self.children[i]) > 2))
            rows.append((*self._line(i, depth, style,
                                     folded=bool(self.children[i]) and not open_), i))
            if not open_:
                return
            groups = self._folds(i, folds.get(i, set()))
            hidden = {c for g in groups for c in g}
            kids = self.children[i]
            k = 0
            while k < len(kids):
                c = kids[k]
                if c in hidden:
                    rows.extend(self._group_line(g, depth + 1, style) for g in groups
                                if g[0] == c)
                    k += 1
                    continue
                if group and self.children[c] and self.status[c] != RUNNING:
                    run = [c]
                    while (k + len(run) < len(kids) and self.children[kids[k + len(run)]]
                           and kids[k + len(run)] not in hidden
                           and self.status[kids[k + len(run)]] == self.status[c]):
                        run.append(kids[k + len(run)])
                    if len(run) > 2:
                        rows.append(self._group_line(run, depth + 1, style))
                        k += len(run)
                        continue
                walk(c, depth + 1)
                k += 1

        walk(0, 0)
        return rows

    def _folds(self, i: int, hows: set[str]) -> list[list[int]]:
        """The groups of children of ``i`` that ``hows`` (:data:`_FOLDINGS`) fold into one line
        each: siblings before its running child, siblings after it."""
        kids = self.children[i]
        running = [k for k, c in enumerate(kids) if self.status[c] == RUNNING]
        if not hows or not running:
            return []
        before, after = kids[:running[0]], kids[running[0] + 1:]
        if "before" in hows:
            first = list(before)
        elif "done" in hows:
            first = [c for c in before
                     if self.children[c] and self.status[c] in (SUCCESS, FAILURE)]
        else:
            first = []
        second = list(after) if "after" in hows else []
        return [g for g in (first, second) if len(g) >= _MIN_FOLD]

    def _group_line(self, nodes: list[int], depth: int,
                    style: str) -> tuple[str, str, int]:
        """One line for ``nodes`` (siblings): how many, their status, the first and last."""
        st = self.status[nodes[0]]
        same = all(self.status[n] == st for n in nodes)
        symbol = STATUS_SYMBOLS[style][st] if same else STATUS_SYMBOLS[style][INVALID]
        return (f"{'  ' * depth}{symbol} {len(nodes)} × {FOLD[style]} {self.names[nodes[0]]} … "
                f"{self.names[nodes[-1]]}", st if same else INVALID, -1)


#: How :meth:`TreeState.lines` folds siblings of the running branch when the tree does not fit,
#: in order: the finished composites before it (finished waypoints), the siblings after it
#: (waypoints to come), then every sibling before it.
_FOLDINGS = ("done", "after", "before")
#: A fold replaces at least this many rows (one row folded into one line gains nothing).
_MIN_FOLD = 2


def _preorder(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    out: list[py_trees.behaviour.Behaviour] = []
    stack = [root]
    while stack:
        node = stack.pop()
        out.append(node)
        stack.extend(reversed(node.children))
    return out



# --- dot ------------------------------------------------------------------------------------

_DOT_STYLE = {"selector": ("octagon", "cyan"), "sequence": ("box", "orange"),
              "parallel": ("parallelogram", "gold"), "decorator": ("ellipse", "ghostwhite"),
              "leaf": ("ellipse", "gray")}


def _quote(text: str) -> str:
    """A dot double-quoted string (backslashes and quotes escaped, newlines as \\n)."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


def dot_tree(root: Behaviour) -> str:
    """The tree as Graphviz dot text (render: ``dot -Tpng FILE -o tree.png``): each node
    labelled as the text drawing's ASCII style labels it, the legend under the graph."""
    import pydot

    state = TreeState.of_tree(root)
    counts = Counter(state.names)

    def label(i: int) -> str:
        lines = [state.label(i, "ascii")]
        name = state.names[i]
        if counts[name] > 1:  # say where it is: its nearest uniquely named ancestor
            up = state.parents[i]
            while up >= 0 and counts[state.names[up]] > 1:
                up = state.parents[up]
            if up >= 0:
                lines.append(f"in {state.names[up].split(' (', 1)[0]}")  # "Waypoint 2: green"
        return "\n".join(lines)

    graph = pydot.Dot(graph_type="digraph", graph_name="marknav", ordering="out")
    kinds = "  ".join(f"{KIND_SYMBOLS['ascii'][k].strip()} {k}"
                      for k in ("sequence", "selector", "parallel", "decorator"))
    graph.set("label", _quote(f"{kinds}  {MEMORY.strip()} memory: resumes its running child"))
    graph.set("labelloc", "b")
    graph.set("fontname", "Helvetica")
    graph.set("fontsize", "10")
    graph.set_node_defaults(fontname="Helvetica", fontsize="10", style="filled")
    for i in range(len(state.names)):
        shape, colour = _DOT_STYLE[state.kinds[i]]
        graph.add_node(pydot.Node(f"n{i}", label=_quote(label(i)), shape=shape,
                                  fillcolor=colour))
        if state.parents[i] >= 0:
            graph.add_edge(pydot.Edge(f"n{state.parents[i]}", f"n{i}"))
    return str(graph.to_string())
