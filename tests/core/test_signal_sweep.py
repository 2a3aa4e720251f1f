"""The signal sweep (issue 31): every ending signal at random moments of a whole ``marknav run``,
from marknav's first line to the process's exit: exit 130 without a traceback, the report and
the log whole once the mission was read, the wheels left at 0.
"""

from __future__ import annotations

import json
import math
import os
import random
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

from tests.faultkit import (
    ENV,
    SLALOM,
)

SWEEP_MOMENTS = int(os.environ.get("MARKNAV_SWEEP_MOMENTS", "14"))


def _log_has(events: Path, kind: str) -> bool:
    """The event log's last few records include one of ``kind``."""
    try:
        with open(events, "rb") as fh:
            fh.seek(max(0, os.path.getsize(events) - 2000))
            return f'"kind": "{kind}"'.encode() in fh.read()
    except OSError:
        return False


def _sweep_run(tmp_path: Path, k: int, anchor: str, offset: float, sig: int
               ) -> tuple[int, str, bool, float]:
    """``run`` the slalom and signal it ``offset`` s after ``anchor``: "start" (marknav's first
    line ran: its entry point imported :mod:`marknav.core.signals`), "events" (the event log
    appeared: the run is starting), "tick" (the loop runs), "end" (the log's end record: the
    final write is under
    way), "report" (the report is written: the command is returning), "never". Exit code,
    stderr, whether it was still running when signalled, and how soon it ended after that."""
    report = tmp_path / f"r{k}.json"
    events = tmp_path / f"r{k}.events.jsonl"
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "marknav", "run",
                             str(SLALOM), "--tree", "none", "--report", str(report),
                             "--max-time", "1"], cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    started = threading.Event()

    def read_stderr() -> None:  # -X importtime: one line per import, as it finishes
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line)
            if line.rstrip().endswith(" marknav.core.signals"):
                started.set()

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    seen = {"start": started.is_set, "events": events.exists,
            "tick": lambda: _log_has(events, "tick"), "end": lambda: _log_has(events, "end"),
            "report": report.exists,
            "never": lambda: False}[anchor]
    running = False
    exited_within = math.inf  # seconds from the signal to the process's end
    if anchor != "never":
        deadline = time.monotonic() + 60
        while not seen() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        time.sleep(offset)
        running = proc.poll() is None and not _zombie(proc.pid)
        if running:
            proc.send_signal(sig)
            sent = time.monotonic()
            while proc.poll() is None and not _zombie(proc.pid) and time.monotonic() < sent + 1:
                time.sleep(0.001)
            exited_within = time.monotonic() - sent
    try:
        proc.wait(90)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(10)
    err = "".join(ln for ln in lines if not ln.startswith("import time:"))
    return proc.returncode, err, running, exited_within


def _zombie(pid: int) -> bool:
    """The process has ended (its exit code is set) but was not collected yet (Linux)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"
    except (OSError, IndexError):
        return False


def test_signal_sweep_over_the_whole_life_of_a_run(tmp_path: Path) -> None:
    """A signal at any moment of ``run`` — start-up, reading and checking the mission, the run,
    the final write, the exit — ends it with 130 and no traceback; once the mission was read,
    the report and the log exist, the log ends with its ``end`` record and, where the simulated
    robot had been started, its wheels were left at 0. The moments are random within each
    part of the run's life (found by what the run has written so far), from marknav's first
    line on: the interpreter's own start-up before it (≈ 15 ms idle, over 100 ms on a loaded
    machine) is Python's, not marknav's (docs/architecture.md, Signals)."""
    from concurrent.futures import ThreadPoolExecutor

    seed = int(os.environ.get("MARKNAV_SWEEP_SEED", random.randrange(10**6)))
    rng = random.Random(seed)
    code, err, _, _ = _sweep_run(tmp_path, 0, "never", 0.0, signal.SIGINT)
    assert code == 1 and "time limit" in err, err  # undisturbed, the run fails its time limit
    parts = [("start", 0.0, 0.3)] * 3 + [("start", 0.3, 1.5)] * 2 + [("events", 0.0, 0.3)] * 2
    parts += [("tick", 0.0, 0.15)] * 3 + [("end", 0.0, 0.01)] * 2 + [("report", 0.0, 0.005)] * 2
    while len(parts) < SWEEP_MOMENTS:
        parts.append(rng.choice(parts))
    moments = [(anchor, rng.uniform(lo, hi)) for anchor, lo, hi in parts[:SWEEP_MOMENTS]]
    from marknav.core.signals import ENDING_SIGNALS  # every ending signal, in turn

    sigs = [ENDING_SIGNALS[k % len(ENDING_SIGNALS)] for k in range(len(moments))]
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda k: _sweep_run(tmp_path, k + 1, *moments[k], sigs[k]),
                                range(len(moments))))
    phases: Counter[str] = Counter()
    for k, ((anchor, offset), (code, err, running, exited_within)) in enumerate(
            zip(moments, results, strict=True), start=1):
        where = f"seed {seed}, moment {k}: {offset:.3f} s after {anchor}, {sigs[k - 1]!r}\n{err}"
        assert "Traceback" not in err and "Exception" not in err, where
        report = tmp_path / f"r{k}.json"
        events = tmp_path / f"r{k}.events.jsonl"
        if not running or (code == 1 and exited_within < 0.05 and report.exists()
                           and "interrupted" not in err):
            # It had ended, or was ending: os._exit called, the kernel freeing it (≈ 10 ms;
            # a signal is not delivered then and the exit code is set): the run's own result.
            assert code == 1 and "time limit" in err, where
            phases["after the process ended"] += 1
            continue
        assert code == 130, where
        if not report.exists():  # signalled before the mission was read: nothing written
            assert not events.exists() and "report:" not in err, where
            phases["start-up or reading the mission"] += 1
            continue
        data = json.loads(report.read_text())
        last = json.loads(events.read_text().splitlines()[-1])
        assert last["kind"] == "end" and last["reason"] == data["reason"], where
        if data.get("sim_final") is not None:
            assert data["sim_final"]["wheels_mm_s"] == [0, 0], where
        if data["reason"].startswith("interrupted") and data["reason"].endswith(
                ("while checking the mission", "while preparing the simulator",
                 "while starting")):
            phases["checks and start"] += 1
        elif data["reason"].startswith("interrupted"):
            phases["the run"] += 1
        else:  # the verdict was reached: it stands, the exit code says "signalled"
            assert (data["outcome"], data["reason"]) == ("failed", "time limit: 1 s"), where
            phases["final write or exit"] += 1
    print(f"signal sweep, seed {seed}: {len(moments)} moments: {dict(phases)}")
    assert sum(phases.values()) == len(moments)
