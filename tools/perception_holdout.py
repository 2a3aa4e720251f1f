"""Held-out recall, false marks, range error and the detector's ablation table (JSON).

From the repository root::

    python tools/perception_holdout.py [--quick] [--no-ablation]

See :mod:`marknav.runs.metrics.holdout` for the split, the corpora and the scoring.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from marknav.runs.metrics.holdout import holdout_report

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small corpora (a smoke test)")
    parser.add_argument("--no-ablation", action="store_true", help="the detector only")
    args = parser.parse_args()
    sizes = ({"composites_per_condition": 1, "synthetic": 6, "simulator": 6} if args.quick
             else {})
    report = holdout_report(ROOT / "tests" / "data", ablate=not args.no_ablation, **sizes)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
