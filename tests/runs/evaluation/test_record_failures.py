"""``marknav evaluate --record-failures DIR``: each failing seed again, with its recording."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

pytest.importorskip("mcap_ros2")
pytest.importorskip("rosbags")

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"


@pytest.mark.slow
def test_every_failing_seed_gets_a_recording_of_its_own(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = tmp_path / "failures"
    # 3 s of mission time: no run gets through the slalom, every seed fails
    code = main(["evaluate", str(SLALOM), "--runs", "2", "--seed", "4", "--max-time", "3",
                 "--record-failures", str(out)])
    err = capsys.readouterr().err
    assert code == 1, err
    for seed in (4, 5):
        folder = out / f"seed-{seed}"
        assert f"recording of seed {seed}: {folder / 'run.mcap'}" in err
        assert "this time" not in err  # the run again failed as it had: a seed decides a run
        assert sorted(p.name for p in folder.iterdir()) == ["metadata.yaml", "run.mcap"]
        with AnyReader([folder], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as bag:
            counts = Counter(c.topic for c in bag.connections for _ in range(c.msgcount))
        assert counts["/marknav/tree"] == counts["/tf"] > 0


def test_record_failures_needs_a_folder(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    afile = tmp_path / "f.txt"
    afile.write_text("")
    assert main(["evaluate", str(SLALOM), "--runs", "1", "--record-failures", str(afile)]) == 2
    err = capsys.readouterr().err
    assert f"{afile}: --record-failures: is not a folder" in err
