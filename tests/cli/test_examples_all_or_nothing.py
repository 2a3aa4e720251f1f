"""``marknav examples`` copies all or nothing (issue 41, R12): a disk that fills part-way leaves
no file and no folder behind (so a retry is not refused as "would overwrite"); a folder name
the file system cannot take is exit 2 naming it."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path
from typing import Any

import pytest

from marknav.cli.main import main
from marknav.missions.examples import example_files

#: Files that fit before the disk is full.
FILES_THAT_FIT = 3


def test_a_full_disk_part_way_copies_nothing_and_a_retry_works(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    real = shutil.copyfile
    copied: list[str] = []

    def filling(src: Any, dst: Any, **kw: Any) -> Any:
        if len(copied) >= FILES_THAT_FIT:
            Path(dst).write_bytes(b"name: ha")  # part of the file got out
            raise OSError(errno.ENOSPC, "No space left on device")
        copied.append(str(dst))
        return real(src, dst, **kw)

    monkeypatch.setattr(shutil, "copyfile", filling)
    dest = tmp_path / "a" / "ex"
    assert main(["examples", str(dest)]) == 2
    err = capsys.readouterr().err
    assert "No space left on device; nothing was copied" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # not even the folders it made
    monkeypatch.setattr(shutil, "copyfile", real)
    assert main(["examples", str(dest)]) == 0  # the retry, once there is room
    assert sum(1 for p in dest.rglob("*") if p.is_file()) == len(example_files())


@pytest.mark.parametrize("where", ["dest", "inside"])
def test_a_folder_name_too_long_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                          where: str) -> None:
    long = "x" * 300
    dest = tmp_path / long if where == "dest" else tmp_path / "ok" / long / "more"
    assert main(["examples", str(dest)]) == 2
    err = capsys.readouterr().err
    assert "File name too long" in err and long in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
