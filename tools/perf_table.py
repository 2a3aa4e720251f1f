"""Write the documentation's performance page from ``marknav bench all --json``.

    python -m marknav bench all --json > bench.json
    python tools/perf_table.py bench.json --out docs/reference/performance.md \
        --note "quiet machine"

The page states the machine (from the benchmark's ``machine`` block), the date (``--date``,
default: now, UTC) and any ``--note`` (e.g. the load average while it ran), then one table of
the figures. Every figure comes from the JSON; a benchmark missing from it is left out.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

Row = tuple[str, str, str]


def _get(data: dict[str, Any], path: str) -> Any:
    node: Any = data
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def _num(value: Any, digits: int = 2) -> str:
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    return f"{value:,.{digits}f}"


def _rows(d: dict[str, Any]) -> list[Row]:
    g: Callable[[str], Any] = lambda path: _get(d, path)  # noqa: E731
    rows: list[Row] = []
    if g("loop") is not None:
        rows.append((
            "closed loop (slalom): render 640×480, detect, estimate, tick, driver over the "
            "byte-level simulated Create",
            f"{_num(g('loop.speedup'), 1)}× real time ({_num(g('loop.speedup_cpu'), 1)}× per CPU "
            f"second); cycle p50 {_num(g('loop.cycle_ms_p50'))} ms, p99 "
            f"{_num(g('loop.cycle_ms_p99'))} ms; {_num(g('loop.overruns'))} overrun(s) in "
            f"{_num(g('loop.cycles'))} cycles",
            "`bench loop`",
        ))
        parts = g("loop.breakdown_ms_per_cycle") or {}
        if parts:
            text = ", ".join(f"{k} {_num(v)}" for k, v in parts.items() if k != "total")
            rows.append(("… per cycle, ms", f"{text} (total {_num(parts.get('total'))})",
                         "`bench loop`"))
    if g("tree") is not None:
        rows.append((
            f"tree tick, {g('tree.waypoints')}-waypoint route, mocked perception",
            f"p50 {_num(g('tree.tick_us_p50'), 1)} µs, p99 {_num(g('tree.tick_us_p99'), 0)} µs "
            f"(CPU p50 {_num(g('tree.tick_cpu_us_p50'), 1)} µs, p99 "
            f"{_num(g('tree.tick_cpu_us_p99'), 0)} µs)",
            "`bench tree`",
        ))
        rows.append(("tree tick, slalom route",
                     f"p50 {_num(g('tree.slalom_tick_us_p50'), 1)} µs, p99 "
                     f"{_num(g('tree.slalom_tick_us_p99'), 0)} µs", "`bench tree`"))
    if g("safety") is not None:
        rows.append(("bump to zero wheel command, safety layer alone",
                     f"p50 {_num(g('safety.bump_to_stop_ms_p50'), 3)} ms, p99 "
                     f"{_num(g('safety.bump_to_stop_ms_p99'), 3)} ms ({_num(g('safety.n'))} bumps)",
                     "`bench safety`"))
        rows.append(("bump frame's bytes into the driver to Drive Direct 0/0 written",
                     f"p50 {_num(g('safety.bump_to_stop_e2e_ms_p50'), 3)} ms, p99 "
                     f"{_num(g('safety.bump_to_stop_e2e_ms_p99'), 3)} ms, max "
                     f"{_num(g('safety.max_ms'), 3)} ms ({_num(g('safety.e2e_n'))} bumps; one "
                     f"stream period is {_num(g('safety.stream_period_ms'), 0)} ms)",
                     "`bench safety`"))
    if g("render") is not None:
        rows.append((f"simulator frame, {g('render.width')}×{g('render.height')}",
                     f"p50 {_num(g('render.frame_ms_p50'))} ms", "`bench render`"))
    if g("vision") is not None:
        rows.append((
            f"detector, {g('vision.frames')} synthetic {g('vision.width')}×{g('vision.height')} "
            "frames (clutter, light, casts, blur, occlusion)",
            f"p50 {_num(g('vision.detector_ms_p50'))} ms, p99 {_num(g('vision.detector_ms_p99'))} "
            f"ms; recall {_num(g('vision.recall'))}, {_num(g('vision.false_positives'))} false "
            f"marks",
            "`bench vision`",
        ))
        rows.append(("… the same frames: `cv2.HoughCircles` alone / BGR→HSV alone",
                     f"p50 {_num(g('vision.hough_ms_p50'))} ms / {_num(g('vision.hsv_ms_p50'))} ms",
                     "`bench vision`"))
        if g("vision.real") is not None:
            rows.append((
                "labelled real marks found (photo corpus)",
                f"{_num(g('vision.real.recall.found'))} of "
                f"{_num(g('vision.real.recall.labelled'))}",
                "`bench vision`",
            ))
            rows.append((
                "false marks per natural photograph, 640 / 1280 px",
                f"{_num(g('vision.real.false_640.per_photo'), 3)} / "
                f"{_num(g('vision.real.false_1280.per_photo'), 3)} "
                f"({_num(g('vision.real.false_640.photos'))} photos); with the horizon prior "
                f"{_num(g('vision.real.false_640_horizon.per_photo'), 3)} / "
                f"{_num(g('vision.real.false_1280_horizon.per_photo'), 3)}",
                "`bench vision`",
            ))
            rows.append((
                "detector on real 640-px photographs",
                f"p50 {_num(g('vision.real.timing_640.detector_ms_p50'))} ms, p95 "
                f"{_num(g('vision.real.timing_640.detector_ms_p95'))} ms; the robot's detector "
                f"(camera minimum radius, horizon prior) p95 "
                f"{_num(g('vision.real.timing_640_camera_horizon.detector_ms_p95'))} ms",
                "`bench vision`",
            ))
        if g("vision.composite") is not None:
            rows.append((
                f"marks composited into photographs ({_num(g('vision.composite.marks'))} marks, "
                f"{_num(g('vision.composite.frames'))} frames)",
                f"recall {_num(g('vision.composite.recall'), 3)}, "
                f"{_num(g('vision.composite.false_marks'))} false marks, range error p95 "
                f"{_num(100 * g('vision.composite.range_err_p95'), 1)} %",
                "`bench vision`",
            ))
        crowded = g("vision.crowded") or {}
        for name, frame in crowded.items():
            rows.append((
                f"crowded frame `{name}` (worst case)",
                f"{_num(frame['detector']['ms'], 1)} ms bare detector, "
                f"{_num(frame['robot']['ms'], 1)} ms the robot's "
                f"({_num(frame['detector']['readings'])} / {_num(frame['robot']['readings'])} "
                "blobs read)",
                "`bench vision`",
            ))
    return rows


def page(data: dict[str, Any], *, date: str, note: str | None) -> str:
    m = data.get("machine", {})
    machine = (f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores; Python {m.get('python', '?')}, "
               f"NumPy {m.get('numpy', '?')}, OpenCV {m.get('opencv', '?')} "
               f"({m.get('opencv_threads', '?')} OpenCV thread)")
    lines = [
        "# Performance",
        "",
        "One run of `marknav bench all --json` on one machine, turned into this page by "
        "`tools/perf_table.py`. Figures are wall-clock unless they say CPU; p50 and p99 are "
        "medians and 99th percentiles. They depend on the machine and on what else it runs: "
        "measure your own with `marknav bench` (`--profile` prints the top costs).",
        "",
        f"- **Machine**: {machine}",
        f"- **Date**: {date}",
    ]
    if note:
        lines.append(f"- **Conditions**: {note}")
    lines += ["", "| what | figure | measured by |", "|---|---|---|"]
    lines += [f"| {w} | {f} | {b} |" for w, f, b in _rows(data)]
    lines += [
        "",
        "The commands: `marknav bench loop`, `tree`, `safety`, `render`, `vision`, or `all`; "
        "`marknav bench dask` (not in `all`: minutes, and the `cluster` extra) measures an "
        "evaluation's throughput on local Dask clusters of 1 and 2 workers.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("bench_json", type=Path, help="output of `marknav bench all --json`")
    parser.add_argument("--out", type=Path, help="page to write (default: stdout)")
    parser.add_argument("--date", default=dt.datetime.now(dt.timezone.utc).strftime(
        "%Y-%m-%d %H:%M UTC"), help="when the benchmark ran (default: now, UTC)")
    parser.add_argument("--note", help="conditions, e.g. the load average while it ran")
    args = parser.parse_args(argv)
    data = json.loads(args.bench_json.read_text(encoding="utf-8"))
    text = page(data, date=args.date, note=args.note)
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
