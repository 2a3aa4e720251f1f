"""``marknav run``: drive a mission — in the simulator by default, on a real Create by choice."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from marknav.cli.validate import SET_HELP, set_item
from marknav.core.errors import EXIT_INTERRUPTED, InputError, MissionFailed

#: Shown when preparing takes over a second: building the compiled loops on a cold cache (the
#: first run after installing: 10–40 s), or loading them on a very busy machine.
PREPARING = "preparing the simulator (the first run compiles its renderer: up to a minute)…"

if TYPE_CHECKING:
    from marknav.missions.schema import Mission
    from marknav.runs.loop.run import RunRequest


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "run",
        help="run a mission (simulator by default)",
        description=(
            "Run MISSION's behaviour tree at control.rate_hz. With no --robot/--camera the "
            "built-in simulator is the robot and the camera. On a terminal the tree and a status "
            "panel are redrawn in place every tick; piped, the tree is printed whenever a status "
            "changes. The run report and the complete run log (JSON Lines: every tick's status "
            "changes, poses, detections, wheel commands, safety events; 'marknav replay' reads "
            "it) are written as the run goes, also when it fails or is interrupted (default "
            "folder: runs/NAME-TIME/). --record saves the run as ROS 2 messages in MCAP (the "
            "'record' extra), --foxglove serves them live (the 'foxglove' extra); --viewer "
            "needs the 'viewer' extra (Rerun); marknav turns Rerun's anonymous usage "
            "analytics off (RERUN_ANALYTICS=0)."
        ),
    )
    p.add_argument("mission", metavar="MISSION",
                   help="mission YAML file, or the name of a built-in example (slalom)")
    p.add_argument("--world", metavar="WORLD|generate|random",
                   help="simulator world file (default: the mission's sim.world, else one "
                        "generated from the route and --seed); 'generate' forces a generated "
                        "world, 'random' one with randomised light, noise, wheels and mark yaw "
                        "(what 'marknav evaluate' runs, so its failures replay exactly)")
    p.add_argument("--robot", default="sim", metavar="sim|PORT|URL",
                   help="'sim', a serial device (/dev/ttyUSB0) or a pyserial URL "
                        "(socket://host:port, rfc2217://host:port)")
    p.add_argument("--camera", default="sim", metavar="sim|INDEX|PATH|URL",
                   help="'sim', a camera index, a video file, an image folder or an http:// "
                        "MJPEG stream")
    p.add_argument("--tree", default="auto", choices=("auto", "ascii", "unicode", "none"),
                   help="how to draw the tree (default auto: unicode where the terminal "
                        "can show it)")
    p.add_argument("--report", metavar="FILE.json", type=Path, help="run report path")
    p.add_argument("--events", metavar="FILE.jsonl", type=Path,
                   help="event log path (default: beside the report)")
    p.add_argument("--plot", metavar="FILE.png", type=Path,
                   help="top-down picture of the run (simulator only)")
    p.add_argument("--frames", type=float, metavar="HZ",
                   help="also save camera frames as JPEG files beside the run log, at most HZ "
                        "per second (e.g. 2), so a real-robot run can be looked at afterwards; "
                        "with --viewer, also the camera image rate there (default 5 per "
                        "second of run time, JPEG-compressed)")
    p.add_argument("--viewer", action="store_true",
                   help="stream the run live to the Rerun viewer: camera with detections, "
                        "top-down map, range and wheel plots, tree status (extra: viewer)")
    p.add_argument("--engine", choices=("builtin", "mujoco"),
                   help="simulator engine (default: the mission's sim.engine, else builtin): "
                        "mujoco runs MuJoCo's physics and renderer (the 'mujoco' extra and the "
                        "system package libosmesa6)")
    p.add_argument("--seed", type=int, help="simulator seed (default: the mission's sim.seed)")
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--realtime", action="store_const", const=True, dest="realtime",
                      help="pace the simulator at wall-clock speed (the default when the live "
                           "view is on a terminal)")
    pace.add_argument("--fast", action="store_const", const=False, dest="realtime",
                      help="run the simulator as fast as it goes, also under the live view "
                           "(the default when the output is not a terminal)")
    p.add_argument("--max-time", type=float, metavar="SECONDS",
                   help="give up after this much mission time (default 60 s + 40 s per "
                        "waypoint)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", dest="overrides",
                   type=set_item, help=SET_HELP + "; recorded in the report")
    _recording_options(p)
    # -- Groot2's live monitor ---------------------------------------------------------------
    from marknav.cli.groot2_option import GROOT2_HELP

    p.add_argument("--groot2", nargs="?", const="1667", metavar="[HOST:]PORT", help=GROOT2_HELP)
    # ------------------------------------------------------------------------------------------
    p.set_defaults(func=run)


# -- the recording (MCAP, ROS 2 messages) and the live view in Foxglove ----------------------

def _recording_options(p: argparse.ArgumentParser) -> None:
    from marknav.runs.records.mcap_recording import JPEG_QUALITY, RECORD_HZ
    from marknav.runs.views.foxglove_live import DEFAULT_PORT

    g = p.add_argument_group("recording and live view (ROS 2 messages: Foxglove, Rerun, ros2 bag)")
    g.add_argument("--record", nargs="?", const="", metavar="FILE.mcap",
                   help="save the run as ROS 2 messages in an MCAP file, with the rosbag2 "
                        "metadata.yaml beside it (default file: run.mcap in the run's folder; "
                        "'marknav view' opens it in Rerun; extra: record)")
    g.add_argument("--record-hz", type=float, metavar="HZ",
                   help=f"camera images per second of run time in the recording (default "
                        f"{RECORD_HZ:g})")
    g.add_argument("--record-quality", type=int, metavar="0..100",
                   help=f"JPEG quality of the recorded images (default {JPEG_QUALITY})")
    g.add_argument("--foxglove", nargs="?", const=DEFAULT_PORT, type=int, metavar="PORT",
                   help=f"serve the recording's channels live to Foxglove on 127.0.0.1:PORT "
                        f"(default {DEFAULT_PORT}; 0: a free port) while the mission runs "
                        "(extra: foxglove)")


def _check_recording(args: argparse.Namespace) -> None:
    """The recording options make sense and their libraries are installed (exit 2 if not)."""
    if args.record_hz is not None and not args.record_hz > 0:
        raise InputError(f"must be positive, got {args.record_hz}", field="--record-hz")
    from marknav.runs.records.mcap_recording import JPEG_QUALITY_MAX

    if args.record_quality is not None and not 0 <= args.record_quality <= JPEG_QUALITY_MAX:
        raise InputError(f"must be in 0..100, got {args.record_quality}",
                         field="--record-quality")
    if args.foxglove is not None:
        from marknav.runs.views.foxglove_live import PORT_MAX, require_foxglove

        if not 0 <= args.foxglove <= PORT_MAX:
            raise InputError(f"must be a port in 0..{PORT_MAX}, got {args.foxglove}",
                             field="--foxglove")
        require_foxglove("--foxglove")
    if args.record is not None:
        try:
            import mcap.writer  # noqa: F401
            import mcap_ros2  # noqa: F401
        except ImportError:
            raise InputError("needs the MCAP writer, which is not installed: pip install "
                             "'marknav[record]'", field="--record") from None
        if args.record and not args.record.endswith(".mcap"):
            raise InputError("the recording's file name must end in .mcap",
                             file=args.record, field="--record")


def _record_path(args: argparse.Namespace, report_path: Path) -> Path | None:
    """Where the recording goes: the file named, or run.mcap beside the report."""
    from marknav.core.outputs import check_output_file
    from marknav.runs.records.mcap_recording import recording_folder_problem

    if args.record is None:
        return None
    path = Path(args.record) if args.record else report_path.with_name("run.mcap")
    check_output_file(path, option="--record")
    problem = recording_folder_problem(path)
    if problem is not None:
        raise InputError(problem, file=str(path), field="--record")
    return path


def check_outputs(args: argparse.Namespace) -> None:
    """Every output path the user gave is writable, before anything starts (exit 2)."""
    from marknav.core.outputs import check_output_file

    for option, path in (("--report", args.report), ("--events", args.events),
                         ("--plot", args.plot)):
        if path is not None:
            check_output_file(path, option=option)
    if args.plot is not None and args.robot != "sim":
        raise InputError("--plot draws the simulator's ground truth; it needs --robot sim",
                         field="--plot")


def run(args: argparse.Namespace) -> int:
    from marknav.cli.groot2_option import groot2_address
    from marknav.cli.requirements import MUJOCO, require
    from marknav.core.errors import InputErrors
    from marknav.core.outputs import printable
    from marknav.missions.examples import mission_path
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.loop.checks import loaded_mission_problems, read_mission
    from marknav.runs.loop.run import execute, prepare, summary, write_interrupted
    from marknav.runs.records.report import reached
    from marknav.runs.views.progress import slow_status

    if args.max_time is not None and not args.max_time > 0:
        raise InputError(f"must be positive, got {args.max_time}", field="--max-time")
    if args.seed is not None and args.seed < 0:
        raise InputError(f"must be ≥ 0, got {args.seed}", field="--seed")
    if args.frames is not None and not args.frames > 0:
        raise InputError(f"must be positive, got {args.frames}", field="--frames")
    if args.viewer:
        from marknav.runs.views.viewer import require_display, require_rerun

        require_rerun("--viewer")
        require_display("--viewer")
    _check_recording(args)
    check_outputs(args)
    args.groot2 = groot2_address(args.groot2)  # (host, port) or None
    overrides = parse_overrides(args.overrides)
    args.mission = mission_path(args.mission)
    world = None if args.world in (None, "generate", "random") else args.world
    requests: list[RunRequest] = []

    def request() -> RunRequest:
        """The run's request, made once: the default report path is a new folder."""
        if not requests:
            requests.append(_request(args, mission))
        return requests[0]

    def written() -> str:
        req = request()
        names = {req.report_path: "report", req.events_path: "events", args.plot: "plot"}
        order = [req.report_path, req.events_path, args.plot]
        shown = sorted(req.written, key=lambda p: order.index(p) if p in order else 9)
        return "  ".join(f"{names[p]}: {printable(str(p))}" for p in shown)

    def write_errors() -> None:
        for error in request().write_errors:
            print(f"marknav run: error: {printable(error)}", file=sys.stderr)

    # Everything 'marknav validate' checks, before anything starts; then only the hardware.
    # Once the file is read, a signal at any moment leaves a report and an event log.
    mission = read_mission(args.mission, overrides, world=world)
    stage = "while checking the mission"
    started = False
    try:
        problems = loaded_mission_problems(mission, overrides, world=world, engine=args.engine)
        if problems:
            raise InputErrors(problems)
        if args.engine is None and mission.sim is not None and mission.sim.engine == "mujoco":
            require(MUJOCO, "sim.engine")  # --engine was checked with the other options
        req = request()
        stage = "while preparing the simulator"
        with slow_status(PREPARING, sys.stderr):
            prepare(simulator=args.robot == "sim")
        stage, started = "while starting", True
        result = execute(req)
    except KeyboardInterrupt as exc:
        req = request()
        when = stage
        early = not req.finishing  # execute() had not got as far as writing its files
        if early:
            write_interrupted(req, exc, when)
        write_errors()
        state = "wheels stopped" if started else "nothing was started"
        # the whole message: returning (not re-raising) keeps the CLI's generic
        # "interrupted" line from repeating it
        print(f"marknav run: interrupted{' ' + when if early else ''}; {state}; "
              f"{written() or 'nothing written'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except InputError:
        if requests:
            write_errors()
            if requests[0].written:
                print(f"marknav run: did not start; {written()}", file=sys.stderr)
        raise
    report = result.report
    print(summary(report))
    got_to = reached(report.waypoints)
    for i, wp in enumerate(report.waypoints, start=1):
        truth = ""
        if wp.truth is not None and wp.mark is not None:
            side = f"passed on its {wp.passed_on}" if wp.passed_on else "not passed"
            ok = ("ok" if wp.truth == "passed" else "not reached" if i > got_to
                  else wp.truth.replace("_", " ").upper())
            closest = (f", closest {wp.min_clearance_mm:.0f} mm"
                       if wp.min_clearance_mm is not None else "")
            truth = (f"; ground truth (mark {wp.mark['index']} at {wp.mark['x_mm']:g}, "
                     f"{wp.mark['y_mm']:g}): {side} ({ok}){closest}")
        print(f"  {i}. {wp.colour} (pass on its {wp.side}): {wp.outcome}{truth}")
    law = report.range_law
    if law is not None and law.get("steps"):
        print(f"range law learnt from {law['steps']} fits (started from {law['source']}); "
              f"paste under camera: in the mission:\n  {law['yaml']}")
    if req.written:
        line = written()
        if req.record_path is not None and req.record_path.exists():
            line += f"  recording: {printable(str(req.record_path))}"
        print(line)
    if req.write_errors:
        write_errors()
        return 2
    if report.outcome != "success":
        raise MissionFailed(f"{report.outcome}: {report.reason}")
    return 0


def _request(args: argparse.Namespace, mission: Mission) -> RunRequest:
    """What to run, and where its files go (the default: a new folder under runs/, created
    now; its event log checked as the user's own paths were)."""
    from marknav.core.outputs import check_output_file
    from marknav.runs.loop.run import RunRequest, default_run_dir

    report_path: Path = args.report or default_run_dir(mission) / "report.json"
    events_path: Path = args.events or report_path.with_name(report_path.stem + ".events.jsonl")
    if args.events is None:
        check_output_file(events_path, option="--events")
    generated = args.world in ("generate", "random")
    return RunRequest(
        mission=mission, world=None if generated else args.world, robot=args.robot,
        camera=args.camera, generate_world=generated, randomise=args.world == "random",
        tree_style=args.tree, out=sys.stdout, report_path=report_path,
        events_path=events_path, plot_path=args.plot, seed=args.seed,
        realtime=args.realtime, max_time_s=args.max_time, frames_hz=args.frames,
        viewer=args.viewer, record_path=_record_path(args, report_path), engine=args.engine,
        record_hz=args.record_hz, record_quality=args.record_quality,
        foxglove_port=args.foxglove,
        groot2=args.groot2,
    )
