"""The marks' overlap check (issue 41, R11): the same verdict and the same first pair as comparing
every pair, with a number of comparisons that grows linearly, not quadratically."""

from __future__ import annotations

import itertools
import math
import types
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marknav.core.errors import InputError
from marknav.sim import overlap
from marknav.sim.overlap import first_overlap
from marknav.sim.world import load_world


def all_pairs(centres: list[tuple[float, float]], radii: list[float]) -> tuple[int, int] | None:
    for j in range(len(centres)):
        for i in range(j):
            if math.dist(centres[i], centres[j]) < radii[i] + radii[j]:
                return j, i
    return None


coords = st.floats(-5000, 5000, allow_nan=False)
discs = st.lists(st.tuples(coords, coords, st.floats(1, 800)), max_size=40)


@settings(max_examples=300, deadline=None)
@given(discs=discs)
def test_the_same_first_pair_as_every_pair(discs: list[tuple[float, float, float]]) -> None:
    centres = [(x, y) for x, y, _ in discs]
    radii = [r for _, _, r in discs]
    assert first_overlap(centres, radii) == all_pairs(centres, radii)


def test_touching_is_not_overlapping() -> None:
    assert first_overlap([(0.0, 0.0), (200.0, 0.0)], [100.0, 100.0]) is None
    assert first_overlap([(0.0, 0.0), (199.9, 0.0)], [100.0, 100.0]) == (1, 0)


@pytest.mark.parametrize("n", [1_000, 6_000])
def test_comparisons_grow_linearly(monkeypatch: pytest.MonkeyPatch, n: int) -> None:
    calls = 0

    def dist(p: tuple[float, float], q: tuple[float, float]) -> float:
        nonlocal calls
        calls += 1
        return math.dist(p, q)

    monkeypatch.setattr(overlap, "math", types.SimpleNamespace(floor=math.floor, dist=dist))
    side = math.isqrt(n) + 1
    centres = [(300.0 * k, 300.0 * m) for k, m in itertools.islice(
        itertools.product(range(side), repeat=2), n)]
    assert first_overlap(centres, [100.0] * n) is None
    assert calls <= 8 * n  # at most the neighbours of each; every pair would be n²/2


def test_a_world_of_6000_marks_is_checked_and_its_overlap_found(tmp_path: Path) -> None:
    lines = ["marks:"] + [f"- {{colour: red, x_mm: {300 * (k % 80)}, y_mm: {300 * (k // 80)}}}"
                          for k in range(6000)]
    lines.append("- {colour: green, x_mm: 3010, y_mm: 3000}")
    path = tmp_path / "w.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")  # 240 kB: under the size cap
    with pytest.raises(InputError, match=r"marks\[6000\] \(green at 3010, 3000\) overlaps "
                                         r"marks\[810\] \(red at 3000, 3000\)"):
        load_world(path)
