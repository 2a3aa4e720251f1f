"""MkDocs hook: charts drawn from the code at build time, in place of a marker in a page.

A page holding the line ``<!-- chart: NAME -->`` gets, in its place, the chart ``NAME`` as a
``text`` block. Charts:

- ``safety``: the safety layer's transitions, from its ``transitions.Machine``
  (:func:`marknav.robot.safety_chart.safety_chart`), in ``explanation/safety.md``.

A marker naming no chart fails the build.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

MARKER = re.compile(r"^<!-- chart: ([a-z-]+) -->$", re.MULTILINE)


def _safety() -> str:
    from marknav.robot.safety_chart import safety_chart

    return safety_chart()


CHARTS: dict[str, Callable[[], str]] = {"safety": _safety}


def fill_charts(markdown: str) -> str:
    """``markdown`` with every chart marker replaced by its chart."""

    def chart(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in CHARTS:
            raise ValueError(f"no chart {name!r} (known: {', '.join(sorted(CHARTS))})")
        return "```text\n" + CHARTS[name]().rstrip("\n") + "\n```"

    return MARKER.sub(chart, markdown)


def on_page_markdown(markdown: str, **_kwargs: Any) -> str:
    return fill_charts(markdown)
