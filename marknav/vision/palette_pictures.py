"""What ``marknav palette --annotate DIR`` shows of a teaching: each picture with the marks it
found outlined in the colour each was given, and the hue histogram of every colour's mark
pixels with the ranges proposed (or checked) and the margins between them.

The outline of a mark is its fitted ellipse, drawn in the hue its colour's range is centred on
(full saturation and value, so a pale mark's outline still reads as its colour), with the name;
a mark given no colour is outlined grey. The histogram needs matplotlib (the ``plot`` extra).
"""

from __future__ import annotations

import colorsys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.errors import InputError
from marknav.core.wording import count
from marknav.vision.palette import HUE_MAX, ColourRange, Palette
from marknav.vision.palette_teach import RoundMark

__all__ = ["colour_bgr", "hue_histogram", "margins_of", "outline_marks"]

Image = npt.NDArray[np.uint8]

#: Outline thickness (px) and the label's font scale (OpenCV's Hershey units) on a 640-wide
#: picture; both grow with the picture's width so they read the same at any resolution.
OUTLINE_PX = 2
LABEL_SCALE = 0.5
#: The width the sizes above are for (px).
REFERENCE_WIDTH_PX = 640
#: The outline of a mark given no colour (BGR).
UNNAMED_BGR = (160, 160, 160)
#: The height of one row of margin words above the tallest bar (fraction of its height).
MARGIN_ROW = 0.22
#: Histogram bins: one per hue unit.
HUE_BINS = HUE_MAX


def colour_bgr(colour: ColourRange | None) -> tuple[int, int, int]:
    """The fully saturated colour at the centre of ``colour``'s hue range (BGR, 0..255)."""
    if colour is None:
        return UNNAMED_BGR
    r, g, b = colorsys.hsv_to_rgb(colour.centre_hue / HUE_MAX, 1.0, 1.0)
    return (round(b * 255), round(g * 255), round(r * 255))


def outline_marks(image: Image, marks: Sequence[RoundMark], names: Sequence[str],
                  palette: Palette) -> Image:
    """A copy of ``image`` with each mark's ellipse outlined in its colour and labelled."""
    by_name = {c.name: c for c in palette}
    out = image.copy()
    scale = max(1.0, image.shape[1] / REFERENCE_WIDTH_PX)
    thick = max(1, round(OUTLINE_PX * scale))
    for mark, name in zip(marks, names, strict=True):
        bgr = colour_bgr(by_name.get(name))
        centre = (round(mark.x), round(mark.y))
        axes = (max(1, round(mark.axes[0])), max(1, round(mark.axes[1])))
        # a dark edge under the colour: the outline stands out on a mark of its own colour
        cv2.ellipse(out, centre, axes, mark.angle, 0, 360, (0, 0, 0), thick + 2, cv2.LINE_AA)
        cv2.ellipse(out, centre, axes, mark.angle, 0, 360, bgr, thick, cv2.LINE_AA)
        label = name or "no colour"
        org = (round(mark.x - mark.radius), max(12, round(mark.y - mark.radius - 4 * scale)))
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, LABEL_SCALE * scale,
                    (0, 0, 0), thick + 2, cv2.LINE_AA)
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, LABEL_SCALE * scale, bgr,
                    thick, cv2.LINE_AA)
    return out


def _spans(colour: ColourRange) -> list[tuple[float, float]]:
    """The range as one or two [start, end) spans on 0..180 (a wrapping range is two)."""
    if colour.wraps:
        return [(colour.hue_lo - 0.5, HUE_MAX), (0.0, colour.hue_hi + 0.5)]
    return [(colour.hue_lo - 0.5, colour.hue_hi + 0.5)]


def hue_histogram(marks: Sequence[RoundMark], names: Sequence[str], palette: Palette,
                  path: str | Path, *, title: str,
                  margins: Sequence[tuple[str, str, float, float]] = ()) -> None:
    """Write the hue histogram of each colour's mark pixels, with its range shaded and the
    ``margins`` (below, above, margin below, margin above: hue units) written over the
    boundary between two colours."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--annotate needs matplotlib: pip install 'marknav[plot]'",
                         field="--annotate") from None
    from marknav.core.figures import save_figure

    fig, ax = plt.subplots(figsize=(9.0, 3.8), dpi=100)
    edges = np.arange(HUE_BINS + 1) - 0.5
    top = 1.0
    for colour in palette:
        rgb = tuple(v / 255.0 for v in reversed(colour_bgr(colour)))
        hues = [np.mod(m.hue + m.hue_offsets, HUE_MAX) for m, n in zip(marks, names,
                                                                       strict=True)
                if n == colour.name]
        for k, (a, b) in enumerate(_spans(colour)):
            ax.axvspan(a, b, color=rgb, alpha=0.15, lw=0,
                       label=f"{colour.name}: range {colour.hue_lo}..{colour.hue_hi}"
                       if k == 0 else None)
        if hues:
            counts, _ = np.histogram(np.concatenate(hues), bins=edges)
            share = counts / max(1, counts.sum())
            top = max(top, float(share.max()) * 100.0)
            marks_of = count(sum(n == colour.name for n in names), "mark")
            ax.stairs(share * 100.0, edges, color=rgb, lw=1.5,
                      label=f"{colour.name}: pixels of {marks_of}")
    by_name = {c.name: c for c in palette}
    boundaries = sorted((by_name[b].hue_hi + 0.5, b, a, mb, ma) for b, a, mb, ma in margins
                        if b in by_name)
    for k, (edge, below, above, m_below, m_above) in enumerate(boundaries):
        ax.axvline(edge, color="0.3", lw=0.8, ls="--")
        # neighbouring boundaries' words on alternate rows, so close ones do not overlap
        ax.annotate(f"{below} | {above}\nmargins {m_below:.1f} / {m_above:.1f}",
                    (edge, top * (1.02 + MARGIN_ROW * (k % 2))), ha="center", va="bottom",
                    fontsize=7)
    ax.set_xlim(-0.5, HUE_MAX - 0.5)
    ax.set_ylim(0.0, top * (1.05 + MARGIN_ROW * 2))
    ax.set_xlabel("hue [OpenCV units, 0..179]")
    ax.set_ylabel("pixels of the colour's marks [%]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3,
              frameon=False)
    save_figure(fig, path)


def margins_of(gaps: Sequence[Any]) -> list[tuple[str, str, float, float]]:
    """The proposal's gaps that meet at a boundary, as :func:`hue_histogram` takes them."""
    return [(g.below, g.above, g.margin_below, g.margin_above) for g in gaps
            if g.boundary is not None]
