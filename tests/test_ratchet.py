"""The complexity ratchet (``tools/ratchet.py``): the tree is at or under its baseline, and a
planted rise — a new branchy function, a new bare number in a comparison — fails it."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _ratchet():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("ratchet", ROOT / "tools" / "ratchet.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules["ratchet"] = module
    spec.loader.exec_module(module)
    return module


def test_no_count_rose_above_the_baseline() -> None:
    ratchet = _ratchet()
    baseline = json.loads((ROOT / ".ci" / "ratchet.json").read_text(encoding="utf-8"))
    assert ratchet.rises(ratchet.counts(), baseline) == []


def test_a_planted_rise_is_named(tmp_path: Path) -> None:
    ratchet = _ratchet()
    pkg = tmp_path / "marknav"
    pkg.mkdir()
    shutil.copy(ROOT / "marknav" / "planning" / "kinematics.py", pkg / "kinematics.py")
    before = ratchet.counts(("marknav",), root=tmp_path)
    branches = "\n".join(f"    if x == {i}:\n        return {i}" for i in range(20))
    with (pkg / "kinematics.py").open("a", encoding="utf-8") as fh:
        fh.write(f"\n\ndef planted(x: int) -> int:\n{branches}\n    return -1\n")
    after = ratchet.counts(("marknav",), root=tmp_path)
    risen = ratchet.rises(after, before)
    name = "marknav/kinematics.py"
    assert risen == [f"{name}: C901 1 > {before['C901'].get(name, 0)}",
                     f"{name}: PLR2004 {after['PLR2004'][name]} > {before['PLR2004'].get(name, 0)}"]
    assert ratchet.rises(before, after) == []  # a fall is never a failure


def test_a_new_file_starts_at_zero() -> None:
    ratchet = _ratchet()
    assert ratchet.rises({"C901": {"marknav/new.py": 1}, "PLR2004": {}}, {}) == [
        "marknav/new.py: C901 1 > 0"]
