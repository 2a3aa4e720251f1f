"""tools/perf_table.py: the performance page states its machine and date and every figure of the
benchmark JSON it was given, and leaves out what the JSON does not hold."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("perf_table", ROOT / "tools" / "perf_table.py")
assert _spec is not None and _spec.loader is not None
perf_table = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(perf_table)

BENCH = {
    "machine": {"cpu": "Test CPU", "cores": 2, "python": "3.11.7", "numpy": "2.4.6",
                "opencv": "5.1.0", "opencv_threads": 1},
    "loop": {"speedup": 25.47, "speedup_cpu": 30.1, "cycle_ms_p50": 1.25, "cycle_ms_p99": 5.0,
             "overruns": 0, "cycles": 819,
             "breakdown_ms_per_cycle": {"detector": 0.97, "render": 0.4, "total": 1.9}},
    "safety": {"n": 2000, "bump_to_stop_ms_p50": 0.01, "bump_to_stop_ms_p99": 0.039,
               "e2e_n": 500, "bump_to_stop_e2e_ms_p50": 0.035, "bump_to_stop_e2e_ms_p99": 0.08,
               "stream_period_ms": 15.0, "max_ms": 0.2},
}


def test_the_page_names_the_machine_date_and_figures(tmp_path: Path) -> None:
    src = tmp_path / "b.json"
    src.write_text(json.dumps(BENCH), encoding="utf-8")
    out = tmp_path / "performance.md"
    assert perf_table.main([str(src), "--out", str(out), "--date", "2026-12-03 10:00 UTC",
                            "--note", "quiet"]) == 0
    page = out.read_text(encoding="utf-8")
    assert "Test CPU, 2 cores; Python 3.11.7, NumPy 2.4.6, OpenCV 5.1.0" in page
    assert "**Date**: 2026-12-03 10:00 UTC" in page and "**Conditions**: quiet" in page
    assert "25.5× real time (30.1× per CPU second)" in page
    assert "detector 0.97, render 0.40 (total 1.90)" in page
    assert "p99 0.080 ms, max 0.200 ms (500 bumps" in page
    # no tree, render or vision block in the JSON: no row for them
    assert "tree tick" not in page and "simulator frame" not in page and "detector," not in page
