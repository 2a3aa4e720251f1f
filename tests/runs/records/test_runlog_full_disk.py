"""A disk that fills during ``run --frames`` (issue 41, R4): the frames stop, the run goes on to
its own verdict with its report and event log, and the loss is said once — no traceback."""

from __future__ import annotations

import errno
import json
import logging
from pathlib import Path
from typing import Any

import pytest

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"
#: Frames written before the disk is full.
FRAMES_THAT_FIT = 3


def test_a_full_disk_drops_the_frames_and_the_run_goes_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        caplog: pytest.LogCaptureFixture) -> None:
    real = Path.write_bytes
    written: list[str] = []
    refused: list[str] = []

    def full_disk(self: Path, data: Any) -> int:
        if self.suffix == ".jpg":
            if len(written) >= FRAMES_THAT_FIT:
                refused.append(self.name)
                real(self, bytes(data)[:100])  # part of the file got out
                raise OSError(errno.ENOSPC, "No space left on device")
            written.append(self.name)
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", full_disk)
    report = tmp_path / "r.json"
    with caplog.at_level(logging.WARNING):
        code = main(["run", str(SLALOM), "--tree", "none", "--max-time", "3", "--frames", "5",
                     "--report", str(report)])
    assert code == 1  # the run's own verdict: its time limit
    data = json.loads(report.read_text())
    assert data["reason"] == "time limit: 3 s"
    assert len(written) == FRAMES_THAT_FIT and len(refused) == 1  # tried once, then no more
    warnings = [r.getMessage() for r in caplog.records if "cannot save camera frames" in
                r.getMessage()]
    assert len(warnings) == 1 and "No space left on device" in warnings[0]
    frames = tmp_path / "r.frames"
    assert sorted(p.name for p in frames.iterdir()) == sorted(written)  # no half frame
    events = [json.loads(ln) for ln in (tmp_path / "r.events.jsonl").read_text().splitlines()]
    images = [e["image"] for e in events if e["kind"] == "frame" and "image" in e]
    assert [Path(i).name for i in images] == written
    assert events[-1]["kind"] == "end"
