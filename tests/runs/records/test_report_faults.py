"""The event log when the disk fills (issue 31): it never keeps half a record, and says why it
stopped.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.faultkit import ENV


def test_the_event_log_never_keeps_half_a_record_when_the_disk_fills(tmp_path: Path) -> None:
    """A file that stops taking bytes in the middle of a record (a full disk; here the file
    size limit, RLIMIT_FSIZE: the write takes what fits, then EFBIG): the log ends with the last
    whole record, and says why it stopped."""
    path = tmp_path / "e.jsonl"
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))\n"
            "from marknav.runs.records.report import EventLog\n"
            f"log = EventLog({str(path)!r})\n"
            "for i in range(100):\n"
            "    log.write(i * 0.05, 'tick', n=i, pad='x' * 37)\n"
            "log.close()\n"
            "print(log.error)\n")
    proc = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "File too large" in proc.stdout
    data = path.read_text()
    assert 0 < len(data) <= 1000 and data.endswith("\n"), data[-80:]
    records = [json.loads(line) for line in data.splitlines()]
    assert [r["n"] for r in records] == list(range(len(records)))
