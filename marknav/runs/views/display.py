"""The view of a running (or replayed) tree: in place on a terminal, change-only text otherwise.

:class:`LiveView` (stdout is a terminal) redraws one screen in place with rich: a legend, the
compact tree (:mod:`~marknav.runs.records.tree_state`: finished waypoints folded to one line, the
running branch open, at most ~25 rows) and a status panel refreshed every tick — time, target,
range and bearing, wheel speeds, safety state, marks in view, camera rate, overruns. Log
messages are printed above it while it runs.

:class:`PlainView` (pipes, CI, log files) prints the tree only when a node's status changes,
with one status line under it.

Both take the :class:`~marknav.runs.records.tree_state.TreeState` and the panel figures the run
recorder captured, so ``marknav replay`` draws the same screens from a run log.
"""

from __future__ import annotations

import logging
import time
from typing import Any, TextIO

from marknav.runs.records.tree_state import STATUS_STYLE, TreeState, legend

STYLES = ("auto", "ascii", "unicode", "none")
#: The tree's share of the screen (rows), whatever the terminal's height.
MAX_TREE_ROWS = 25
#: The live view redraws at most this often (wall-clock seconds); the last state always shows.
MIN_REDRAW_S = 0.05


def resolve_style(style: str, out: TextIO) -> str:
    """``auto`` → ``unicode`` when ``out`` can encode it, else ``ascii``."""
    if style not in STYLES:
        raise ValueError(f"tree style must be one of {', '.join(STYLES)}, got {style!r}")
    if style != "auto":
        return style
    encoding = (getattr(out, "encoding", None) or "").lower().replace("-", "")
    return "unicode" if encoding in ("utf8", "utf16", "utf32") else "ascii"


def status_text(panel: dict[str, Any], style: str = "unicode") -> list[str]:
    """The panel as lines of text: what the run is doing now."""
    deg = "°" if style == "unicode" else " deg"
    t = f"t={panel.get('t', 0.0):.2f} s  tick {panel.get('tick', 0)}"
    if panel.get("active"):
        t += f"  doing: {panel['active']}"
    target = f"target {panel['target']}" if panel.get("target") else "target: none yet"
    if "range_mm" in panel:
        b = float(panel.get("bearing_deg", 0.0))
        side = "left" if b > 0 else "right"
        target += (f"  range {panel['range_mm'] / 1000.0:.2f} m  bearing {abs(b):.0f}{deg} "
                   f"{side}" if abs(b) >= 0.5 else
                   f"  range {panel['range_mm'] / 1000.0:.2f} m  bearing 0{deg}")
        if panel.get("seen_s_ago", 0.0) > 0.0:  # not in the newest frame
            target += f" (out of view, seen {panel['seen_s_ago']:.2f} s ago)"
    wheels = panel.get("wheels_mm_s")
    robot = (f"wheels L {wheels[0]:+d} R {wheels[1]:+d} mm/s  " if wheels else "") + \
        f"safety {panel.get('safety', '?')}"
    cam = panel.get("camera_hz")
    marks = ", ".join(panel.get("marks") or []) or "none"
    seen = (f"marks in view: {marks}  camera {cam:.1f} Hz" if cam is not None
            else f"marks in view: {marks}  camera: waiting for frames")
    if panel.get("latency_ms") is not None:
        seen += f"  latency {panel['latency_ms']:.0f} ms"
    seen += f"  overruns {panel.get('overruns', 0)}"
    return [t, target, robot, seen]


def status_line(panel: dict[str, Any], style: str = "unicode") -> str:
    """The panel on one line (the change-only text view)."""
    return "  |  ".join(status_text(panel, style))


class PlainView:
    """Prints the tree when a status changes, and a status line under it."""

    def __init__(self, out: TextIO, *, style: str = "ascii",
                 max_rows: int = MAX_TREE_ROWS) -> None:
        self.out = out
        self.style = resolve_style(style, out)
        self.max_rows = max_rows
        self._last: tuple[str, ...] | None = None
        self.prints = 0
        self.out.write(f"legend: {legend(self.style)}\n\n")

    def update(self, state: TreeState, panel: dict[str, Any]) -> bool:
        key = tuple(state.status)
        if key == self._last:
            return False
        self._last = key
        self.out.write(state.text(style=self.style, max_rows=self.max_rows) + "\n")
        self.out.write(status_line(panel, self.style) + "\n\n")
        self.out.flush()
        self.prints += 1
        return True

    def close(self) -> None:
        self.out.flush()


#: The status panel's height on screen: its four lines and the two of its box.
PANEL_ROWS = 6
#: Rows the live view leaves free below it (the cursor's line: a screen one row too tall
#: scrolls, and rich then redraws its top twice).
SPARE_ROWS = 1
#: The fewest tree rows the live view draws, however small the terminal.
MIN_TREE_ROWS = 8


def tree_rows(height: int, width: int, style: str) -> int:
    """How many tree rows fit a ``height`` × ``width`` terminal under the legend (wrapped to
    ``width``) and above the status panel, at most :data:`MAX_TREE_ROWS`."""
    legend_rows = legend(style, width).count("\n") + 1
    return max(MIN_TREE_ROWS, min(MAX_TREE_ROWS,
                                  height - legend_rows - PANEL_ROWS - SPARE_ROWS))


def render(state: TreeState, panel: dict[str, Any], *, style: str, max_rows: int,
           title: str = "", width: int | None = None) -> Any:
    """The screen as a rich renderable: legend (wrapped to ``width``), tree, status panel."""
    from rich.console import Group
    from rich.panel import Panel
    from rich.text import Text

    rows: list[Any] = [Text(line, style="dim", no_wrap=True, overflow="ellipsis")
                       for line in legend(style, width).split("\n")]
    for text, status in state.lines(style=style, max_rows=max_rows):
        rows.append(Text(text, style=STATUS_STYLE.get(status, ""), no_wrap=True,
                         overflow="ellipsis"))
    body = Text("\n".join(status_text(panel, style)), no_wrap=True, overflow="ellipsis")
    box = None if style == "unicode" else _ascii_box()
    kw: dict[str, Any] = {"title": title or None, "title_align": "left"}
    if box is not None:
        kw["box"] = box
    rows.append(Panel(body, **kw))
    return Group(*rows)


def _ascii_box() -> Any:
    from rich import box

    return box.ASCII


class LiveView:
    """Redraws the whole view in place on a terminal (rich ``Live``), every tick."""

    def __init__(self, out: TextIO, *, style: str = "auto", title: str = "") -> None:
        from rich.console import Console
        from rich.live import Live

        self.style = resolve_style(style, out)
        self.console = Console(file=out)
        self.title = title
        self._live = Live(console=self.console, auto_refresh=False, transient=False,
                          redirect_stdout=False, redirect_stderr=True,
                          vertical_overflow="crop")
        self._live.start()
        self._handlers: list[tuple[logging.StreamHandler[Any], Any]] = []
        self._redirect_logging()
        self._last_draw = 0.0
        self._pending: tuple[TreeState, dict[str, Any]] | None = None
        self.draws = 0

    def _redirect_logging(self) -> None:
        """Log records go above the live view, not through it (which would scroll it)."""
        import sys

        for handler in logging.getLogger().handlers:
            if isinstance(handler, logging.StreamHandler) and not isinstance(
                    handler, logging.FileHandler):
                old = handler.setStream(sys.stderr)  # rich's proxy while Live runs
                self._handlers.append((handler, old))

    def update(self, state: TreeState, panel: dict[str, Any]) -> bool:
        now = time.monotonic()
        self._pending = (state, panel)
        if now - self._last_draw < MIN_REDRAW_S:
            return False
        self._draw()
        self._last_draw = now
        return True

    def _draw(self) -> None:
        if self._pending is None:
            return
        state, panel = self._pending
        size = self.console.size  # read every time: the terminal may be resized
        self._live.update(render(state, panel, style=self.style,
                                 max_rows=tree_rows(size.height, size.width, self.style),
                                 title=self.title, width=size.width), refresh=True)
        self.draws += 1

    def close(self) -> None:
        if self._live.is_started:
            self._draw()
            self._live.stop()
            for handler, old in self._handlers:
                if old is not None:
                    handler.setStream(old)
            self._handlers = []


def make_view(out: TextIO | None, style: str, *, title: str = "") -> LiveView | PlainView | None:
    """The live view on a terminal, change-only text elsewhere, nothing for ``none``."""
    if out is None or style == "none":
        return None
    isatty = getattr(out, "isatty", None)
    if isatty is not None and isatty():
        import os

        if os.environ.get("TERM") != "dumb":
            return LiveView(out, style=style, title=title)
    return PlainView(out, style=style)
