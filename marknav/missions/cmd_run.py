"""``marknav run``: drive a mission — in the simulator by default, on a real Create by choice."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from marknav.errors import InputError, MissionFailed


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "run",
        help="run a mission (simulator by default)",
        description=(
            "Run MISSION's behaviour tree at control.rate_hz. With no --robot/--camera the "
            "built-in simulator is the robot and the camera. The tree is printed whenever it "
            "changes. The run report and a JSON Lines event log are written even when the run "
            "fails or is interrupted (default folder: runs/NAME-TIME/)."
        ),
    )
    p.add_argument("mission", metavar="MISSION", help="mission YAML file")
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
    p.add_argument("--tree", default="ascii", choices=("ascii", "unicode", "none"),
                   help="how to show the tree as it changes (default ascii)")
    p.add_argument("--report", metavar="FILE.json", type=Path, help="run report path")
    p.add_argument("--events", metavar="FILE.jsonl", type=Path,
                   help="event log path (default: beside the report)")
    p.add_argument("--plot", metavar="FILE.png", type=Path,
                   help="top-down picture of the run (simulator only)")
    p.add_argument("--seed", type=int, help="simulator seed (default: the mission's sim.seed)")
    p.add_argument("--realtime", action="store_true",
                   help="pace the simulator at wall-clock speed")
    p.add_argument("--max-time", type=float, metavar="SECONDS",
                   help="give up after this much mission time (default 60 s + 40 s per "
                        "waypoint)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.missions.run import RunRequest, default_run_dir, execute, summary
    from marknav.missions.schema import load_mission

    if args.max_time is not None and not args.max_time > 0:
        raise InputError(f"must be positive, got {args.max_time}", field="--max-time")
    if args.seed is not None and args.seed < 0:
        raise InputError(f"must be ≥ 0, got {args.seed}", field="--seed")
    mission = load_mission(args.mission)
    report_path: Path = args.report or default_run_dir(mission) / "report.json"
    events_path: Path = args.events or report_path.with_name(report_path.stem + ".events.jsonl")
    generated = args.world in ("generate", "random")
    req = RunRequest(
        mission=mission, world=None if generated else args.world, robot=args.robot,
        camera=args.camera, generate_world=generated, randomise=args.world == "random",
        tree_style=args.tree, out=sys.stdout, report_path=report_path,
        events_path=events_path, plot_path=args.plot, seed=args.seed,
        realtime=args.realtime, max_time_s=args.max_time,
    )
    try:
        result = execute(req)
    except KeyboardInterrupt:
        print(f"marknav run: interrupted; wheels stopped; report: {report_path}",
              file=sys.stderr)
        raise
    report = result.report
    print(summary(report))
    for i, wp in enumerate(report.waypoints, start=1):
        truth = ""
        if wp.truth is not None and wp.mark is not None:
            side = f"passed on its {wp.passed_on}" if wp.passed_on else "not passed"
            ok = "ok" if wp.truth == "passed" else wp.truth.replace("_", " ").upper()
            closest = (f", closest {wp.min_clearance_mm:.0f} mm"
                       if wp.min_clearance_mm is not None else "")
            truth = (f"; ground truth (mark {wp.mark['index']} at {wp.mark['x_mm']:g}, "
                     f"{wp.mark['y_mm']:g}): {side} ({ok}){closest}")
        print(f"  {i}. {wp.colour} (pass on its {wp.side}): {wp.outcome}{truth}")
    print(f"report: {report_path}  events: {events_path}"
          + (f"  plot: {args.plot}" if args.plot else ""))
    if report.outcome != "success":
        raise MissionFailed(f"{report.outcome}: {report.reason}")
    return 0
