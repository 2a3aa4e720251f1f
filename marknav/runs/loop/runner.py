"""The control loop: tick the mission tree at a fixed rate against an environment.

One cycle (``control.rate_hz``): the environment delivers what happened since the last cycle
(sensor frames, safety timeouts), the tree ticks once (perception → guards → route), then time
moves to the next cycle — by sleeping (real robot, or ``--realtime``) or by stepping the
simulator. Each cycle's processing time is measured; a cycle longer than the period is an
overrun. The loop ends when the tree's root is no longer RUNNING, at the time limit, or on
Ctrl-C / SIGTERM; in every case the wheels are stopped first, then the report and the event log
are completed.

Environments (the simulator, a real Create + camera) implement :class:`Environment`.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import py_trees
import py_trees.visitors
from py_trees.common import Status

from marknav.core import signals
from marknav.core.clock import Clock
from marknav.core.signals import Interrupted, interrupting
from marknav.robot.robot import ESTOPPED, FAULT, Robot
from marknav.runs.records.report import ABORTED, FAILED, SUCCESS, EventLog, RunReport
from marknav.vision.sources import FrameSource

log = logging.getLogger(__name__)


class Environment(Protocol):
    """Robot, camera and time for one run."""

    @property
    def name(self) -> str: ...

    @property
    def clock(self) -> Clock: ...

    @property
    def robot(self) -> Robot: ...

    @property
    def camera(self) -> FrameSource: ...

    def poll(self) -> None:
        """Process what arrived since the last call (sensor frames, safety timeouts)."""
        ...

    def advance(self, until: float) -> None:
        """Let time reach ``until`` (clock seconds): sleep, or step the simulation."""
        ...

    def safety_events(self) -> list[dict[str, Any]]:
        """Safety transitions so far, as ``{t, event, state, detail}`` dicts."""
        ...

    def finish(self, report: RunReport) -> None:
        """Fill in what only this environment knows (ground truth, collisions)."""
        ...

    def close(self) -> None:
        """Stop the wheels and release the hardware. Idempotent."""
        ...


class TickObserver(Protocol):
    """Watches a run: ``tick`` after each tick (run time, overruns so far; it writes records,
    with signals held off until it returns), then ``show`` (a live view, a viewer: what may
    block on a terminal or a socket, so signals are not held), ``finish`` before the event
    log's ``end`` record."""

    def tick(self, now: float, overruns: int) -> None: ...

    def show(self) -> None: ...

    def finish(self, report: RunReport) -> None: ...


@dataclass
class RunOptions:
    rate_hz: float = 20.0
    max_time_s: float = 300.0
    realtime: bool = False  # pace a simulated clock at wall-clock speed
    sleep: bool = False  # the clock is real: sleep until the next cycle
    setup_timeout_s: float = 5.0
    #: Watches every tick (the run log, the live view, the viewer): ``tick(now, overruns)``
    #: after each tick, ``finish(report)`` before the ``end`` record.
    observer: TickObserver | None = None
    #: py_trees visitors added to the tree (the recorder's: which nodes each tick reached).
    visitors: list[py_trees.visitors.VisitorBase] = field(default_factory=list)



#: SIGINT/SIGTERM raise :class:`Interrupted` inside the loop (the process-wide policy of
#: :mod:`marknav.core.signals`, set up for the run if the CLI has not set it up for the process).
_signals_interrupt = interrupting


def _verdict(root: py_trees.behaviour.Behaviour, status: Status, now: float,
             max_time_s: float,
             classify: Callable[[py_trees.behaviour.Behaviour], tuple[bool, str]] | None,
             robot: Robot) -> tuple[str, str] | None:
    """The run's (outcome, reason) after a tick, or None while it goes on."""
    if status == Status.SUCCESS:
        return SUCCESS, "every waypoint passed"
    if status == Status.FAILURE:
        if classify is not None:
            aborted, reason = classify(root)
        else:
            aborted, reason = False, failure_reason(root)
        aborted = aborted or robot.safety_state in (FAULT, ESTOPPED)
        return (ABORTED if aborted else FAILED), reason
    if now >= max_time_s:
        return FAILED, f"time limit: {max_time_s:g} s"
    return None


def failure_reason(root: py_trees.behaviour.Behaviour) -> str:
    """The deepest failed node and its feedback: why the tree failed."""
    reason = ""
    for node in root.iterate():
        if node.status == Status.FAILURE:
            reason = f"{node.name}: {node.feedback_message}" if node.feedback_message else node.name
    return reason or f"{root.name} failed"


def active_path(root: py_trees.behaviour.Behaviour) -> str:
    """Names from the root down to the running leaf."""
    names = []
    node = root
    while True:
        names.append(node.name)
        running = [c for c in node.children if c.status == Status.RUNNING]
        if not running:
            break
        node = running[0]
    return " / ".join(names)


def run_tree(
    root: py_trees.behaviour.Behaviour,
    env: Environment,
    report: RunReport,
    events: EventLog,
    options: RunOptions,
    *,
    setup_kwargs: dict[str, Any] | None = None,
    waypoint_outcomes: Callable[[], list[str]] | None = None,
    classify: Callable[[py_trees.behaviour.Behaviour], tuple[bool, str]] | None = None,
) -> RunReport:
    """Run ``root`` in ``env`` until it finishes, the time runs out, or a signal arrives.

    Always stops the wheels and completes ``report`` (the caller writes it). Returns it.
    ``classify(root)`` says why a failed tree failed: ``(aborted, reason)``.
    """
    tree = py_trees.trees.BehaviourTree(root)
    for visitor in options.visitors:
        tree.add_visitor(visitor)
    observer = options.observer
    period = 1.0 / options.rate_hz
    tick_times: list[float] = []
    wall0 = time.perf_counter()
    t0 = env.clock.now()
    last_status: Status | None = None
    n_safety = 0
    verdict: tuple[str, str] | None = None  # (outcome, reason), once the run has one
    report.outcome, report.reason = ABORTED, "did not start"
    try:
        with _signals_interrupt():
            # py_trees times setup out with a signal, which only the main thread may install;
            # elsewhere (a Dask worker's task thread) setup runs without that timeout.
            main = threading.current_thread() is threading.main_thread()
            tree.setup(timeout=options.setup_timeout_s if main
                       else py_trees.common.Duration.INFINITE,
                       **(setup_kwargs or {}))
            events.write(env.clock.now() - t0, "start", mission=report.mission, env=env.name)
            t_next = env.clock.now()
            while True:
                c0 = time.perf_counter()
                env.poll()
                tree.tick()
                dt = time.perf_counter() - c0
                tick_times.append(dt)
                if dt > period:
                    report.overruns += 1
                now = env.clock.now() - t0
                status = root.status
                # The tick's count, its safety events, status, record and verdict go in
                # together: a signal arriving among them is raised once all are written, so the
                # report's tick count always matches the run log's last tick, and a verdict
                # reached in that tick stands.
                with signals.deferred():
                    report.ticks += 1
                    safety = env.safety_events()
                    for ev in safety[n_safety:]:  # clock time -> run time (never before 0)
                        t_ev = max(0.0, float(ev["t"]) - t0) if "t" in ev else now
                        events.write(t_ev, "safety",
                                     **{k: v for k, v in ev.items() if k != "t"})
                    n_safety = len(safety)
                    if status != last_status:
                        events.write(now, "status", status=status.value,
                                     active=active_path(root))
                        last_status = status
                    if observer is not None:
                        observer.tick(now, report.overruns)
                    verdict = _verdict(root, status, now, options.max_time_s, classify,
                                       env.robot)
                    if verdict is not None:
                        report.outcome, report.reason = verdict
                if observer is not None:
                    observer.show()
                if verdict is not None:
                    break
                t_next += period
                if options.realtime and not options.sleep:
                    lag = (t_next - t0) - (time.perf_counter() - wall0)
                    if lag > 0:
                        time.sleep(lag)
                env.advance(t_next)
    except Interrupted as exc:
        if verdict is None:
            report.outcome, report.reason = ABORTED, f"interrupted ({exc})"
        raise
    except KeyboardInterrupt:
        if verdict is None:
            report.outcome, report.reason = ABORTED, "interrupted (SIGINT)"
        raise
    finally:
        # A signal arriving while the run is being closed is raised once the closing
        # records are written: the event log always ends with the run's `end`.
        with signals.deferred():
            # Wheels first, then everything else.
            try:
                env.robot.stop()
            except Exception:  # the link may be gone; the environment's close() tries again
                log.exception("stopping the wheels failed")
            try:
                tree.interrupt()
            except Exception:
                log.exception("interrupting the tree failed")
            report.sim_time_s = env.clock.now() - t0
            report.wall_time_s = time.perf_counter() - wall0
            report.set_tick_times(tick_times)
            if waypoint_outcomes is not None:
                for wp, outcome in zip(report.waypoints, waypoint_outcomes(), strict=False):
                    wp.outcome = outcome
            try:
                env.finish(report)
            except Exception:
                log.exception("collecting ground truth failed")
            report.safety_events = [
                {**ev, "t": round(max(0.0, float(ev["t"]) - t0), 4)} if "t" in ev else dict(ev)
                for ev in env.safety_events()
            ]
            for ev in report.safety_events[n_safety:]:  # the stop above, a late fault
                events.write(ev.get("t", report.sim_time_s), "safety",
                             **{k: v for k, v in ev.items() if k != "t"})
            if observer is not None:
                try:
                    observer.finish(report)
                except Exception:
                    log.exception("finishing the run log failed")
            events.write(report.sim_time_s, "end", outcome=report.outcome, reason=report.reason,
                         ticks=report.ticks)
    return report
