"""``marknav evaluate``: success rate and safety figures of a mission over many simulated worlds,
or (``--accuracy``) the paper's Fig. 13 position-accuracy experiment (§5, eq. 40)."""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from typing import TextIO

from marknav.core.errors import InputError, MissionFailed

BAR_WIDTH = 20


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "evaluate",
        help="run a mission on many generated worlds and report its success rate",
        description=(
            "Run MISSION --runs N times in the simulator, each on a world generated from the "
            "route with seed S, S+1, ... and randomised light, colour cast, noise, blur, wheel "
            "mismatch, mark yaw and camera latency. Prints the success rate with its 95 % "
            "confidence interval, collisions, marks passed on the wrong side, the closest "
            "approach to a mark, time per run, and each failing seed with the command that "
            "replays it. Exits 1 when the success rate is under --min-success. With --accuracy, "
            "measures the position estimate's error against ground truth over a grid of mark "
            "positions instead (the paper's Fig. 13)."
        ),
    )
    p.add_argument("mission", metavar="MISSION", nargs="?",
                   help="mission YAML file (optional with --accuracy)")
    p.add_argument("--missions", choices=("random",), metavar="random",
                   help="instead of MISSION: draw a mission and its world per run from the seed "
                        "(routes of 3-12 marks, 2-5 colours, mixed sides, clearances, bypass "
                        "distances, speeds and range models varied; off-course marks)")
    p.add_argument("--runs", type=int, metavar="N", help="number of simulated runs")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default 0)")
    p.add_argument("--jobs", type=int, default=1, metavar="J",
                   help="runs in parallel processes (default 1); results do not depend on it")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run on this Dask scheduler's workers instead (pip install "
                        "'marknav[cluster]'; workers need marknav and the mission file at the "
                        "same path); results do not depend on it")
    p.add_argument("--max-time", type=float, metavar="SECONDS",
                   help="mission time limit per run (default 60 s + 40 s per waypoint)")
    p.add_argument("--min-success", type=float, default=0.95, metavar="RATE",
                   help="exit 1 when the success rate is under this (0..1, default 0.95)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--accuracy", action="store_true",
                   help="measure position accuracy against ground truth (paper Fig. 13)")
    p.add_argument("--frames", type=int, default=100, metavar="N",
                   help="--accuracy: frames per grid point (default 100)")
    p.add_argument("--grid", default="paper", choices=("paper", "coarse"),
                   help="--accuracy: 'paper' x -600..600 by 200, y 500..3000 by 250 mm "
                        "(default), or 'coarse' 3 x 4 points")
    p.add_argument("--plot", metavar="FILE.png", help="--accuracy: draw error against distance")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                   help="change a mission setting for every run, e.g. --set "
                        "navigation.clearance_mm=350 (dotted key, YAML value; repeatable)")
    p.set_defaults(func=run)


class ProgressBar:
    """Progress of an evaluation, from its start: ``[#####-----] 12/20 done, 11 successes,
    1:02 elapsed, ETA 0:43``, on a terminal only: shown when the runs start, redrawn as each
    finishes and every second in between (so the elapsed time moves before the first run
    finishes)."""

    def __init__(self, out: TextIO, *, refresh_s: float = 1.0) -> None:
        self.out = out
        self.tty = out.isatty()
        self.refresh_s = refresh_s
        self.total = 0
        self.done = 0
        self.successes = 0
        self.t0 = time.monotonic()
        self.shown = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None

    def start(self, total: int) -> None:
        """The evaluation of ``total`` runs starts now."""
        self.total, self.t0 = total, time.monotonic()
        if not self.tty:
            return
        self._draw()
        if self.refresh_s > 0:
            self._ticker = threading.Thread(target=self._tick, name="marknav-progress",
                                            daemon=True)
            self._ticker.start()

    def line(self) -> str:
        elapsed = time.monotonic() - self.t0
        total = max(self.total, 1)
        filled = BAR_WIDTH * self.done // total
        eta = _clock(elapsed / self.done * (self.total - self.done)) if self.done else "—"
        return (f"[{'#' * filled}{'-' * (BAR_WIDTH - filled)}] {self.done}/{self.total} done, "
                f"{self.successes} success{'es' if self.successes != 1 else ''}, "
                f"{_clock(elapsed)} elapsed, ETA {eta}")

    def _draw(self) -> None:
        with self._lock:
            self.out.write(f"\r{self.line()}\x1b[K")
            self.out.flush()
            self.shown = True

    def _tick(self) -> None:
        while not self._stop.wait(self.refresh_s):
            self._draw()

    def __call__(self, done: int, total: int, successes: int) -> None:
        if done == 0:  # the runs start (the input was good)
            self.start(total)
            return
        self.done, self.total, self.successes = done, total, successes
        if self.tty:
            self._draw()

    def finish(self) -> None:
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
            self._ticker = None
        if self.shown:
            self.out.write("\n")
            self.out.flush()
            self.shown = False


def _clock(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``)."""
    s = max(0, round(seconds))
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


def run(args: argparse.Namespace) -> int:
    if args.accuracy:
        return _accuracy(args)
    for option, given in (("--frames", args.frames != 100), ("--plot", args.plot is not None),
                          ("--grid", args.grid != "paper")):
        if given:
            raise InputError("only applies with --accuracy", field=option)
    if args.missions is not None:
        if args.mission is not None:
            raise InputError("give either a MISSION or --missions random, not both",
                             field="--missions")
        args.mission = args.missions
    if args.mission is None:
        raise InputError("give a MISSION to evaluate (or --missions random, or --accuracy)")
    if args.runs is None:
        raise InputError("give the number of runs: --runs N", field="--runs")
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.evaluate import evaluate, format_evaluation

    parse_overrides(args.overrides)  # a malformed --set: exit 2 before anything runs
    if args.dask is not None and args.jobs != 1:
        raise InputError("--jobs is for local processes; with --dask the cluster's workers "
                         "run the evaluation", field="--jobs")
    bar = ProgressBar(sys.stderr)
    try:
        ev = evaluate(args.mission, runs=args.runs, seed=args.seed, jobs=args.jobs,
                      max_time_s=args.max_time, min_success=args.min_success, progress=bar,
                      overrides=args.overrides, dask=args.dask)
    finally:
        bar.finish()
    if args.json:
        print(json.dumps(ev.to_dict(), indent=2))
    else:
        print(format_evaluation(ev))
    if not ev.passed:
        raise MissionFailed(f"success rate {ev.success_rate:.1%} ({ev.successes}/{ev.runs}) is "
                            f"under --min-success {ev.min_success:.1%}")
    return 0


def _accuracy(args: argparse.Namespace) -> int:
    if args.runs is not None:
        raise InputError("does not apply with --accuracy", field="--runs")
    if args.overrides:
        raise InputError("does not apply with --accuracy", field="--set")
    from marknav.runs.evaluate import format_accuracy, plot_accuracy, position_accuracy

    result = position_accuracy(args.mission, frames=args.frames, grid=args.grid,
                               seed=args.seed)
    if args.plot:
        plot_accuracy(result, args.plot)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(format_accuracy(result))
        if args.plot:
            print(f"plot: {args.plot}")
    return 0
