"""Numbers in messages as a person writes them: ``1 mark`` / ``2 marks``, and no ``-0``.

A value that rounds to zero is printed ``0`` (``+0.0`` with a sign asked for is ``0.0``):
``-0 mm`` says a direction the value does not have.
"""

from __future__ import annotations

__all__ = ["count", "signed"]


def count(n: int, noun: str, plural: str | None = None) -> str:
    """``1 mark``, ``0 marks``, ``3 marks`` (``plural`` when it is not ``noun + "s"``)."""
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"


def signed(value: float, decimals: int = 0) -> str:
    """``value`` with its sign (``+12``, ``-3.5``), but ``0`` / ``0.0`` for one that rounds
    to zero at ``decimals`` places."""
    text = f"{value:+.{decimals}f}"
    if float(text) == 0.0:
        return f"{0.0:.{decimals}f}"
    return text
