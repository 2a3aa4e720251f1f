"""Where an evaluation's runs execute (issue 16; issue 15 item 9): a Dask cluster gives the same
per-seed results as the local pool, Ctrl-C cancels the cluster's tasks, and the local pool's
workers stop with their parent whatever signal it gets (fault tests on a real ``marknav
evaluate --jobs 2`` process group)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from marknav.cli.main import main
from marknav.runs.evaluation.backends import QUEUED_PER_WORKER
from marknav.runs.evaluation.evaluate import SeedResult, evaluate
from tests.tiny_mission import TINY

distributed = pytest.importorskip("distributed")



@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("backends") / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A real scheduler and two single-threaded worker processes on loopback."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0") as c:
        yield c


def outcome(r: SeedResult) -> tuple[Any, ...]:
    """Everything of a run but its wall time."""
    return (r.seed, r.outcome, r.reason, r.sim_time_s, r.collisions, r.waypoints, r.ticks)


@pytest.mark.slow
def test_dask_gives_the_per_seed_results_of_the_local_pool(tiny: Path, cluster: Any) -> None:
    local = evaluate(tiny, runs=3, seed=5, jobs=2, max_time_s=8, min_success=0)
    seen: list[tuple[int, int, int]] = []
    remote = evaluate(tiny, runs=3, seed=5, dask=cluster.scheduler_address, max_time_s=8,
                      min_success=0, progress=lambda d, t, s: seen.append((d, t, s)))
    assert [outcome(r) for r in remote.results] == [outcome(r) for r in local.results]
    assert [r.seed for r in remote.results] == [5, 6, 7]
    assert remote.jobs == 2  # the cluster's two workers
    # Progress: the start, then one call per finished run.
    assert [(d, t) for d, t, _ in seen] == [(0, 3), (1, 3), (2, 3), (3, 3)]
    assert seen[-1][2] == remote.successes


def test_dask_bad_address_is_bad_input(tiny: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(tiny), "--runs", "1", "--dask", "127.0.0.1:1"]) == 2
    assert "--dask: give the scheduler's address as tcp://HOST:PORT" in capsys.readouterr().err
    assert main(["evaluate", str(tiny), "--runs", "1", "--dask", "tcp://127.0.0.1:9",
                 "--jobs", "2"]) == 2
    assert "--jobs:" in capsys.readouterr().err


def _spawn(argv: list[str]) -> subprocess.Popen[str]:
    """``marknav ARGV`` in its own process group (as a shell job: Ctrl-C reaches the group),
    with SIGINT at its default even if something in this test process left it ignored (an
    ignored signal is inherited, and Python then leaves it ignored)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    old = signal.getsignal(signal.SIGINT)
    if old is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return subprocess.Popen([sys.executable, "-m", "marknav", *argv],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env, start_new_session=True)
    finally:
        signal.signal(signal.SIGINT, old)


def _dask_tasks(client: Any) -> list[str]:
    def ours(dask_scheduler: Any) -> list[str]:
        return [str(k) for k in dask_scheduler.tasks if str(k).startswith("marknav-")]

    tasks: list[str] = client.run_on_scheduler(ours)
    return tasks


def test_ctrl_c_cancels_the_clusters_tasks(tiny: Path, cluster: Any) -> None:
    proc = _spawn(["evaluate", str(tiny), "--runs", "40", "--max-time", "8",
                   "--dask", cluster.scheduler_address])
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        deadline = time.monotonic() + 120
        while not _dask_tasks(client) and time.monotonic() < deadline:
            time.sleep(0.2)  # the evaluation has submitted its first runs to the cluster
        # a few per worker (two workers), not the 40 at once
        assert 0 < len(_dask_tasks(client)) <= QUEUED_PER_WORKER * 2
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130, err
        assert "interrupted" in err and "Traceback" not in err
        deadline = time.monotonic() + 30
        while _dask_tasks(client) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _dask_tasks(client) == []


# ------------------------------------------------------------------ local pool: faults


def _group(pgid: int) -> list[tuple[int, str]]:
    """(pid, command) of the live (not zombie) processes of process group ``pgid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            out.append((int(entry.name), cmd))
    return out


def _wait_group(pgid: int, n: int, *, timeout: float = 60) -> list[tuple[int, str]]:
    """Wait until the group has ``n`` live processes (≥ n when n > 0) and return them."""
    deadline = time.monotonic() + timeout
    while True:
        procs = _group(pgid)
        if (len(procs) >= n if n else not procs) or time.monotonic() > deadline:
            return procs
        time.sleep(0.1)


def _started_pool(tiny: Path) -> subprocess.Popen[str]:
    proc = _spawn(["evaluate", str(tiny), "--runs", "60", "--max-time", "8", "--jobs", "2"])
    # parent + 2 workers + multiprocessing's resource tracker
    procs = _wait_group(proc.pid, 4)
    assert len(procs) >= 4, procs
    assert any("resource_tracker" in cmd for _, cmd in procs), procs
    return proc


pytestmark_linux = pytest.mark.skipif(not Path("/proc/self/stat").exists(),
                                      reason="reads process groups from /proc")


@pytest.mark.slow
@pytestmark_linux
@pytest.mark.parametrize("presses", [1, 2])
def test_pool_ctrl_c_stops_everything(tiny: Path, presses: int) -> None:
    proc = _started_pool(tiny)
    for _ in range(presses):
        os.killpg(proc.pid, signal.SIGINT)  # what the terminal does on Ctrl-C
        time.sleep(0.2)
    _, err = proc.communicate(timeout=60)
    # A second press that lands after the clean-up, while Python exits, ends it by SIGINT
    # (-2; a shell shows 130 either way).
    assert proc.returncode in ((130,) if presses == 1 else (130, -signal.SIGINT)), err
    assert "interrupted" in err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert _wait_group(proc.pid, 0) == []


@pytestmark_linux
def test_pool_sigterm_leaves_no_orphans(tiny: Path) -> None:
    proc = _started_pool(tiny)
    proc.terminate()  # the parent only, as a service manager or `kill PID` would
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err, err
    assert _wait_group(proc.pid, 0) == []  # no worker, no resource tracker


@pytestmark_linux
def test_pool_workers_die_with_a_killed_parent(tiny: Path) -> None:
    proc = _started_pool(tiny)
    proc.kill()  # no chance to clean up: the workers notice on their own
    proc.communicate(timeout=60)
    assert _wait_group(proc.pid, 0) == []


def test_help_text(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["evaluate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "95 % confidence" in text and "%%" not in text
    assert "--dask tcp://HOST:PORT" in text
