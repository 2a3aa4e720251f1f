"""``marknav bench``: the benchmark registry and the command that runs them.

Each benchmark is a function returning a JSON-ready dict (its section). ``marknav bench all``
runs every one and prints ONE JSON object: ``machine`` (CPU, cores, Python, numpy and OpenCV
versions) once at the top level, then a section per benchmark:

- ``vision`` — the detector against plain ``HoughCircles`` on fixed synthetic frames
  (:func:`marknav.runs.benchmarks.vision.run_vision_bench`), and on the real photographs and
  composited
  frames of the source tree's ``tests/data``
  (:func:`marknav.runs.benchmarks.photos.run_real_bench`),
  and its worst case, crowded frames (:func:`marknav.runs.benchmarks.crowded.run_crowded_bench`);
  and ``cost``: in one run on the same frames (synthetic, real 640-px photographs, simulator
  frames) the detector, the least OpenCV detector, plain ``HoughCircles`` and one BGR→HSV, p50
  and p95 (:func:`marknav.runs.benchmarks.cost.run_cost_bench`);
- ``tree`` — µs per behaviour-tree tick, slalom and a 50-waypoint route, mocked perception
  (:func:`marknav.runs.benchmarks.suite.bench_tree`);
- ``loop`` — a simulated mission with rendering and detection: cycle times, overruns, speed-up
  (:func:`marknav.runs.benchmarks.suite.bench_loop`);
- ``recording`` (not part of ``all``: the ``record`` and ``foxglove`` extras) — the slalom's
  MCAP recording: its size, and the loop's wall time, CPU time
  and cycle time with ``--record`` and with ``--foxglove`` (a client subscribed) over without,
  as ratios (:func:`marknav.runs.benchmarks.recording.bench_recording`);
- ``safety`` — bump-to-stop latency, safety layer alone and through the real driver
  (:func:`marknav.runs.benchmarks.suite.bench_safety`);
- ``render`` — ms per simulator frame against the 2 ms target
  (:func:`marknav.runs.benchmarks.render.bench_render`);
- ``mujoco`` (not part of ``all``: the ``mujoco`` extra) — MuJoCo's camera in frames per second
  at 320×240 and 640×480 with and without shadows, against the built-in renderer
  (:func:`marknav.runs.benchmarks.engines.bench_mujoco`);
- ``groot2`` (not part of ``all``: a minute, and the ``groot2`` extra) — what Groot2 watching a
  run costs the loop (:func:`marknav.runs.benchmarks.groot2.bench_groot2`);
- ``dask`` (not part of ``all``: minutes, and the ``cluster`` extra) — an evaluation's
  throughput on a local Dask cluster of one worker, then two, cluster start excluded
  (:func:`marknav.runs.benchmarks.cluster.bench_dask`).

``--quick`` runs each with small sizes (a smoke test: the figures are noisier). ``--profile``
runs them under :mod:`cProfile` and prints the top costs (own time and cumulative time per
function) to stderr; the profiler slows everything down, so the figures printed with it are not
the benchmark's.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from marknav.core.errors import InputError

__all__ = ["BENCHMARKS", "Benchmark", "machine_info", "profile_top", "run_benchmarks"]


@dataclass(frozen=True)
class Benchmark:
    name: str
    help: str
    #: ``run(quick)`` -> the section's dict.
    run: Callable[[bool], dict[str, Any]]
    #: Run by ``marknav bench all``.
    in_all: bool = True


def _vision(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.cost import run_cost_bench
    from marknav.runs.benchmarks.crowded import run_crowded_bench
    from marknav.runs.benchmarks.photos import run_real_bench
    from marknav.runs.benchmarks.vision import run_vision_bench
    from marknav.runs.metrics.photo_corpus import default_corpus

    result = run_vision_bench(frames=10, repeats=1) if quick else run_vision_bench()
    det, hsv = result["detector_ms_p50"], result["hsv_ms_p50"]
    assert isinstance(det, float) and isinstance(hsv, float)
    result["detector_over_hsv_p50"] = round(det / max(hsv, 1e-9), 2)
    result["crowded"] = run_crowded_bench(1 if quick else 3)
    result["cost"] = (run_cost_bench(synthetic=4, sim=4, repeats=1) if quick
                      else run_cost_bench())
    corpus = default_corpus()
    if corpus is None:
        result["real"] = "no corpus: run from a source checkout (tests/data/labels.json)"
        return result
    real = (run_real_bench(corpus, per_condition=1, repeats=1, hough=False, sizes=(640,))
            if quick else run_real_bench(corpus))
    result.update(real)
    return result


def _tree(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.suite import bench_tree

    return bench_tree(ticks=200, slalom_ticks=200) if quick else bench_tree()


def _loop(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.suite import bench_loop

    return bench_loop(max_time_s=5.0) if quick else bench_loop(max_time_s=60.0)


def _recording(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.recording import bench_recording

    return (bench_recording(max_time_s=5.0, repeats=1) if quick
            else bench_recording(max_time_s=60.0, repeats=5))


def _render(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.render import bench_render

    return bench_render(frames=20, batches=1) if quick else bench_render()


def _mujoco(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.engines import bench_mujoco
    from marknav.sim.mujoco.gl import import_mujoco

    import_mujoco()  # no extra or no headless OpenGL: exit 2 naming it
    return bench_mujoco(frames=5, batches=1) if quick else bench_mujoco()


def _safety(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.suite import bench_safety

    return bench_safety(n=200, e2e_n=50) if quick else bench_safety()


def _groot2(quick: bool) -> dict[str, Any]:
    from marknav.cli.groot2_option import groot2_address

    groot2_address("1667")  # no extra: exit 2 naming it
    from marknav.runs.benchmarks.groot2 import bench_groot2

    return bench_groot2(max_time_s=10.0, repeats=1) if quick else bench_groot2()


def _dask(quick: bool) -> dict[str, Any]:
    from marknav.runs.benchmarks.cluster import bench_dask

    return bench_dask(runs=2, max_time_s=10.0) if quick else bench_dask()


#: The registry, in the order ``all`` runs them.
BENCHMARKS: dict[str, Benchmark] = {b.name: b for b in (
    Benchmark("vision", "detector vs HoughCircles, 640×480 synthetic frames, one core", _vision),
    Benchmark("tree", "µs per behaviour-tree tick (slalom, 50 waypoints), mocked perception",
              _tree),
    Benchmark("loop", "60 s simulated slalom at 20 Hz with rendering and detection", _loop),
    Benchmark("safety", "bump-to-stop latency: safety layer, and end to end via the driver",
              _safety),
    Benchmark("render", "ms per 640×480 simulator frame, noise and blur (target 2 ms)",
              _render),
    Benchmark("mujoco", "MuJoCo camera fps at 320×240 and 640×480, shadows on and off, against "
              "the built-in renderer (extra: mujoco; not in all)", _mujoco, in_all=False),
    Benchmark("groot2", "what a Groot2 client polling at 100 Hz costs the run loop: loop and "
              "server CPU, ticks while polled and not (extra: groot2; not in all)", _groot2,
              in_all=False),
    Benchmark("dask", "evaluation throughput on a local Dask cluster, 1 then 2 workers, "
              "cluster start excluded (8 slalom runs each; not in all)", _dask, in_all=False),
    Benchmark("recording", "the slalom's MCAP size; loop speed with --record and with "
              "--foxglove over without (extras: record, foxglove; not in all)", _recording,
              in_all=False),
)}


def machine_info() -> dict[str, Any]:
    """CPU model (from /proc/cpuinfo), cores, Python, numpy and OpenCV versions."""
    import cv2
    import numpy as np

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "opencv": cv2.__version__}


def run_benchmarks(names: list[str], *, quick: bool = False,
                   on_start: Callable[[int, str], None] | None = None) -> dict[str, Any]:
    """``{"machine": ..., name: section, ...}`` for the named benchmarks, in registry order.
    A section's own ``machine`` entry (the vision bench has one) moves to the top level.
    ``on_start(done, name)`` is called before each benchmark."""
    out: dict[str, Any] = {"machine": machine_info()}
    for name in BENCHMARKS:
        if name not in names:
            continue
        if on_start is not None:
            on_start(len(out) - 1, name)
        section = dict(BENCHMARKS[name].run(quick))
        extra = section.pop("machine", None)
        if isinstance(extra, dict):
            for key, value in extra.items():
                out["machine"].setdefault(key, value)
        out[name] = section
    return out


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "bench",
        help="measure vision, tree, control-loop and safety timings on this machine",
        description="Run the benchmarks and print their figures (" + "; ".join(
            f"{b.name}: {b.help}" for b in BENCHMARKS.values()) + "; all: every one but dask).",
    )
    p.add_argument("which", nargs="?", default="all", choices=[*BENCHMARKS, "all"],
                   metavar="WHICH",
                   help=f"which benchmark: {', '.join(BENCHMARKS)} or all (default all)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quick", action="store_true",
                   help="small sizes: a smoke test, noisier figures")
    p.add_argument("--profile", type=int, nargs="?", const=25, default=None, metavar="N",
                   help="run under cProfile and print the N top costs to stderr (default 25; "
                        "the profiler slows the benchmark down)")
    p.set_defaults(func=run)


def _text(results: dict[str, Any]) -> str:
    lines = []
    for section, values in results.items():
        lines.append(f"{section}:")
        for key, value in values.items():
            lines.append(f"  {key}: {value}")
    return "\n".join(lines)


def profile_top(stats: pstats.Stats, n: int) -> str:
    """The ``n`` functions with the most own time and the ``n`` with the most cumulative time,
    as a table (ms, share of the total, calls, ``file:line(function)``)."""
    raw: dict[Any, Any] = stats.stats  # type: ignore[attr-defined]
    total = sum(tt for _cc, _nc, tt, _ct, _callers in raw.values()) or 1.0

    def where(key: tuple[str, int, str]) -> str:
        file, line, func = key
        parts = Path(file).parts
        short = "/".join(parts[parts.index("marknav"):]) if "marknav" in parts else (
            "/".join(parts[-2:]) if len(parts) > 1 else file)
        return f"{short}:{line}({func})" if line else func

    lines = [f"profile: {total * 1e3:.0f} ms of function time"]
    for title, col in (("own time", 2), ("cumulative time", 3)):
        lines.append(f"top {n} by {title}:")
        lines.append(f"  {'ms':>9} {'share':>6} {'calls':>8}  function")
        rows = sorted(raw.items(), key=lambda kv: kv[1][col], reverse=True)[:n]
        for key, value in rows:
            ms = value[col] * 1e3
            lines.append(f"  {ms:9.1f} {100 * value[col] / total:5.1f}% {value[1]:8d}  "
                         f"{where(key)}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from marknav.runs.views.progress import Progress

    names = ([n for n, b in BENCHMARKS.items() if b.in_all] if args.which == "all"
             else [args.which])
    # one redraw a second on a terminal: the bar's thread must not weigh on the timings
    progress = Progress("bench", sys.stderr, unit="benchmarks done", redraws_per_s=1.0)

    def on_start(done: int, name: str) -> None:
        if not progress.started:
            progress.start(len(names))
        progress.update(done, note=f"running {name}")

    if args.profile is not None:
        if args.profile < 1:
            raise InputError(f"must be at least 1, got {args.profile}", field="--profile")
        profiler = cProfile.Profile()
        profiler.enable()
        try:
            results = run_benchmarks(names, quick=args.quick, on_start=on_start)
        finally:
            profiler.disable()
            progress.finish()
        print(profile_top(pstats.Stats(profiler), args.profile), file=sys.stderr)
    else:
        try:
            results = run_benchmarks(names, quick=args.quick, on_start=on_start)
            progress.update(len(names), note="")
        finally:
            progress.finish()
    print(json.dumps(results, indent=2) if args.json else _text(results))
    return 0
