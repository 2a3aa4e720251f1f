"""Counts and signed numbers in messages: ``1 mark``, and never ``-0``."""

from __future__ import annotations

import pytest

from marknav.core.wording import count, signed


def test_count_agrees_with_its_number() -> None:
    assert count(1, "mark") == "1 mark"
    assert [count(n, "mark") for n in (0, 2, 20)] == ["0 marks", "2 marks", "20 marks"]
    assert count(2, "box", "boxes") == "2 boxes"


@pytest.mark.parametrize(("value", "decimals", "text"), [
    (-0.3, 0, "0"), (0.4, 0, "0"), (-0.04, 1, "0.0"), (0.0, 1, "0.0"), (-0.0, 0, "0"),
    (12.0, 0, "+12"), (-3.46, 1, "-3.5"), (-0.6, 0, "-1"), (0.05, 1, "+0.1"),
])
def test_signed_keeps_the_sign_except_on_zero(value: float, decimals: int, text: str) -> None:
    assert signed(value, decimals) == text
