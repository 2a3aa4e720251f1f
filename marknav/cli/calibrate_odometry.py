"""``marknav calibrate-odometry``: drive a known distance and turn, compare, print the scale."""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from typing import Any

from marknav.core.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "calibrate-odometry",
        help="measure the odometry scale (and wheel base) by driving a known distance and turn",
        description=(
            "Drive straight ahead until odometry says --distance-mm, stop, and compare with the "
            "distance really travelled: measured with a tape (--measured-mm, or typed when "
            "asked) on a real robot, the ground truth in the simulator (give the world's "
            "conditions, e.g. encoder_scale, with --world). Then turn on the spot --turn-deg by "
            "odometry and compare likewise (--measured-deg). Prints robot.odometry_scale and "
            "robot.wheel_base_mm to put in the mission. Leave 1.5 m of free floor ahead."
        ),
    )
    p.add_argument("mission", metavar="MISSION", help="the mission (robot model, wheel base, "
                   "current odometry scale, safety settings)")
    p.add_argument("--robot", default="sim", help="sim (default), a serial port or pyserial URL")
    p.add_argument("--world", metavar="WORLD", help="simulator world (its conditions: "
                   "encoder_scale, top_speed_mm_s, ...); default: an empty room")
    p.add_argument("--distance-mm", type=float, default=1000.0,
                   help="distance to drive by odometry, mm (default 1000)")
    p.add_argument("--speed-mm-s", type=float, default=150.0,
                   help="driving speed, mm/s (default 150: little slip on starting and stopping)")
    p.add_argument("--turn-deg", type=float, default=360.0,
                   help="turn on the spot by odometry, degrees (default 360; 0: no turn)")
    p.add_argument("--measured-mm", type=float,
                   help="the distance really travelled, mm (a real robot; asked if not given)")
    p.add_argument("--measured-deg", type=float,
                   help="the angle really turned, degrees (a real robot; asked if not given)")
    p.add_argument("--seed", type=int, default=0, help="simulator seed (default 0)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)


#: The Create's top wheel speed (OI spec, Drive Direct: -500 to 500 mm/s).
MAX_SPEED_MM_S = 500.0
#: Slowest calibration speed (mm/s): Drive Direct takes whole mm/s, so below this the command
#: is off by over 5 %, and a metre takes over 50 s.
MIN_SPEED_MM_S = 20.0
#: Shortest straight (mm): an encoder count is ≈ 0.44 mm (72 mm wheel, 508.8 counts a turn), so
#: below this the count alone is off by over 4 %.
MIN_DISTANCE_MM = 10.0
#: Longest straight (mm): a room's free floor; a leg is bounded in time by its length.
MAX_DISTANCE_MM = 10_000.0
#: Largest turn (degrees): ten whole turns, far more than the wheel base needs.
MAX_TURN_DEG = 3600.0
#: Seeds are 64-bit: the simulator's random source takes them whole.
MAX_SEED = 2**63 - 1


def _bounded(value: float, option: str, low: float, high: float, unit: str) -> None:
    if not low <= value <= high:  # also refuses nan
        raise InputError(f"must be from {low:g} to {high:g} {unit}, got {value:g}",
                         field=option)


def _positive(value: float | None, option: str) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"must be a positive number, got {value}", field=option)


def _ask(prompt: str, option: str) -> float:
    """Read a measurement typed by the user (only on a terminal)."""
    if not sys.stdin.isatty():
        raise InputError(f"give the measurement with {option} (no terminal to ask on)",
                         field=option)
    text = input(prompt).strip()
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", field=option) from None
    _positive(value, option)
    return value


def run(args: argparse.Namespace) -> int:
    from marknav.robot import odometry_calibration as oc
    from marknav.runs.loop.checks import checked_mission

    for value, option in ((args.distance_mm, "--distance-mm"), (args.speed_mm_s, "--speed-mm-s"),
                          (args.measured_mm, "--measured-mm"),
                          (args.measured_deg, "--measured-deg")):
        _positive(value, option)
    if args.speed_mm_s > MAX_SPEED_MM_S:
        raise InputError(f"the Create's wheels reach {MAX_SPEED_MM_S:g} mm/s at most, got "
                         f"{args.speed_mm_s}", field="--speed-mm-s")
    _bounded(args.speed_mm_s, "--speed-mm-s", MIN_SPEED_MM_S, MAX_SPEED_MM_S, "mm/s")
    _bounded(args.distance_mm, "--distance-mm", MIN_DISTANCE_MM, MAX_DISTANCE_MM, "mm")
    if not (math.isfinite(args.turn_deg) and args.turn_deg >= 0):
        raise InputError(f"must be 0 or positive, got {args.turn_deg}", field="--turn-deg")
    _bounded(args.turn_deg, "--turn-deg", 0.0, MAX_TURN_DEG, "degrees")
    if not 0 <= args.seed <= MAX_SEED:
        raise InputError(f"must be from 0 to {MAX_SEED} (seeds are 64-bit), got {args.seed}",
                         field="--seed")
    if args.robot != "sim" and not sys.stdin.isatty():
        for value, option, needed in ((args.measured_mm, "--measured-mm", True),
                                      (args.measured_deg, "--measured-deg", args.turn_deg > 0)):
            if needed and value is None:
                raise InputError(f"give the measurement with {option} (no terminal to ask on)",
                                 field=option)
    mission = checked_mission(args.mission, [])
    robot_cfg = mission.robot
    env, truth = _environment(args, mission)
    truth_theta = truth.theta if truth is not None else None
    try:
        before = len(truth.xy) if truth is not None else 0
        straight = oc.drive_straight(env, distance_mm=args.distance_mm,
                                     speed_mm_s=args.speed_mm_s,
                                     rate_hz=mission.control.rate_hz)
        truth_mm = None
        if truth is not None:
            (x0, y0), (x1, y1) = truth.xy[before - 1], truth.xy[-1]
            truth_mm = math.hypot(x1 - x0, y1 - y0)
        turn = None
        truth_turn = None
        if args.turn_deg > 0:
            mark = len(truth_theta) if truth_theta is not None else 0
            turn = oc.turn_in_place(env, angle_deg=args.turn_deg, turn_speed_deg_s=45.0,
                                    wheel_base_mm=robot_cfg.wheel_base_mm,
                                    rate_hz=mission.control.rate_hz)
            if truth_theta is not None:
                seq = truth_theta[mark - 1:]
                truth_turn = math.degrees(sum(math.remainder(b - a, 2 * math.pi)
                                              for a, b in itertools.pairwise(seq)))
    finally:
        close = getattr(env, "close", None)
        if close is not None:
            close()

    sim = args.robot == "sim"
    if args.measured_mm is not None:
        measured_mm = args.measured_mm
    elif truth_mm is not None:
        measured_mm = truth_mm
    else:
        measured_mm = _ask(f"odometry drove {straight.odometry:.1f} mm: measured distance, mm? ",
                           "--measured-mm")
    scale = oc.odometry_scale(measured_mm=measured_mm, odometry_mm=straight.odometry,
                              current=robot_cfg.odometry_scale)
    out: dict[str, Any] = {
        "odometry_mm": round(straight.odometry, 1), "measured_mm": round(measured_mm, 1),
        "drive_s": round(straight.drive_s, 2), "commanded_mm_s": args.speed_mm_s,
        "measured_mm_s": round(measured_mm / straight.drive_s, 1) if straight.drive_s else None,
        "odometry_scale": round(scale, 4),
    }
    wheel_base = robot_cfg.wheel_base_mm
    if turn is not None:
        if args.measured_deg is not None:
            measured_deg = args.measured_deg
        elif truth_turn is not None:
            measured_deg = truth_turn
        else:
            measured_deg = _ask(f"odometry turned {turn.odometry:.1f}°: measured angle, "
                                f"degrees? ", "--measured-deg")
        wheel_base = oc.effective_wheel_base(
            wheel_base_mm=robot_cfg.wheel_base_mm, odometry_deg=turn.odometry,
            measured_deg=measured_deg, scale_change=scale / robot_cfg.odometry_scale)
        out.update(odometry_deg=round(turn.odometry, 1), measured_deg=round(measured_deg, 1))
    out["wheel_base_mm"] = round(wheel_base, 1)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"drove {out['odometry_mm']} mm by odometry in {out['drive_s']} s "
          f"(commanded {args.speed_mm_s:g} mm/s); measured {out['measured_mm']} mm "
          f"({'ground truth' if sim and args.measured_mm is None else 'given'}; mean "
          f"{out['measured_mm_s']} mm/s)")
    if turn is not None:
        print(f"turned {out['odometry_deg']}° by odometry; measured {out['measured_deg']}°")
    print("paste under robot: in the mission:")
    print(f"  odometry_scale: {out['odometry_scale']}")
    print(f"  wheel_base_mm: {out['wheel_base_mm']}")
    return 0


def _environment(args: argparse.Namespace, mission: Any) -> tuple[Any, Any]:
    """The environment to drive in, and (simulator) the ground truth it records."""
    if args.robot != "sim":
        if args.world is not None:
            raise InputError("--world needs --robot sim", field="--world")
        from marknav.robot.driver import CreateDriver
        from marknav.robot.odometry_calibration import DriverEnvironment

        driver = CreateDriver(
            args.robot, model=mission.robot.model, baudrate="auto",
            command_timeout_s=mission.safety.command_timeout_s,
            sensor_timeout_s=mission.safety.sensor_timeout_s,
            wheel_base_mm=mission.robot.wheel_base_mm,
            odometry_scale=mission.robot.odometry_scale)
        driver.connect()
        return DriverEnvironment(driver), None
    from marknav.runs.loop.sim_environment import SimEnvironment
    from marknav.sim.world.schema import World, load_world

    world = load_world(args.world) if args.world is not None else World()
    env = SimEnvironment(
        world, mission.palette(), model=mission.robot.model, seed=args.seed,
        robot_radius_mm=mission.robot.radius_mm,
        command_timeout_s=mission.safety.command_timeout_s,
        sensor_timeout_s=mission.safety.sensor_timeout_s,
        wheel_base_mm=mission.robot.wheel_base_mm,
        odometry_scale=mission.robot.odometry_scale)
    return env, env.truth
