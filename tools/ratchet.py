"""The complexity ratchet: per-file counts of ruff's C901 (cyclomatic complexity over 15) and
PLR2004 (a bare number in a comparison) may fall, never rise.

``python tools/ratchet.py`` compares today's counts with ``.ci/ratchet.json`` and exits 1 naming
every file whose count rose (a new file starts at 0); ``--update`` writes today's counts as the
baseline, refusing to raise any (a rise is fixed in the code, or named as a constant with its
unit). CI runs the check; ``tests/test_ratchet.py`` runs it on the tree and on a planted rise.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections import Counter
from collections.abc import Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = ROOT / ".ci" / "ratchet.json"
RULES = ("C901", "PLR2004")
MAX_COMPLEXITY = 15  # the bound; ruff's default is 10


def counts(paths: tuple[str, ...] = ("marknav",), root: Path = ROOT) -> dict[str, dict[str, int]]:
    """``{rule: {file: count}}`` for :data:`RULES` over ``paths`` (relative to ``root``)."""
    out = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "--isolated", "--select", ",".join(RULES),
         "--config", f"lint.mccabe.max-complexity = {MAX_COMPLEXITY}",
         "--output-format", "json", "--exit-zero", *paths],
        cwd=root, capture_output=True, text=True, check=True).stdout
    found: dict[str, Counter[str]] = {rule: Counter() for rule in RULES}
    for item in json.loads(out):
        rel = Path(item["filename"]).resolve().relative_to(root.resolve()).as_posix()
        found[item["code"]][rel] += 1
    return {rule: dict(sorted(c.items())) for rule, c in found.items()}


def rises(now: Mapping[str, Mapping[str, int]],
          baseline: Mapping[str, Mapping[str, int]]) -> list[str]:
    """Every (rule, file) whose count is above its baseline (absent from it: 0)."""
    return [f"{path}: {rule} {n} > {baseline.get(rule, {}).get(path, 0)}"
            for rule in RULES for path, n in sorted(now.get(rule, {}).items())
            if n > baseline.get(rule, {}).get(path, 0)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--update", action="store_true", help="write today's counts as the baseline")
    args = ap.parse_args(argv)
    now = counts()
    if not BASELINE.exists() and args.update:  # the first baseline: today's counts
        BASELINE.write_text(json.dumps(now, indent=1) + "\n", encoding="utf-8")
    baseline = json.loads(BASELINE.read_text(encoding="utf-8")) if BASELINE.exists() else {}
    risen = rises(now, baseline)
    if risen:
        print("complexity ratchet: counts rose (fix the code, or name the number):")
        print("\n".join(f"  {line}" for line in risen))
        return 1
    if args.update:
        BASELINE.write_text(json.dumps(now, indent=1) + "\n", encoding="utf-8")
    totals = {rule: sum(now[rule].values()) for rule in RULES}
    print(f"complexity ratchet: {totals['C901']} functions over CC {MAX_COMPLEXITY}, "
          f"{totals['PLR2004']} bare numbers in comparisons; none rose")
    return 0


if __name__ == "__main__":
    sys.exit(main())
