"""Writing a matplotlib figure: the one way every ``--plot`` option saves its picture."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from marknav.core.errors import InputError


def save_figure(fig: Any, out: str | Path) -> None:
    """Lay ``fig`` out, write it to ``out`` and close it; an unwritable path is an
    :class:`InputError` naming the file (exit 2), never a traceback."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    try:
        fig.savefig(str(out), bbox_inches="tight")  # legends placed outside the axes
    except OSError as exc:
        raise InputError(f"cannot write the plot: {exc}", file=str(out)) from None
    finally:
        plt.close(fig)
