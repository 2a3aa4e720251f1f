"""Benchmarks of the behaviour tree, the simulated control loop and the safety stop (issue 7).

Each function returns a JSON-ready dict, the section ``marknav bench`` prints for it.

- :func:`bench_tree` — wall time of ``BehaviourTree.tick()`` for the default route tree
  (architecture, *The mission tree*) with mocked perception (:class:`~marknav.testing.
  FakePerception` seeing marks placed by :func:`~marknav.sim.world.generate_world`) and a
  :class:`~marknav.testing.FakeRobot` on a :class:`~marknav.core.clock.ManualClock`: steady-state
  ticks while the robot approaches and bypasses marks. Setup is excluded, and so is the fake
  robot's own simulation (it is caught up with the clock before each timed tick), so the time is
  the tree's: the perception leaf publishing the marks, the guards, target selection, approach
  steering and the Bézier bypass (planning, pure pursuit).
- :func:`bench_loop` — a simulated mission at ``control.rate_hz`` with full rendering and
  detection (the run loop of :mod:`marknav.runs.loop.runner`): the cycle time (poll + tick, which
  renders and detects), overruns of the period, the simulator's speed-up over real time, and
  where the wall time goes (``breakdown_ms_per_cycle``: detector, render, the rest of the
  tick, simulation = the simulated Create, world and driver byte path, other).
- :func:`bench_safety` — bump-to-stop latency of the safety layer alone
  (:func:`marknav.runs.benchmarks.safety.measure_bump_to_stop`), and end to end through the real
  driver: a :class:`~marknav.sim.simulated_create.SimulatedCreate` behind ``createsim://`` sends a
  stream
  frame with the bump bit (OI packet 7), and the time is taken from the frame's bytes being
  handed to :meth:`CreateDriver.process_input` to the zero Drive Direct (opcode 145) arriving at
  the simulated robot (OI spec, *Stream* and *Drive Direct*).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
import py_trees

from marknav.missions.schema import Mission

__all__ = ["bench_loop", "bench_safety", "bench_tree", "default_slalom"]

log = logging.getLogger(__name__)

SLALOM_ROUTE = ("red", "green", "red", "blue")
#: The OI stream period (s): a bump must stop the wheels within one.
STREAM_PERIOD_S = 0.015
#: Control period of the tree benchmark (s): the brief's 20 Hz.
TREE_DT_S = 0.05


def _pct(values_s: Sequence[float], q: float, scale: float) -> float:
    return round(float(np.percentile(np.asarray(values_s) * scale, q)), 3)


def _route(waypoints: int) -> list[str]:
    return [SLALOM_ROUTE[i % len(SLALOM_ROUTE)] for i in range(waypoints)]


# ------------------------------------------------------------------------------------- tree


def _time_route_tree(mission: Mission, *, ticks: int, warmup: int, seed: int,
                     cpu: list[float] | None = None) -> tuple[list[float], int, int]:
    """Tick the mission's route tree with mocked perception; per-tick wall seconds (after
    ``warmup`` ticks), waypoints passed, ticks run. ``cpu`` receives each timed tick's CPU
    seconds (this thread's: time the scheduler gave to other processes is not in it)."""
    from marknav.behaviours import keys
    from marknav.behaviours.route import build_route_tree
    from marknav.core.clock import ManualClock
    from marknav.sim.world.generate import generate_world
    from marknav.testing import FakePerception, FakeRobot, WorldMark

    world = generate_world(
        mission.route, seed=seed, clearance_mm=mission.navigation.clearance_mm,
        radius_mm=mission.marks.radius_mm,
        bypass_distance_mm=mission.navigation.bypass_distance_mm,
        sides=[mission.side_of(c) for c in mission.route],
        half_fov_deg=mission.camera.hfov_deg / 2.0)
    keys.reset()
    clock = ManualClock()
    robot = FakeRobot(clock=clock, wheel_base_mm=mission.robot.wheel_base_mm,
                      command_timeout_s=mission.safety.command_timeout_s,
                      sensor_timeout_s=mission.safety.sensor_timeout_s)
    perception = FakePerception(
        world=[WorldMark(m.colour, m.x_mm, m.y_mm) for m in world.marks],
        focal_px=mission.camera.focal_px, image_width=mission.camera.width,
        image_height=mission.camera.height)
    root = build_route_tree(mission, perception=perception)
    tree = py_trees.trees.BehaviourTree(root)  # what marknav run ticks
    tree.setup(robot=robot, clock=clock, mission=mission)
    times: list[float] = []
    n = 0
    try:
        for n in range(1, warmup + ticks + 1):
            clock.advance(TREE_DT_S)
            robot.sync()  # the fake robot's physics: not the tree's time
            c0 = time.thread_time()
            t0 = time.perf_counter()
            tree.tick()
            dt = time.perf_counter() - t0
            if n > warmup:
                times.append(dt)
                if cpu is not None:
                    cpu.append(time.thread_time() - c0)
            if root.status != py_trees.common.Status.RUNNING:
                break
        bb = py_trees.blackboard.Blackboard
        passed = len(bb.get(keys.PASSED)) if bb.exists(keys.PASSED) else 0
    finally:
        tree.interrupt()
        keys.reset()
    return times, passed, n


def bench_tree(*, waypoints: int = 50, ticks: int = 2000, slalom_ticks: int = 1000,
               warmup: int = 10, seed: int = 0) -> dict[str, Any]:
    """µs per tick of the slalom's route tree and of a ``waypoints``-waypoint route (see the
    module docstring). ``ticks``/``slalom_ticks`` bound the timed ticks (at 20 Hz: 2000 ticks are
    100 s of mission, about 15 marks); a route that finishes earlier stops there."""
    from marknav.testing import make_mission

    if waypoints < 1 or ticks < 1 or slalom_ticks < 1 or warmup < 0:
        raise ValueError("waypoints, ticks and slalom_ticks must be ≥ 1, warmup ≥ 0")
    big = make_mission(name=f"bench-{waypoints}", route=_route(waypoints))
    slalom = make_mission(name="slalom", route=list(SLALOM_ROUTE))
    big_cpu: list[float] = []
    big_t, big_passed, _ = _time_route_tree(big, ticks=ticks, warmup=warmup, seed=seed,
                                            cpu=big_cpu)
    sl_t, sl_passed, _ = _time_route_tree(slalom, ticks=slalom_ticks, warmup=warmup, seed=seed)
    if not big_t or not sl_t:
        raise RuntimeError("the route finished during the warm-up: nothing was timed")
    return {
        "waypoints": waypoints,
        "ticks": len(big_t),
        "waypoints_passed": big_passed,
        "tick_us_p50": _pct(big_t, 50, 1e6),
        "tick_us_p99": _pct(big_t, 99, 1e6),
        "tick_us_max": _pct(big_t, 100, 1e6),
        # CPU time of the ticking thread: on a shared machine, without the time the scheduler
        # gave to other processes (on a quiet one, close to the wall figures above).
        "tick_cpu_us_p50": _pct(big_cpu, 50, 1e6),
        "tick_cpu_us_p99": _pct(big_cpu, 99, 1e6),
        "slalom_ticks": len(sl_t),
        "slalom_waypoints_passed": sl_passed,
        "slalom_tick_us_p50": _pct(sl_t, 50, 1e6),
        "slalom_tick_us_p99": _pct(sl_t, 99, 1e6),
    }


# ------------------------------------------------------------------------------------- loop


def default_slalom() -> Mission:
    """The built-in example ``slalom`` (the checkout's ``missions/slalom.yaml``), with its own
    world."""
    from marknav.missions.examples import EXAMPLES_DIR
    from marknav.missions.schema import load_mission

    return load_mission(EXAMPLES_DIR / "slalom.yaml")


def bench_loop(*, mission: Mission | None = None, max_time_s: float = 60.0,
               seed: int | None = None) -> dict[str, Any]:
    """Run ``mission`` (default :func:`default_slalom`) in the simulator for at most
    ``max_time_s`` simulated seconds, as fast as the machine allows; cycle times, overruns,
    speed-up."""
    from marknav.runs.loop.run import RunRequest, execute

    if not max_time_s > 0:
        raise ValueError(f"max_time_s must be positive, got {max_time_s}")
    mission = mission if mission is not None else default_slalom()
    package = logging.getLogger("marknav")
    old = package.level
    package.setLevel(max(old, logging.ERROR))  # bumps in a run are not the benchmark's news
    spent: dict[str, float] = {}
    try:
        with _timed_parts(spent):
            cpu0 = time.process_time()
            report = execute(RunRequest(mission=mission, seed=seed,
                                        max_time_s=max_time_s)).report
            cpu_s = time.process_time() - cpu0
    finally:
        package.setLevel(old)
    return {
        "mission": mission.name,
        "rate_hz": mission.control.rate_hz,
        "width": mission.camera.width,
        "height": mission.camera.height,
        "outcome": report.outcome,
        "sim_time_s": round(report.sim_time_s, 2),
        "wall_time_s": round(report.wall_time_s, 2),
        "speedup": round(report.speedup, 2) if report.speedup is not None else None,
        # This process's CPU time for the whole run, set-up included (world, renderer): on a
        # shared machine, the speed-up the other processes' share of the cores does not hide.
        "cpu_time_s": round(cpu_s, 2),
        "speedup_cpu": round(report.sim_time_s / cpu_s, 2) if cpu_s > 0 else None,
        "cycles": report.ticks,
        "cycle_ms_p50": report.tick_ms["p50"],
        "cycle_ms_p99": report.tick_ms["p99"],
        "cycle_ms_max": report.tick_ms["max"],
        "overruns": report.overruns,
        "breakdown_ms_per_cycle": _breakdown(spent, report.ticks, report.wall_time_s),
    }


#: What :func:`bench_loop` times inside a run: (part, module, class, method). The tick contains
#: the camera's rendering and the detector; poll and advance are the simulated Create, the
#: world's contacts and the driver's byte path.
_PARTS = (
    ("tick", "py_trees.trees", "BehaviourTree", "tick"),
    ("render", "marknav.sim.builtin_camera", "Renderer", "render"),
    ("detector", "marknav.missions.mission_detector", "CameraDetector", "detect"),
    ("simulation", "marknav.runs.loop.sim_environment", "SimEnvironment", "poll"),
    ("simulation", "marknav.runs.loop.sim_environment", "SimEnvironment", "advance"),
)


@contextlib.contextmanager
def _timed_parts(spent: dict[str, float]) -> Iterator[None]:
    """While inside, the methods of :data:`_PARTS` add their wall seconds to ``spent[part]``
    (a wrapper each: ≈ 1 µs per call, five calls per cycle). A method that no longer exists
    is left out (its part reads None)."""
    patched: list[tuple[type, str, Any]] = []

    def timed(part: str, method: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(method)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                spent[part] = spent.get(part, 0.0) + time.perf_counter() - t0
        return wrapper

    try:
        for part, module, cls_name, name in _PARTS:
            cls = getattr(importlib.import_module(module), cls_name, None)
            method = cls.__dict__.get(name) if cls is not None else None
            if cls is None or method is None:
                log.warning("bench loop: %s.%s.%s not found; its part is not timed", module,
                            cls_name, name)
                continue
            patched.append((cls, name, method))
            setattr(cls, name, timed(part, method))
        yield
    finally:
        for cls, name, method in reversed(patched):
            setattr(cls, name, method)


def _breakdown(spent: dict[str, float], cycles: int, wall_s: float) -> dict[str, float | None]:
    """ms per cycle: detector, render, the rest of the tick, simulation, and everything else
    of the run's wall time (the runner's bookkeeping, the tree's setup)."""
    if cycles < 1:
        return {}

    def ms(value: float | None) -> float | None:
        return None if value is None else round(value * 1e3 / cycles, 3)

    tick, render, detector = spent.get("tick"), spent.get("render"), spent.get("detector")
    simulation = spent.get("simulation")
    tick_other = (tick - render - detector
                  if tick is not None and render is not None and detector is not None else None)
    other = wall_s - tick - simulation if tick is not None and simulation is not None else None
    return {"detector": ms(detector), "render": ms(render), "tick_other": ms(tick_other),
            "simulation": ms(simulation), "other": ms(other), "total": ms(wall_s)}


# ----------------------------------------------------------------------------------- safety


def _bump_to_stop_e2e(n: int, *, speed_mm_s: int = 200) -> list[float]:
    """Seconds from a bump frame's bytes handed to ``process_input`` to the zero Drive Direct
    bytes reaching the simulated Create; ``n`` times (see the module docstring)."""
    from marknav.core.clock import ManualClock
    from marknav.robot import oi
    from marknav.robot.driver import CreateDriver
    from marknav.sim.protocol_createsim import register, unregister
    from marknav.sim.simulated_create import SimulatedCreate

    stop_bytes = bytes(oi.drive_direct(left=0, right=0))

    class StampingCreate(SimulatedCreate):
        """Notes when the zero Drive Direct arrives, before executing it."""

        zero_at: float | None = None

        def write(self, data: bytes | bytearray) -> int:
            if bytes(data) == stop_bytes and self.zero_at is None:
                self.zero_at = time.perf_counter()
            return super().write(data)

    clock = ManualClock()
    sim = StampingCreate(clock=clock)
    url = register(sim)
    driver = CreateDriver(url, clock=clock, reader_thread=False, first_frame_timeout_s=None,
                          settle_s=0.0)
    latencies: list[float] = []

    def next_frame() -> None:
        """Simulate exactly up to the next 15 ms stream frame (no float drift)."""
        sent = sim.frames_sent
        clock.set(sim.next_tick_time())
        sim.sync()
        if sim.frames_sent != sent + 1:
            raise RuntimeError("the simulated Create did not send one stream frame")

    try:
        driver.connect()
        next_frame()
        driver.process_input()
        for i in range(n):
            sim.set_bump(False, False)
            next_frame()
            driver.process_input()  # bump released: bumped -> ready
            if not driver.drive(left=speed_mm_s, right=speed_mm_s):
                raise RuntimeError(f"run {i}: drive refused in state {driver.safety_state}")
            sim.set_bump(True, False)
            next_frame()  # the frame with the bump is now waiting in the port
            sim.zero_at = None
            t0 = time.perf_counter()
            driver.process_input()
            stopped = sim.zero_at
            wheels = sim.wheel_speeds
            if stopped is None or wheels.left != 0 or wheels.right != 0:
                raise RuntimeError(f"run {i}: the bump did not stop the wheels "
                                   f"(state {driver.safety_state})")
            latencies.append(stopped - t0)
    finally:
        driver.close()
        unregister(url.split("://", 1)[1])
    return latencies


def bench_safety(*, n: int = 2000, e2e_n: int = 500) -> dict[str, Any]:
    """Bump-to-stop latency, safety layer alone (``n`` bumps) and end to end (``e2e_n``)."""
    from marknav.robot import safety
    from marknav.runs.benchmarks.safety import measure_bump_to_stop

    if n < 1 or e2e_n < 1:
        raise ValueError("n and e2e_n must be ≥ 1")
    layer = measure_bump_to_stop(n)
    quiet = [logging.getLogger(name) for name in (safety.__name__, "marknav.robot.driver")]
    levels = [lg.level for lg in quiet]
    for lg in quiet:
        lg.setLevel(logging.ERROR)  # time the stop path, not log handlers
    try:
        e2e = _bump_to_stop_e2e(e2e_n)
    finally:
        for lg, level in zip(quiet, levels, strict=True):
            lg.setLevel(level)
    worst = max(max(layer), max(e2e))
    return {
        "n": n,
        "bump_to_stop_ms_p50": _pct(layer, 50, 1e3),
        "bump_to_stop_ms_p99": _pct(layer, 99, 1e3),
        "e2e_n": e2e_n,
        "bump_to_stop_e2e_ms_p50": _pct(e2e, 50, 1e3),
        "bump_to_stop_e2e_ms_p99": _pct(e2e, 99, 1e3),
        "stream_period_ms": STREAM_PERIOD_S * 1e3,
        "max_ms": round(worst * 1e3, 3),
        "within_one_period": worst < STREAM_PERIOD_S,
    }
