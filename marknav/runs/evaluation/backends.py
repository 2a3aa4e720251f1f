"""Where the runs of an evaluation execute: this process, a pool of local worker processes, or
an existing Dask cluster (issue 16).

A job is ``(mission spec, seed)``; every backend runs
:func:`marknav.runs.evaluation.job.run_seed` on it and hands each
:class:`~marknav.runs.records.seed_result.SeedResult` to ``on_result`` as soon as it arrives
(in completion order; the summary sorts by seed). A run is deterministic for its seed, so the
backend changes the wall time and nothing else.

Local pool (``--jobs J``), the lifetime rules of issue 15 item 9:

- workers are ``spawn``-ed (they share nothing with the parent: py_trees' blackboard is
  process-global); each ignores SIGINT and the other signals of
  :data:`~marknav.core.signals.ENDING_SIGNALS` (a closed terminal sends SIGHUP to the whole
  process group: the parent decides), runs its job in a helper thread (so no run installs
  signal handlers in the worker) and leaves SIGTERM at its default, so the parent can end it at
  once; a watchdog thread ends a worker whose parent has gone (``os.getppid()`` changed — the
  parent was killed), so no worker outlives its parent by more than :data:`ORPHAN_POLL_S`;
- in the parent, every signal of :data:`~marknav.core.signals.ENDING_SIGNALS` raises
  :class:`EvaluationInterrupted` while the pool runs; the parent then ignores further ones,
  terminates its workers, shuts the pool down (which also lets multiprocessing's resource
  tracker exit) and re-raises — the CLI exits 130.

Dask (``--dask tcp://HOST:PORT``, ``pip install 'marknav[cluster]'``): the jobs are submitted to
the scheduler as tasks, a few per worker ahead as in the local pool; the workers must be able
to import marknav and read the mission file at the same absolute path (the same checkout or a
shared file system). On Ctrl-C every task of this evaluation still on the cluster is cancelled
before the command exits. A lock serialises runs inside one worker process (py_trees'
blackboard is process-global), so workers should be started with ``--nthreads 1``
(``dask worker tcp://HOST:PORT --nthreads 1``).

Every backend runs each job with OpenCV on one thread (:func:`one_opencv_thread`): one run per
core, not one run spread thinly over all of them.
"""

from __future__ import annotations

import ctypes
import gc
import itertools
import logging
import multiprocessing
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from types import FrameType
from typing import Any

from marknav.core.cvthreads import one_opencv_thread
from marknav.core.errors import InputError
from marknav.core.signals import ENDING_SIGNALS

__all__ = [
    "ORPHAN_POLL_S", "EvaluationInterrupted", "Job", "OnLost", "one_opencv_thread", "run_jobs",
]

log = logging.getLogger(__name__)

#: One evaluation job: the mission spec (a path) and the seed of its world.
Job = (tuple[str, int] | tuple[str, int, tuple[str, ...]]
       | tuple[str, int, tuple[str, ...], str | None])  # (mission, seed[, --set[, engine]])
#: Called with each result as it arrives.
OnResult = Callable[[Any], None]

#: How often a pool worker checks that its parent is alive (s).
ORPHAN_POLL_S = 0.5
#: How long the parent waits between checks of its futures (s): bounds the reaction to signals.
WAIT_S = 0.5
#: Jobs queued ahead per worker in the local pool and on a Dask cluster: enough that a worker
#: finishing a run finds the next one waiting, few enough that the queue costs nothing (10^7
#: runs were 5.1 GB of futures queued up front, with the signals ignored for the 12 minutes
#: that took).
QUEUED_PER_WORKER = 2
#: How long the Dask scheduler has to answer marknav's first message (s): on a LAN it answers
#: in milliseconds, over a busy Wi-Fi link (130-300 ms round trips) within a second.
DASK_PROBE_TIMEOUT_S = 3.0
#: How long the Dask client then has to register with that scheduler (s).
DASK_CONNECT_TIMEOUT_S = 10.0

#: Serialises runs inside one process (py_trees' blackboard is process-global).
_RUN_LOCK = threading.Lock()


#: What a job runs: ``task(mission_path, seed, max_time_s, *rest)`` -> a picklable result.
Task = Callable[..., Any]


class EvaluationInterrupted(KeyboardInterrupt):
    """A signal of :data:`~marknav.core.signals.ENDING_SIGNALS` arrived while the evaluation's
    runs were executing."""


def _run(task: Task, job: Job, max_time_s: float | None) -> Any:
    with _RUN_LOCK, one_opencv_thread():
        try:
            return task(job[0], job[1], max_time_s, *job[2:])  # job[2]: --set overrides
        finally:
            _release_memory()


def _release_memory() -> None:
    """After a run: free its reference cycles (the tree and its blackboard clients, the
    environment and its threads' closures, the frames they hold), which only a full collection
    frees, then hand the freed heap back to the system (glibc keeps it, fragmented: with the
    collection alone a worker still grew from 330 to 500 MB over 40 runs; with both it stays
    within a few MB after the first runs)."""
    gc.collect()
    if _malloc_trim is not None:
        _malloc_trim(0)


def _find_malloc_trim() -> Any:
    """glibc's ``malloc_trim``, or None (another C library, another system)."""
    try:
        return ctypes.CDLL(None).malloc_trim
    except (AttributeError, OSError):
        return None


_malloc_trim = _find_malloc_trim()


# ------------------------------------------------------------------------------ signals


@contextmanager
def _signals_handled(handler: Any, signals: tuple[signal.Signals, ...] = ENDING_SIGNALS
                     ) -> Iterator[None]:
    """Route ``signals`` to ``handler`` (a function or ``signal.SIG_IGN``) for a while, then
    restore the previous handlers (main thread only: elsewhere the caller's thread handles
    signals and this does nothing)."""
    try:
        old = {s: signal.signal(s, handler) for s in signals}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    raise EvaluationInterrupted(signal.Signals(signum).name)


def _interruptible() -> AbstractContextManager[None]:
    """Every signal of :data:`ENDING_SIGNALS` raises :class:`EvaluationInterrupted` (main
    thread only)."""
    return _signals_handled(_raise_interrupted)


def _signals_ignored(signals: tuple[signal.Signals, ...] = ENDING_SIGNALS
                     ) -> AbstractContextManager[None]:
    """Ignore ``signals`` for a while, e.g. so that a second Ctrl-C (or SIGTERM) cannot
    interrupt the clean-up (main thread only)."""
    return _signals_handled(signal.SIG_IGN, signals)


# ----------------------------------------------------------------------------- serial


def _run_serial(task: Task, jobs: Sequence[Job], max_time_s: float | None,
                on_result: OnResult) -> int:
    for job in jobs:
        on_result(_run(task, job, max_time_s))
    return 1


# --------------------------------------------------------------------------- local pool


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(ORPHAN_POLL_S)
        if os.getppid() != parent:
            os._exit(1)  # the parent is gone: nobody wants this run's result


def _init_worker(level: int, parent: int) -> None:
    for s in ENDING_SIGNALS:  # the parent decides what a Ctrl-C or a closed terminal means
        signal.signal(s, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # how the parent ends a worker at once
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    threading.Thread(target=_watch_parent, args=(parent,), name="marknav-parent-watch",
                     daemon=True).start()


def _pool_task(task: Task, job: Job, max_time_s: float | None) -> Any:
    """Run one job in a helper thread: a run then leaves the worker's signal handling alone
    (SIGINT ignored, SIGTERM fatal), whatever the run loop installs in a main thread."""
    out: list[Any] = []
    err: list[BaseException] = []

    def target() -> None:
        try:
            out.append(_run(task, job, max_time_s))
        except BaseException as exc:
            err.append(exc)

    t = threading.Thread(target=target, name=f"marknav-seed-{job[1]}")
    t.start()
    t.join()
    if err:
        raise err[0]
    return out[0]


def _stop_workers(procs: Sequence[multiprocessing.process.BaseProcess]) -> None:
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + 2.0
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join(1.0)


class _Pool:
    """A ``spawn`` process pool whose workers follow the rules of the module docstring, and
    the processes it started (to end them at once)."""

    def __init__(self, workers: int) -> None:
        ctx = multiprocessing.get_context("spawn")
        level = logging.getLogger().getEffectiveLevel()
        self._before = set(multiprocessing.active_children())
        # The pool's helper processes start with SIGINT, SIGHUP... ignored, inherited (a
        # handler is not): multiprocessing's resource tracker (started with the pool's first
        # lock) and the workers (started by the first submits). A Ctrl-C while a worker is
        # still importing cannot kill it with a traceback, and a closed terminal's SIGHUP to
        # the process group cannot kill the tracker under the pool; the parent alone decides.
        # SIGTERM stays: it ends a worker.
        self.spawning = tuple(s for s in ENDING_SIGNALS if s != signal.SIGTERM)
        with _signals_ignored(self.spawning):
            self.executor = ProcessPoolExecutor(
                max_workers=workers, mp_context=ctx, initializer=_init_worker,
                initargs=(level, os.getpid()))
        self.workers = workers
        self.procs: list[multiprocessing.process.BaseProcess] = []
        #: A worker died: the pool is broken (its futures raise ``BrokenProcessPool``).
        self.broken = False

    def submit(self, task: Task, job: Job, max_time_s: float | None) -> Future[Any]:
        if len(self.procs) >= self.workers:  # every worker started: a submit spawns none
            return self.executor.submit(_pool_task, task, job, max_time_s)
        with _signals_ignored(self.spawning):
            fut = self.executor.submit(_pool_task, task, job, max_time_s)
        self.procs += [p for p in multiprocessing.active_children()
                       if p not in self._before and p not in self.procs]
        return fut

    def died(self) -> str:
        """How the broken pool's workers ended (``SIGABRT``, ``exit code 1``), for a message:
        once its manager thread has ended and reaped them (it ends the others itself)."""
        self.broken = True
        with _signals_ignored():
            self.executor.shutdown(wait=True)
        codes = sorted({p.exitcode for p in self.procs
                        if not p.is_alive() and p.exitcode not in (None, 0)}, key=str)
        return ", ".join(signal.Signals(-c).name if c < 0 else f"exit code {c}"
                         for c in codes if c is not None) or "unknown"

    def stop(self) -> None:
        """End the workers now and shut the pool down (after an error or a signal, or once a
        worker died: a broken pool cannot take more jobs)."""
        if self.broken:
            # A broken pool's own manager thread is ending and reaping its workers: waiting
            # for it first, so that no two threads wait for the same process (the second
            # would never learn that it ended).
            with _signals_ignored():
                self.executor.shutdown(wait=True)
                _stop_workers(self.procs)
            return
        with _signals_ignored():
            # The pool cancels what has not started (cancelling futures here races with its
            # manager thread), the workers end now, then the manager thread is joined.
            self.executor.shutdown(wait=False, cancel_futures=True)
            _stop_workers(self.procs)
            self.executor.shutdown(wait=True)


#: What a job whose worker process died twice becomes: ``on_lost(job, how)`` -> a result.
OnLost = Callable[[Job, str], Any]


def _run_pool(task: Task, jobs: Sequence[Job], max_time_s: float | None, on_result: OnResult,
              workers: int, on_lost: OnLost | None = None) -> int:
    """The local pool. A worker that dies (the renderer's library crashing the process, the
    kernel's OOM killer) breaks the pool and every job in flight with it: those jobs are run
    again one at a time, each in a fresh worker of its own (a run depends on its seed alone),
    and a job whose worker dies again becomes ``on_lost(job, how)``; then a fresh pool goes on
    with the rest. Without ``on_lost`` the broken pool's error is raised."""
    queue = iter(jobs)
    pending: dict[Future[Any], Job] = {}
    pool: _Pool | None = None
    with _interruptible():
        try:
            while True:
                if pool is None:
                    pool = _Pool(workers)
                # lazily: a few jobs ahead, never the whole evaluation
                for job in itertools.islice(queue, QUEUED_PER_WORKER * workers - len(pending)):
                    pending[pool.submit(task, job, max_time_s)] = job
                if not pending:
                    pool.executor.shutdown(wait=True)  # a signal here still stops it (below)
                    break
                done, _ = wait(set(pending), timeout=WAIT_S, return_when=FIRST_COMPLETED)
                broken = []
                for fut in done:
                    job = pending.pop(fut)
                    try:
                        result = fut.result()
                    except BrokenProcessPool:
                        pool.broken = True
                        if on_lost is None:
                            raise
                        broken.append(job)
                        continue
                    on_result(result)
                if broken:
                    # a broken pool fails every job it still holds (one that finished first
                    # keeps its result)
                    for fut, job in pending.items():
                        if fut.done() and not fut.cancelled() and fut.exception() is None:
                            on_result(fut.result())
                        else:
                            broken.append(job)
                    pending.clear()
                    how = pool.died()
                    pool.stop()
                    pool = None
                    log.warning("a worker process died (%s) with %d run(s) in flight: running "
                                "them again one at a time", how, len(broken))
                    assert on_lost is not None
                    for job in broken:
                        on_result(_run_alone(task, job, max_time_s, on_lost))
        except BaseException:
            if pool is not None:
                pool.stop()
            raise
    return workers


def _run_alone(task: Task, job: Job, max_time_s: float | None, on_lost: OnLost) -> Any:
    """``job`` in a pool of one fresh worker; ``on_lost(job, how)`` if that worker dies too."""
    pool = _Pool(1)
    try:
        fut = pool.submit(task, job, max_time_s)
        while True:
            done, _ = wait({fut}, timeout=WAIT_S)
            if done:
                break
        try:
            result = fut.result()
        except BrokenProcessPool:
            pool.broken = True
            how = pool.died()
            log.error("seed %s: its worker process died again (%s)", job[1], how)
            result = on_lost(job, how)
        pool.executor.shutdown(wait=True)
    except BaseException:
        pool.stop()
        raise
    return result


# -------------------------------------------------------------------------------- Dask


def _dask_client(address: str) -> Any:
    try:
        from distributed import Client
    except ImportError:
        raise InputError("needs dask.distributed: pip install 'marknav[cluster]'",
                         field="--dask") from None
    if "://" not in address:
        raise InputError(f"give the scheduler's address as tcp://HOST:PORT, got {address!r}",
                         field="--dask")
    _probe_scheduler(address, DASK_PROBE_TIMEOUT_S)
    try:
        return Client(address, timeout=DASK_CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"cannot connect to the Dask scheduler at {address}: {exc}",
                         field="--dask") from None


def _probe_scheduler(address: str, timeout_s: float) -> None:
    """:class:`InputError` unless a Dask scheduler at ``address`` answers within ``timeout_s``.

    Asked on a private event loop, bounded as a whole: ``distributed.Client``'s own timeout
    does not cover a peer that accepts the connection and never answers (it waited for ever),
    and a client that failed to start leaves threads whose clean-up printed a traceback
    (``TimeoutError: timed out after 20 s``) after the error message. No client exists until
    this passed."""
    import asyncio

    from distributed.comm import connect

    async def identity() -> Any:
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(identity(), timeout_s))
    except (OSError, TimeoutError, ValueError) as exc:  # CommClosedError is an OSError
        why = str(exc) or f"no answer within {timeout_s:g} s"
        raise InputError(f"cannot connect to the Dask scheduler at {address}: {why}",
                         field="--dask") from None
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        raise InputError(f"{address} answered, but is not a Dask scheduler ({kind or reply!r})",
                         field="--dask")


def _run_dask(task: Task, jobs: Sequence[Job], max_time_s: float | None, on_result: OnResult,
              address: str) -> int:
    """The jobs on the cluster at ``address``, lazily as in the local pool: at most
    :data:`QUEUED_PER_WORKER` per worker (at least two) submitted and unfinished, the next one
    submitted as each result arrives (so --runs 100,000 is not 100,000 futures and task graphs
    up front, and a Ctrl-C has only those few to cancel). The worker count is asked again at
    each refill, so workers that join the cluster during the evaluation get jobs."""
    from distributed import as_completed

    client = _dask_client(address)
    queue = iter(jobs)
    inflight: set[Any] = set()
    tag = uuid.uuid4().hex[:8]
    most_workers = 0
    try:
        with _interruptible():
            completed = as_completed(loop=client.loop)

            def refill() -> None:
                nonlocal most_workers
                workers = len(client.nthreads())
                most_workers = max(most_workers, workers)
                window = max(QUEUED_PER_WORKER, QUEUED_PER_WORKER * workers)
                for job in itertools.islice(queue, max(0, window - len(inflight))):
                    fut = client.submit(_run, task, job, max_time_s, pure=False, retries=0,
                                        key=f"marknav-{Path(job[0]).stem}-{job[1]}-{tag}")
                    inflight.add(fut)
                    completed.add(fut)

            refill()
            for fut in completed:
                inflight.discard(fut)
                on_result(fut.result())
                refill()
    except BaseException:
        with _signals_ignored():
            try:
                client.cancel(list(inflight), force=True)
            except Exception:
                log.exception("cancelling the cluster's tasks failed")
            client.close(timeout=5)
        raise
    client.close(timeout=5)
    return most_workers or 1


# ------------------------------------------------------------------------------- entry


def run_jobs(task: Task, jobs: Sequence[Job], *, max_time_s: float | None = None,
             workers: int = 1,
             dask: str | None = None, on_result: OnResult | None = None,
             on_lost: OnLost | None = None) -> tuple[list[Any], int]:
    """Run ``task(mission, seed, max_time_s, *rest)`` for every job ``(mission, seed, *rest)``
    (a module-level function, so a process pool or a cluster can ship it by name); return the
    results (completion order) and how many workers ran them.

    ``dask`` (a scheduler address) runs them on that cluster, else ``workers`` > 1 in a local
    process pool, else here. ``on_result`` sees each result as it arrives. Bad input raised by
    a run (:class:`InputError`) and Ctrl-C propagate, after the other runs are stopped. In the
    local pool, a job whose worker process dies twice (see :func:`_run_pool`) becomes
    ``on_lost(job, how)`` (without it, the broken pool's error is raised).
    """
    results: list[Any] = []

    def done(result: Any) -> None:
        results.append(result)
        if on_result is not None:
            on_result(result)

    if dask is not None:
        used = _run_dask(task, jobs, max_time_s, done, dask)
    elif min(workers, len(jobs)) > 1:
        used = _run_pool(task, jobs, max_time_s, done, min(workers, len(jobs)), on_lost)
    else:
        used = _run_serial(task, jobs, max_time_s, done)
    return results, used
