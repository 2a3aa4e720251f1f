"""``marknav view RUN`` hands a recording (.mcap) to the Rerun viewer."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("rerun")


@pytest.fixture
def launched(monkeypatch: pytest.MonkeyPatch) -> list[list[str]]:
    from marknav.cli import replay

    calls: list[list[str]] = []
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(replay.subprocess, "call",
                        lambda argv, env: calls.append([*argv, env["RERUN_ANALYTICS"]]) or 0)
    return calls


def test_view_opens_the_mcap_file_or_the_one_in_a_run_folder(
        tmp_path: Path, launched: list[list[str]]) -> None:
    from marknav.cli.main import main

    bag = tmp_path / "run.mcap"
    bag.write_bytes(b"\x89MCAP0\r\n")
    assert main(["view", str(bag)]) == 0
    assert main(["view", str(tmp_path)]) == 0  # the run's folder: its recording
    assert [c[1:] for c in launched] == [[str(bag), "0"], [str(bag), "0"]]
    assert Path(launched[0][0]).name == "rerun"


def test_view_of_a_missing_recording_exits_2_naming_it(
        tmp_path: Path, launched: list[list[str]], capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["view", str(tmp_path / "none.mcap")]) == 2
    assert f"{tmp_path / 'none.mcap'}" in capsys.readouterr().err and not launched
