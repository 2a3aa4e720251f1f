"""The small points a newcomer trips on: where a calibration plot went, the viewer's hint
without a display, the first lines of ``--help``."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main

DATA = Path(__file__).resolve().parents[1] / "data"


def test_calibrate_says_where_the_plot_went(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "law.png"
    assert main(["calibrate", str(DATA / "paper_table1.csv"), "--plot", str(out)]) == 0
    assert f"# plot: {out}" in capsys.readouterr().out.splitlines()
    assert out.stat().st_size > 0
    # with --json the plot line goes to stderr: stdout stays one JSON document
    assert main(["calibrate", str(DATA / "paper_table1.csv"), "--plot", str(out),
                 "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.out.lstrip().startswith("{") and "plot" not in captured.out
    assert f"# plot: {out}" in captured.err


def test_view_without_a_display_says_where_else_to_open_the_recording(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("rerun")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    recording = tmp_path / "run.mcap"
    recording.write_bytes(b"\x89MCAP0\r\n")
    assert main(["view", str(recording)]) == 2
    err = capsys.readouterr().err
    assert "open the recording where there is one" in err and "--record" not in err, err


def test_help_starts_with_where_to_start(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "Start here: 'marknav run slalom'" in out
    assert "'marknav examples DIR'" in out
    assert "Documentation: the MkDocs site in the source's docs/ folder" in out


def test_run_paces_by_default_and_takes_fast_or_realtime(
        capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import build_parser

    parser = build_parser()
    assert parser.parse_args(["run", "slalom"]).realtime is None  # the live view decides
    assert parser.parse_args(["run", "slalom", "--fast"]).realtime is False
    assert parser.parse_args(["run", "slalom", "--realtime"]).realtime is True
    with pytest.raises(SystemExit) as exc:
        main(["run", "slalom", "--fast", "--realtime"])
    assert exc.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


def test_the_tune_plot_ticks_whole_trial_numbers(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from marknav.runs.evaluation.tune import Param, TrialSummary, TuneResult, plot_trials

    kept: list[object] = []
    monkeypatch.setattr(plt, "close", lambda fig=None: kept.append(fig))
    trials = [TrialSummary(number=n, params={"navigation.clearance_mm": 300.0 + 10 * n},
                           value=40.0 - n, success_rate=1.0, successes=2, runs=2,
                           median_time_s=40.0 - n) for n in range(3)]  # few: quarters before
    result = TuneResult("missions/slalom.yaml", "memory", "t", trials, trials[-1], 3)
    plot_trials(result, [Param("navigation.clearance_mm", 280, 450)], tmp_path / "tune.png")
    fig = kept[0]
    fig.canvas.draw()  # type: ignore[attr-defined]
    ticks = fig.axes[0].get_xticks()  # type: ignore[attr-defined]
    inside = [t for t in ticks if -0.5 <= t <= 2.5]
    assert inside and all(float(t).is_integer() for t in inside), ticks
