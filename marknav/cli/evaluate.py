"""``marknav evaluate``: success rate and safety figures of a mission over many simulated worlds,
or (``--accuracy``) the paper's Fig. 13 position-accuracy experiment (§5, eq. 40)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from marknav.cli.run import PREPARING
from marknav.cli.validate import set_item
from marknav.core.errors import EXIT_INTERRUPTED, InputError, MissionFailed

if TYPE_CHECKING:
    from marknav.runs.evaluation.evaluate import Evaluation, SeedResult


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
                   help="mission YAML file or a built-in example's name (optional with "
                        "--accuracy)")
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
    p.add_argument("--engine", choices=("builtin", "mujoco"),
                   help="simulator engine (default: the mission's sim.engine, else builtin); "
                        "mujoco needs the 'mujoco' extra and the system package libosmesa6")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--record-failures", metavar="DIR", type=Path,
                   help="run each failing seed again with its MCAP recording in "
                        "DIR/seed-N/run.mcap (extra: record; 'marknav view' opens it)")
    p.add_argument("--accuracy", action="store_true",
                   help="measure position accuracy against ground truth (paper Fig. 13)")
    p.add_argument("--frames", type=int, default=100, metavar="N",
                   help="--accuracy: frames per grid point (default 100)")
    p.add_argument("--grid", default="paper", choices=("paper", "coarse"),
                   help="--accuracy: 'paper' x -600..600 by 200, y 500..3000 by 250 mm "
                        "(default), or 'coarse' 3 x 4 points")
    p.add_argument("--plot", metavar="FILE.png", help="--accuracy: draw error against distance")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                   type=set_item, help="change a mission setting for every run, e.g. --set "
                        "navigation.clearance_mm=350 (dotted key, YAML value; repeatable)")
    p.set_defaults(func=run)


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
    from marknav.missions.examples import mission_path
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.evaluation.evaluate import RANDOM, EvaluationStopped, evaluate
    from marknav.runs.loop.run import prepare
    from marknav.runs.views.progress import Progress, slow_status

    if args.mission != RANDOM:
        args.mission = mission_path(args.mission)

    parse_overrides(args.overrides)  # a malformed --set: exit 2 before anything runs
    _check_record_folder(args.record_failures)
    if args.dask is not None and args.jobs != 1:
        raise InputError("--jobs is for local processes; with --dask the cluster's workers "
                         "run the evaluation", field="--jobs")
    if args.dask is None:  # the workers load the compiled loops this builds
        with slow_status(PREPARING, sys.stderr):
            prepare(simulator=True)
    name = "random missions" if args.mission == RANDOM else Path(args.mission).stem
    progress = Progress(f"evaluate {name}", sys.stderr, unit="runs done")

    def on_progress(done: int, total: int, successes: int) -> None:
        if done == 0:  # the runs start (the input was good)
            progress.start(total)
        else:
            progress.update(done, note=f"{successes} success{'es' if successes != 1 else ''}")

    try:
        ev = evaluate(args.mission, runs=args.runs, seed=args.seed, jobs=args.jobs,
                      max_time_s=args.max_time, min_success=args.min_success,
                      progress=on_progress, overrides=args.overrides, dask=args.dask,
                      engine=args.engine)
    except EvaluationStopped as stop:
        progress.finish()
        _print(stop.evaluation, as_json=args.json)
        print(f"marknav evaluate: interrupted; {stop.evaluation.runs} of "
              f"{stop.evaluation.planned_runs} runs had finished: their figures are printed, "
              "marked interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        progress.finish()
    _print(ev, as_json=args.json)
    _record(ev, args.record_failures)
    if not ev.passed:
        raise MissionFailed(f"success rate {ev.success_rate:.1%} ({ev.successes}/{ev.runs}) is "
                            f"under --min-success {ev.min_success:.1%}")
    return 0


def _check_record_folder(folder: Path | None) -> None:
    """--record-failures DIR: the MCAP writer is installed and DIR is (or can be) a folder."""
    from marknav.core.outputs import printable

    if folder is None:
        return
    try:
        import mcap_ros2  # noqa: F401
    except ImportError:
        raise InputError("needs the MCAP writer, which is not installed: pip install "
                         "'marknav[record]'", field="--record-failures") from None
    if folder.exists() and not folder.is_dir():
        raise InputError("is not a folder", file=str(folder), field="--record-failures")
    if not folder.parent.is_dir():
        raise InputError(f"the folder {printable(str(folder.parent))} does not exist",
                         file=str(folder), field="--record-failures")
    folder.mkdir(exist_ok=True)


def _record(ev: Evaluation, folder: Path | None) -> None:
    """--record-failures DIR: the failing seeds again, recorded."""
    from marknav.core.outputs import printable
    from marknav.runs.evaluation.evaluate import record_failures

    if folder is None or not ev.failures:
        return
    def said(failure: SeedResult, path: Path, again: SeedResult) -> None:
        same = "" if again.outcome == failure.outcome else (
            f" (this time {again.outcome}: {again.reason})")
        print(f"recording of seed {failure.seed}: {printable(str(path))}{same}",
              file=sys.stderr)

    record_failures(ev, folder, on_recorded=said)


def _print(ev: Evaluation, *, as_json: bool) -> None:
    from marknav.runs.evaluation.evaluate import format_evaluation

    if as_json:
        print(json.dumps(ev.to_dict(), indent=2), flush=True)
    else:
        print(format_evaluation(ev), flush=True)


def _accuracy(args: argparse.Namespace) -> int:
    if args.runs is not None:
        raise InputError("does not apply with --accuracy", field="--runs")
    if args.overrides:
        raise InputError("does not apply with --accuracy", field="--set")
    from marknav.runs.evaluation.evaluate import format_accuracy, plot_accuracy, position_accuracy

    if args.mission is not None:
        from marknav.missions.examples import mission_path

        args.mission = mission_path(args.mission)

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
