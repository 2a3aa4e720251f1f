"""Run a mission: load it, build its tree, pick the environment, run the loop, write the report.

Used by ``marknav run`` and by the evaluation (many simulated runs). Everything the run needs is
checked before the robot moves: a bad mission, world, port or camera raises
:class:`~marknav.core.errors.InputError` (exit 2) and nothing starts.
"""

from __future__ import annotations

import contextlib
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import py_trees

from marknav.behaviours import keys
from marknav.behaviours.route import failure_reason
from marknav.behaviours.tree import build_mission_tree
from marknav.behaviours.verify import CONFIRMED, REFUTED
from marknav.core import outputs, signals
from marknav.core.cvthreads import one_opencv_thread
from marknav.core.errors import InputError
from marknav.missions.schema import Mission, load_mission
from marknav.runs.loop.runner import Environment, RunOptions, run_tree
from marknav.runs.records.report import (
    ABORTED,
    DOUBTFUL,
    FAILED,
    PASSED_OUTCOMES,
    SUCCESS,
    UNSURE_OUTCOMES,
    UNVERIFIED,
    EventLog,
    RunReport,
    WaypointResult,
)
from marknav.runs.records.runlog import Recorder

log = logging.getLogger(__name__)


@dataclass
class RunRequest:
    """What ``marknav run`` was asked to do."""

    mission: Mission
    world: str | None = None
    robot: str = "sim"
    camera: str = "sim"
    tree_style: str = "none"
    out: TextIO | None = None
    report_path: Path | None = None
    events_path: Path | None = None
    plot_path: Path | None = None
    seed: int | None = None
    #: Pace a simulated clock at wall-clock speed; ``None``: when the live view is on a
    #: terminal (a person watching), else as fast as it goes.
    realtime: bool | None = False
    max_time_s: float | None = None
    #: Filled in by :func:`execute`: the files it wrote, and why others could not be written.
    written: list[Path] = field(default_factory=list)
    write_errors: list[str] = field(default_factory=list)
    randomise: bool = False  # generated worlds: random conditions and mark yaw (evaluation)
    generate_world: bool = False  # ignore the mission's sim.world: generate one from the seed
    frames_hz: float | None = None  # save camera frames (JPEG) beside the event log this often
    viewer: bool = False  # stream the run to a Rerun viewer (the ``viewer`` extra)
    record_path: Path | None = None  # save the run as ROS 2 messages in MCAP (rosbag2 folder)
    record_hz: float | None = None  # camera images a second in the recording (None: 5)
    record_quality: int | None = None  # their JPEG quality 0..100 (None: 70)
    foxglove_port: int | None = None  # serve the recording's channels live (0: a free port)
    #: Set by :func:`execute` when ``foxglove_port`` is given: the port the server listens on.
    foxglove_bound: int | None = None
    world_model: Any = None  # a World built in memory (a random mission's): used as it is
    #: Set once :func:`execute` (or :func:`write_interrupted`) began writing the report and the
    #: log: a signal that ends the command after that needs no other report.
    finishing: bool = False
    engine: str | None = None  # simulator engine (None: the mission's sim.engine, else builtin)
    groot2: tuple[str, int] | None = None  # serve the live tree to Groot2 on (host, port)


@dataclass
class RunResult:
    report: RunReport
    environment: Environment
    plans: list[Any] = field(default_factory=list)


def default_max_time_s(mission: Mission) -> float:
    """A generous limit: 60 s plus 40 s per waypoint of simulated (or real) time."""
    return 60.0 + 40.0 * len(mission.route)


def engine_of(mission: Mission, req: RunRequest) -> str:
    """The simulator engine of a run: ``--engine``, else the mission's ``sim.engine``."""
    if req.engine is not None:
        return req.engine
    return mission.sim.engine if mission.sim is not None else "builtin"


def _world_for(mission: Mission, req: RunRequest, seed: int) -> Any:
    """The world of a simulated run, with the mission's ``sim.conditions`` on top of its own."""
    world = _base_world(mission, req, seed)
    changes = mission.sim.conditions if mission.sim is not None else {}
    if changes:
        conditions = type(world.conditions).model_validate(
            {**world.conditions.model_dump(), **changes})
        world = world.model_copy(update={"conditions": conditions})
        from marknav.sim.world.course import check_engine_conditions

        check_engine_conditions(world, engine_of(mission, req), mission.source_path,
                                keys=list(changes), prefix="sim.conditions")
    return world


def _base_world(mission: Mission, req: RunRequest, seed: int) -> Any:
    from marknav.sim.world.course import (
        check_against_palette,
        check_course,
        check_engine_conditions,
    )
    from marknav.sim.world.generate import generate_world
    from marknav.sim.world.schema import load_world

    if req.world_model is not None:
        world = req.world_model
        check_against_palette(world, mission.palette())
        check_course(world, mission.route)
        return world.with_mark_radius(mission.marks.radius_mm)
    path = None if req.generate_world else req.world
    if (path is None and not req.generate_world and mission.sim is not None
            and mission.sim.world is not None):
        path = str(mission.sim.world)
    if path is not None:
        world = load_world(path)
        check_against_palette(world, mission.palette(), path)
        check_course(world, mission.route, path)
        check_engine_conditions(world, engine_of(mission, req), path)
    else:
        world = generate_world(
            mission.route, seed=seed, clearance_mm=mission.navigation.clearance_mm,
            radius_mm=mission.marks.radius_mm,
            conditions="randomised" if req.randomise else "default",
            bypass_distance_mm=mission.navigation.bypass_distance_mm,
            sides=[mission.side_of(c) for c in mission.route],
            half_fov_deg=mission.camera.hfov_deg / 2.0,
            engine="mujoco" if engine_of(mission, req) == "mujoco" else "builtin",
        )
    return world.with_mark_radius(mission.marks.radius_mm)


def make_environment(mission: Mission, req: RunRequest, seed: int) -> Environment:
    """The simulator, or a real Create and camera, as the request says."""
    if req.robot == "sim":
        from marknav.runs.loop.sim_environment import SimEnvironment
        from marknav.sim.builtin_camera import CameraConfig

        if req.camera != "sim":
            raise InputError("--camera must be 'sim' with --robot sim (the simulated robot "
                             "only exists in the simulated world)", field="--camera")
        world = _world_for(mission, req, seed)
        cam = CameraConfig(width=mission.camera.width, height=mission.camera.height,
                           focal_px=mission.camera.focal_px)
        return SimEnvironment(
            world, mission.palette(), model=mission.robot.model, camera=cam, seed=seed,
            robot_radius_mm=mission.robot.radius_mm,
            command_timeout_s=mission.safety.command_timeout_s,
            sensor_timeout_s=mission.safety.sensor_timeout_s,
            wheel_base_mm=mission.robot.wheel_base_mm,
            engine=engine_of(mission, req),
            shadows=mission.sim.shadows if mission.sim is not None else True,
            odometry_scale=mission.robot.odometry_scale,
        )
    if req.engine is not None and req.engine != "builtin":
        raise InputError("--engine chooses the simulator; it needs --robot sim",
                         field="--engine")
    if req.camera == "sim":
        raise InputError("--camera sim needs --robot sim; give a real camera (--camera 0, a "
                         "video file or an http:// stream) with a real robot", field="--camera")
    from marknav.robot.driver import CreateDriver
    from marknav.runs.loop.hardware_environment import HardwareEnvironment
    from marknav.vision.sources import open_source

    # timeout 0: the control cycle takes the newest frame if there is one, and never waits
    camera = open_source(req.camera, timeout_s=0.0, latency_s=mission.camera.latency_s)
    try:
        driver = CreateDriver(
            req.robot, model=mission.robot.model, baudrate="auto",
            odometry_scale=mission.robot.odometry_scale,
            command_timeout_s=mission.safety.command_timeout_s,
            sensor_timeout_s=mission.safety.sensor_timeout_s,
            wheel_base_mm=mission.robot.wheel_base_mm,
        )
        driver.connect()  # closes itself if it fails or is interrupted
    except BaseException:
        camera.close()
        raise
    return HardwareEnvironment(driver, camera)


def waypoint_outcomes(mission: Mission, report: RunReport) -> list[str]:
    """Each waypoint's verdict as the robot sees it: ``passed``, ``doubtful`` (passed by
    odometry, but its own sightings do not confirm it: the reason goes in the waypoint's
    ``doubt``), ``failed`` (the first not passed when the run failed) or ``pending``."""
    bb = py_trees.blackboard.Blackboard
    passed = bb.get(keys.PASSED) if bb.exists(keys.PASSED) else ()
    done = {p.waypoint: p for p in passed}
    out = []
    failed_marked = False
    for i in range(len(mission.route)):
        if i in done:
            record = done[i]
            out.append(_verdict_of(record))
            failed_marked = failed_marked or out[-1] == "failed"
            if record.doubt is not None and i < len(report.waypoints):
                report.waypoints[i].doubt = record.doubt
                report.waypoints[i].check = record.check
        elif report.outcome != "success" and not failed_marked:
            out.append("failed")
            failed_marked = True
        else:
            out.append("pending")
    return out


def _verdict_of(record: keys.PassedWaypoint) -> str:
    """A passed waypoint's verdict: sure (no doubt, or confirmed looking back), refuted
    looking back (``failed``), ``unverified`` (looked back, undecided) or ``doubtful`` (not
    checked)."""
    if record.doubt is None or record.check == CONFIRMED:
        return "passed"
    if record.check == REFUTED:
        return "failed"
    return UNVERIFIED if record.check == UNVERIFIED else DOUBTFUL


def pass_times(mission: Mission) -> list[float | None]:
    bb = py_trees.blackboard.Blackboard
    passed = bb.get(keys.PASSED) if bb.exists(keys.PASSED) else ()
    by_index = {p.waypoint: p.t for p in passed}
    return [by_index.get(i) for i in range(len(mission.route))]


def recorded_plans() -> list[Any]:
    bb = py_trees.blackboard.Blackboard
    return list(bb.get(keys.PLANS)) if bb.exists(keys.PLANS) else []


def prepare(*, simulator: bool) -> None:
    """Load the compiled loops a run needs: for the simulator, the renderer's (≈ 0.1–0.3 s once
    per process from the cache; building them on a cold cache takes 10–40 s on a busy 2-core
    machine); the detector has none. Cheap after the first call in a process. The command line
    calls it under a status line before :func:`execute`, which calls it too."""
    if simulator:
        from marknav.sim.projection import warm_up as warm_projection

        warm_projection()


def execute(req: RunRequest) -> RunResult:
    """Run the mission of ``req`` to the end. Raises InputError for bad input,
    KeyboardInterrupt (after stopping the wheels and writing the report) on Ctrl-C/SIGTERM.

    The report (``req.report_path``) and the event log (``req.events_path``) are written in
    every case once this is called — also when the start fails (a robot that does not answer, a
    camera that cannot be opened: outcome ``aborted``, reason ``did not start: …``) and when a
    signal arrives at any point (:mod:`marknav.core.signals`). What was written is listed in
    ``req.written``, what could not be in ``req.write_errors``. The environment (the driver:
    wheels stopped, Passive, port closed) is closed on every way out.
    """
    mission = req.mission
    seed = _seed(req)
    report = _unstarted_report(req, seed)
    events = _event_log(req)
    env: Environment | None = None
    result: RunResult | None = None
    root: py_trees.behaviour.Behaviour | None = None
    try:
        root = build_mission_tree(mission)
        keys.reset()
        # before the robot and the camera are opened and the clock starts: the first control
        # cycle must not wait for the compiled loops
        prepare(simulator=req.robot == "sim")
        env = make_environment(mission, req, seed)
        result = RunResult(report=report, environment=env)
        recorder = _recorder(req, root, env, events)
        options = RunOptions(
            rate_hz=mission.control.rate_hz,
            max_time_s=(req.max_time_s if req.max_time_s is not None
                        else default_max_time_s(mission)),
            realtime=paced(req, recorder), sleep=req.robot != "sim", observer=recorder,
            visitors=[recorder.state.ticked] if recorder is not None else [],
        )
        # A simulated run is lock-step on small arrays: one OpenCV thread is as fast and
        # leaves the other core free (:mod:`marknav.core.cvthreads`).
        with one_opencv_thread() if req.robot == "sim" else contextlib.nullcontext():
            run_tree(
                root, env, report, events, options,
                setup_kwargs={"robot": env.robot, "clock": env.clock, "mission": mission,
                              "camera": env.camera},
                waypoint_outcomes=lambda: waypoint_outcomes(mission, report),
                classify=_classify,
            )
    except (InputError, KeyboardInterrupt) as exc:
        if env is None:  # the start failed: say why in the report and the log
            why = (f"interrupted ({exc or 'SIGINT'}) while starting"
                   if isinstance(exc, KeyboardInterrupt) else f"did not start: {exc}")
            report.outcome, report.reason = ABORTED, why
            events.write(0.0, "end", outcome=report.outcome, reason=why, ticks=0)
        elif isinstance(exc, KeyboardInterrupt) and report.reason == "did not start":
            report.reason = f"interrupted ({exc or 'SIGINT'})"  # before the loop began
        raise
    finally:
        with signals.deferred():
            _finish(req, mission, env, result, report, events, root)
    assert result is not None
    return result


def _seed(req: RunRequest) -> int:
    mission = req.mission
    return req.seed if req.seed is not None else (mission.sim.seed if mission.sim else 0)


def _unstarted_report(req: RunRequest, seed: int) -> RunReport:
    mission = req.mission
    report = RunReport(
        mission=mission.name, seed=seed if req.robot == "sim" else None,
        robot=req.robot, camera=req.camera,
        engine=engine_of(mission, req) if req.robot == "sim" else None,
        waypoints=[WaypointResult(colour=c, side=mission.side_of(c)) for c in mission.route],
        overrides=list(mission.overrides),
    )
    report.outcome, report.reason = ABORTED, "did not start"
    return report


def _event_log(req: RunRequest) -> EventLog:
    try:
        return EventLog(req.events_path)
    except OSError as exc:
        raise InputError(f"cannot write the event log: {exc.strerror or exc}",
                         file=str(req.events_path), field="--events") from None


def write_interrupted(req: RunRequest, exc: KeyboardInterrupt, when: str) -> None:
    """The report and the event log of a run a signal stopped before :func:`execute` (``when``:
    e.g. "while checking the mission"): outcome ``aborted``, reason ``interrupted (SIGNAL)
    WHEN``; nothing had been opened, so no wheel ever turned. Files as :func:`execute` lists
    them (``req.written``, ``req.write_errors``)."""
    report = _unstarted_report(req, _seed(req))
    report.reason = f"interrupted ({exc or 'SIGINT'}) {when}"
    with signals.deferred():
        try:
            events = _event_log(req)
        except InputError as error:
            req.write_errors.append(str(error))
            events = EventLog(None)
        events.write(0.0, "end", outcome=report.outcome, reason=report.reason, ticks=0)
        _finish(req, req.mission, None, None, report, events)


def mark_unconfirmed(report: RunReport) -> None:
    """A run that passed every waypoint, one or more of them ``doubtful`` or ``unverified``
    by the robot's own evidence, ends ``unverified`` (not ``success``), its reason naming them."""
    doubts = [f"waypoint {i} ({w.colour}) {w.outcome}: {w.doubt}"
              for i, w in enumerate(report.waypoints, start=1) if w.outcome in UNSURE_OUTCOMES]
    if report.outcome == SUCCESS and doubts:
        report.outcome = UNVERIFIED
        report.reason += (f", but {len(doubts)} of them not confirmed by the robot's own "
                          "evidence: " + "; ".join(doubts))


def _finish(req: RunRequest, mission: Mission, env: Environment | None,
            result: RunResult | None, report: RunReport, events: EventLog,
            root: py_trees.behaviour.Behaviour | None = None) -> None:
    """Close the environment, complete and write the report and the log, draw the plot.
    An exception from the ground truth (a bug) is raised again once the files are written."""
    req.finishing = True
    failure: Exception | None = None
    extra: dict[str, Any] = {}
    mark_unconfirmed(report)
    try:
        if env is not None:
            env.close()
    finally:
        if env is not None and result is not None:
            result.plans = recorded_plans()
            try:
                extra = _fill_ground_truth(mission, env, report)
                if root is not None:
                    _fill_range_law(root, mission, report)
            except Exception as exc:
                failure = exc
        events.close()
        if events.path is not None:
            if events.error is None:
                req.written.append(events.path)
            else:
                req.write_errors.append(events.error)
        if req.report_path is not None:
            try:
                report.write(req.report_path)
                req.written.append(req.report_path)
            except OSError as exc:
                req.write_errors.append(f"cannot write the report {req.report_path}: "
                                        f"{exc.strerror or exc}")
        if req.plot_path is not None and env is not None and result is not None:
            try:
                _plot(mission, env, result, req.plot_path, extra.get("waypoint_marks"))
                req.written.append(req.plot_path)
            except InputError as exc:
                req.write_errors.append(str(exc))
            except OSError as exc:
                req.write_errors.append(f"cannot write the plot {req.plot_path}: "
                                        f"{exc.strerror or exc}")
        if failure is not None:
            raise failure


def paced(req: RunRequest, recorder: Recorder | None) -> bool:
    """Whether a simulated run goes at wall-clock speed: as asked, else when the live view
    draws it on a terminal (a 41 s mission lasts 41 s on screen, not the 3 s it computes in)."""
    from marknav.runs.views.display import LiveView

    if req.realtime is not None:
        return req.realtime
    return recorder is not None and isinstance(recorder.view, LiveView)


def _recorder(req: RunRequest, root: py_trees.behaviour.Behaviour, env: Environment,
              events: EventLog) -> Recorder | None:
    """The run log's recorder, with the live view and the Rerun recording when asked for."""
    from marknav.runs.views.display import make_view

    sinks: list[Any] = []
    if req.viewer:
        from marknav.runs.views.viewer import RECORD_FRAMES_HZ, RerunSink

        sinks.append(RerunSink(req.mission, getattr(env, "world", None), spawn=True,
                               frames_hz=req.frames_hz or RECORD_FRAMES_HZ))
    recording = _ros2_recording(req, root, env)
    if recording is not None:
        sinks.append(recording)
    if req.groot2 is not None:
        sinks.append(_groot2_server(req, root))
    title = f"marknav run {req.mission.name}"
    if req.realtime is None and req.robot == "sim":
        title += " · real time (--fast: full speed)"
    view = make_view(req.out, req.tree_style, title=title)
    if view is None and not sinks and events.path is None:
        return None
    mission = req.mission
    return Recorder(root, env, events, mission=mission, view=view, sinks=sinks,
                    frames_hz=req.frames_hz,
                    finish=lambda report: _fill_ground_truth(mission, env, report))


def _ros2_recording(req: RunRequest, root: py_trees.behaviour.Behaviour,
                    env: Environment) -> Any:
    """The MCAP recording and the live Foxglove server, when asked for (else None); they start
    (in the recording's own process) before the loop does."""
    from marknav.runs.records.mcap_recording import (
        JPEG_QUALITY,
        RECORD_HZ,
        McapFile,
        OutputSpec,
        Ros2Recording,
    )
    from marknav.runs.records.tree_state import TreeState

    outputs: list[OutputSpec] = []
    if req.foxglove_port is not None:
        from marknav.runs.views.foxglove_live import FoxgloveLive

        outputs.append((FoxgloveLive, {"port": req.foxglove_port}))
    if req.record_path is not None:
        outputs.append((McapFile, {"path": req.record_path}))
    if not outputs:
        return None
    recording = Ros2Recording(
        req.mission, getattr(env, "world", None), outputs, tree=TreeState.of_tree(root),
        record_hz=req.record_hz or RECORD_HZ,
        jpeg_quality=JPEG_QUALITY if req.record_quality is None else req.record_quality)
    req.foxglove_bound = recording.port
    return recording
def _groot2_server(req: RunRequest, root: py_trees.behaviour.Behaviour) -> Any:
    """Groot2's server for the live tree (``--groot2``); a port in use is the user's input."""
    import zmq

    from marknav.runs.views.groot2 import Groot2Server

    assert req.groot2 is not None
    host, port = req.groot2
    try:
        return Groot2Server.for_tree(root, req.mission.name, host=host, port=port)
    except zmq.ZMQError as exc:
        raise InputError(f"cannot serve Groot2 on {host}:{port} (and {port + 1}): {exc}",
                         field="--groot2") from None


def _classify(root: py_trees.behaviour.Behaviour) -> tuple[bool, str]:
    failure = failure_reason(root)
    if failure is None:
        return False, f"{root.name} failed"
    return failure.aborted, failure.reason


def _fill_range_law(root: py_trees.behaviour.Behaviour, mission: Mission,
                    report: RunReport) -> None:
    from marknav.behaviours.perception import Perception

    for node in root.iterate():
        if isinstance(node, Perception):
            report.set_frame_latencies(node.latencies, node.frames_beyond_history)
            if node.range_learner is not None:
                report.range_law = node.learnt_range(pass_times(mission))
            return


def _fill_ground_truth(mission: Mission, env: Environment, report: RunReport) -> dict[str, Any]:
    """The simulator's verdict, from the true path alone: per waypoint the course mark and its
    truth, the path itself, and — a run is a success only if the truth says so — a route the
    tree completed but the truth denies becomes a failure with the truth's reason. Returns the
    run log's extra figures: collision points and the world mark each waypoint was matched to."""
    from marknav.runs.loop.sim_environment import SimEnvironment, waypoint_truth
    from marknav.runs.metrics.truth import PASSED, truth_path

    if not isinstance(env, SimEnvironment):
        return {}
    route = list(mission.route)
    truth = waypoint_truth(env.truth, env.world, route, [mission.side_of(c) for c in route])
    for wp, mt in zip(report.waypoints, truth, strict=True):
        wp.passed_on = mt.passed_on
        wp.min_clearance_mm = mt.min_clearance_mm
        wp.mark = mt.mark_dict()
        wp.truth = mt.truth
        wp.truth_detail = mt.detail
    report.truth_path = truth_path(env.truth.t, env.truth.xy)
    report.collisions = len(env.truth.collisions)
    denied = [f"waypoint {i} ({wp.colour}, mark {mt.mark_index}) {mt.truth.replace('_', ' ')}"
              + (f": {mt.detail}" if mt.detail else "")
              for i, (wp, mt) in enumerate(zip(report.waypoints, truth, strict=True), start=1)
              if mt.truth != PASSED]
    if report.outcome == SUCCESS and denied:
        report.outcome = FAILED
        report.reason = ("the tree completed the route, but the ground truth says: "
                         + "; ".join(denied))
    report.sim_final = {
        "wheels_mm_s": [env.create.wheel_speeds.left, env.create.wheel_speeds.right],
        "oi_mode": env.create.mode.name.lower(),
        "stream": bool(env.create.streaming),
    }
    return {"collision_points": list(env.truth.collisions),
            "waypoint_marks": [mt.mark_index for mt in truth]}


def _plot(mission: Mission, env: Environment, result: RunResult, path: Path,
          waypoint_marks: list[int | None] | None = None) -> None:
    from marknav.runs.loop.sim_environment import SimEnvironment
    from marknav.sim.plot import plot_run

    if not isinstance(env, SimEnvironment):
        raise InputError("--plot draws the simulator's ground truth; it needs --robot sim",
                         field="--plot")
    plot_run(mission, env.world, env.truth, result.plans, result.report, path,
             waypoint_marks=waypoint_marks)


def load(path: str) -> Mission:
    return load_mission(path)


def summary(report: RunReport) -> str:
    """One line: what happened."""
    passed = sum(1 for w in report.waypoints if w.outcome in PASSED_OUTCOMES)
    doubtful = sum(1 for w in report.waypoints if w.outcome in UNSURE_OUTCOMES)
    speed = report.speedup
    speed_s = f", {speed:.1f}x real time" if speed is not None and math.isfinite(speed) else ""
    doubts = f", {doubtful} of them unconfirmed" if doubtful else ""
    line = (f"{report.mission}: {report.outcome} — {report.reason} ({passed}/"
            f"{len(report.waypoints)} waypoints{doubts}, {report.collisions} collisions, "
            f"{report.sim_time_s:.1f} s{speed_s})")
    if report.outcome == ABORTED and report.reason.startswith("interrupted"):
        line += "; wheels stopped"
    return line


def default_run_dir(mission: Mission) -> Path:
    """A new folder under ``runs/`` named after the mission (made safe: see
    :func:`marknav.core.outputs.safe_file_name`), created now."""
    return outputs.default_run_dir(mission.name)
