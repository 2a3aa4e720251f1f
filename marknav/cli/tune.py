"""``marknav tune``: search mission parameters for the best success rate, then the shortest
median mission time, over the same randomised worlds (Optuna;
:mod:`marknav.runs.evaluation.tune`)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from marknav.cli.run import PREPARING
from marknav.core.errors import EXIT_INTERRUPTED, InputError

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "tune",
        help="search mission parameters (Optuna) for the best success rate, then speed",
        description=(
            "Each trial sets the --param keys of MISSION to values chosen by Optuna's TPE "
            "sampler and evaluates it on the same --runs randomised worlds (seeds S, S+1, ...; "
            "locally or with --dask on a cluster). Objective: success rate first, then the "
            "median simulated mission time. The study is stored (default "
            "runs/tune-NAME/study.sqlite3): the same command resumes it after Ctrl-C until "
            "--trials trials are complete. Prints the best parameters as a YAML block to paste "
            "into the mission and draws the trials (runs/tune-NAME/trials.png). Needs "
            "pip install 'marknav[cluster]'."
        ),
    )
    p.add_argument("mission", metavar="MISSION",
                   help="mission YAML file, or the name of a built-in example (slalom)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=LOW:HIGH[:STEP]",
                   help="a dotted mission key and its range, e.g. "
                        "navigation.clearance_mm=250:450 (repeat for more)")
    p.add_argument("--trials", type=int, required=True, metavar="N",
                   help="complete trials the study should have")
    p.add_argument("--runs", type=int, default=5, metavar="R",
                   help="simulated runs per trial (default 5)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default 0)")
    p.add_argument("--jobs", type=int, default=1, metavar="J",
                   help="runs of a trial in parallel processes (default 1)")
    p.add_argument("--dask", metavar="tcp://HOST:PORT",
                   help="run each trial's runs on this Dask scheduler's workers")
    p.add_argument("--max-time", type=float, metavar="SECONDS",
                   help="mission time limit per run (default 60 s + 40 s per waypoint)")
    p.add_argument("--storage", metavar="URL",
                   help="Optuna storage (default sqlite:///runs/tune-NAME/study.sqlite3)")
    p.add_argument("--study", metavar="NAME", help="study name (default the mission's name)")
    p.add_argument("--plot", metavar="FILE.png",
                   help="where to draw the trials (default runs/tune-NAME/trials.png)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.missions.examples import mission_path
    from marknav.runs.evaluation.tune import TrialSummary, best_yaml, parse_param, plot_trials, tune
    from marknav.runs.loop.run import prepare
    from marknav.runs.views.progress import Progress, slow_status

    params = [parse_param(text) for text in args.param]
    args.mission = mission_path(args.mission)
    if args.dask is not None and args.jobs != 1:
        raise InputError("--jobs is for local processes; with --dask the cluster's workers "
                         "run the trials", field="--jobs")
    if args.plot is not None and not args.plot.lower().endswith(".png"):
        raise InputError("the plot is a PNG file: give a name ending in .png", field="--plot")

    if args.dask is None:  # the workers load the compiled loops this builds
        with slow_status(PREPARING, sys.stderr):
            prepare(simulator=True)
    progress = Progress(f"tune {Path(args.mission).stem}", sys.stderr, unit="trials complete")
    best_so_far: list[TrialSummary] = []

    def describe(t: TrialSummary) -> str:
        values = ", ".join(f"{k.rsplit('.', 1)[-1]}={v:g}" for k, v in t.params.items())
        return (f"trial {t.number}: {values} -> success {t.successes}/{t.runs}, median "
                f"{t.median_time_s:.1f} s")

    def on_trial(t: TrialSummary, best: TrialSummary, complete: int) -> None:
        best_so_far[:] = [best]
        line = describe(t).replace(":", f" ({complete}/{args.trials} complete):", 1)
        progress.log(f"{line}{'  (best so far)' if best.number == t.number else ''}")
        progress.update(complete, note=f"best: trial {best.number}")

    try:
        result = tune(args.mission, params, trials=args.trials, runs=args.runs, seed=args.seed,
                      jobs=args.jobs, dask=args.dask, max_time_s=args.max_time,
                      storage=args.storage, study_name=args.study, on_trial=on_trial,
                      on_start=lambda done: progress.start(args.trials, done=done))
    except KeyboardInterrupt:
        progress.finish()
        # This is the whole message: returning (not re-raising) keeps the CLI's generic
        # "interrupted" line from repeating it.
        best = f"; best so far {describe(best_so_far[0])}" if best_so_far else ""
        print(f"marknav tune: interrupted; the completed trials are stored{best} — run the "
              "same command again to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        progress.finish()
    plot = Path(args.plot) if args.plot else None
    if plot is None and result.storage.startswith("sqlite:///"):
        plot = Path(result.storage.removeprefix("sqlite:///")).parent / "trials.png"
    if plot is not None:
        try:
            plot_trials(result, params, plot)
        except InputError as exc:
            if args.plot:
                raise
            log.warning("no plot of the trials: %s", exc)
            plot = None
    if result.new_trials == 0:
        print(f"the study already has {len(result.trials)} complete trials (--trials "
              f"{args.trials}): nothing to run", file=sys.stderr)
    print(best_yaml(result))
    if plot is not None:
        print(f"# plot of the trials: {plot}")
    return 0
