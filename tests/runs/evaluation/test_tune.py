"""``marknav tune`` with a tiny budget: trials evaluated on the same seeds, the best block,
the plot, a resumed study after Ctrl-C, and bad parameters refused (issue 16)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from marknav.cli.main import main
from marknav.runs.evaluation.tune import parse_param
from tests.tiny_mission import TINY

optuna = pytest.importorskip("optuna")

PARAMS = ["--param", "navigation.clearance_mm=280:420",
          "--param", "navigation.bypass_distance_mm=600:900:50"]


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    return path


def _study(folder: Path) -> object:
    return optuna.load_study(study_name="tiny",
                             storage=f"sqlite:///{folder / 'study.sqlite3'}")


@pytest.mark.slow
def test_tune_interrupt_then_resume(tiny: Path, tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "marknav", "tune", str(tiny), *PARAMS, "--runs", "1",
            "--max-time", "20"]
    old = signal.getsignal(signal.SIGINT)
    if old is signal.SIG_IGN:  # an ignored SIGINT is inherited: the child must see Ctrl-C
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        proc = subprocess.Popen([*argv, "--trials", "5"], cwd=tmp_path, stderr=subprocess.PIPE,
                                stdout=subprocess.PIPE, text=True, start_new_session=True,
                                env={**os.environ, "PYTHONUNBUFFERED": "1"})
    finally:
        signal.signal(signal.SIGINT, old)
    assert proc.stderr is not None
    seen = ""
    for line in proc.stderr:
        seen += line
        if "(1/5 complete)" in line:
            break
    else:
        raise AssertionError(seen)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, seen + err
    assert "run the same command again to resume" in err and "Traceback" not in err
    assert err.count("interrupted") == 1, err  # one message, not the CLI's generic one too
    folder = tmp_path / "runs" / "tune-tiny"
    study = _study(folder)
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(complete) == 1

    # The same command (fewer trials wanted in total) resumes: one more trial, same seeds.
    done = subprocess.run([*argv, "--trials", "2"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    study = _study(folder)
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(complete) == 2
    assert "(2/2 complete)" in done.stderr
    # The resumed study drew new values, not the first trial's again.
    assert complete[0].params != complete[1].params
    best = study.best_trial
    block = yaml.safe_load(done.stdout)
    assert block["navigation"]["bypass_distance_mm"] == best.params[
        "navigation.bypass_distance_mm"]
    assert block["navigation"]["clearance_mm"] == round(best.params["navigation.clearance_mm"],
                                                        1)
    assert done.stdout.startswith(f"# marknav tune tiny: best of 2 trials (trial {best.number})")
    assert (folder / "trials.png").stat().st_size > 10_000
    # Each trial's mission is on disk with its values; all trials used the same seed.
    trial = yaml.safe_load((folder / f"trial-{best.number:04d}.yaml").read_text())
    assert trial["navigation"]["clearance_mm"] == best.params["navigation.clearance_mm"]
    # The objective ranks success first: value = (1 − rate)·(runs + 1)·max_time + median.
    for t in complete:
        rate, median = t.user_attrs["success_rate"], t.user_attrs["median_time_s"]
        assert t.value == pytest.approx((1 - rate) * 2 * 20 + median)

    # Complete already: nothing runs. Another parameter space is refused.
    assert main(["tune", str(tiny), *PARAMS, "--runs", "1", "--max-time", "20", "--trials", "2",
                 "--storage", f"sqlite:///{folder / 'study.sqlite3'}"]) == 0
    assert main(["tune", str(tiny), *PARAMS, "--runs", "2", "--max-time", "20", "--trials", "2",
                 "--storage", f"sqlite:///{folder / 'study.sqlite3'}"]) == 2


def test_bad_params_are_input_errors(tiny: Path, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str],
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    for text, message in (
            ("clearance_mm=1:2", "expected KEY=LOW:HIGH"),
            ("navigation.clearance_mm=400:300", "need finite LOW < HIGH"),
            ("navigation.clearance_mm=300:x", "must be numbers"),
            ("navigation.clearance_mm=300:400:500", "STEP must be in"),
    ):
        with pytest.raises(Exception, match=message):
            parse_param(text)
    assert main(["tune", str(tiny), "--param", "navigation.clearance_mm=200:400",
                 "--trials", "1"]) == 2
    err = capsys.readouterr().err
    assert "--param:" in err and "navigation.clearance_mm: clearance_mm 200 must exceed" in err
    assert main(["tune", str(tiny), "--param", "navigation.no_such_mm=1:2",
                 "--trials", "1"]) == 2
    assert "no_such_mm" in capsys.readouterr().err
    assert not list((tmp_path / "runs" / "tune-tiny").glob("trial-*.yaml"))


@pytest.mark.slow
def test_combinations_the_schema_refuses_are_pruned(tiny: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    # Both ends are valid missions, but a bypass distance under the clearance is not.
    assert main(["tune", str(tiny), "--param", "navigation.clearance_mm=280:700",
                 "--param", "navigation.bypass_distance_mm=300:720:10", "--trials", "2",
                 "--runs", "1", "--max-time", "3"]) == 0
    study = _study(tmp_path / "runs" / "tune-tiny")
    states = optuna.trial.TrialState
    complete = [t for t in study.trials if t.state == states.COMPLETE]
    pruned = [t for t in study.trials if t.state == states.PRUNED]
    assert len(complete) == 2
    assert pruned, "sampler seed 0 draws an invalid pair among its first trials"
    for t in pruned:
        assert "must exceed clearance_mm" in t.user_attrs["invalid"]
        assert t.params["navigation.bypass_distance_mm"] <= t.params["navigation.clearance_mm"]
    for t in complete:
        assert t.params["navigation.bypass_distance_mm"] > t.params["navigation.clearance_mm"]
    assert any("is not a valid mission" in r.getMessage() and r.getMessage().endswith("pruned")
               for r in caplog.records)
