"""Hypothesis over numeric options out of their ranges (issue 41): every one is exit 2 naming
the option, before any run starts — never a traceback, never a run that does not end. CI runs
``MARKNAV_FUZZ_EXAMPLES`` examples (default 20) per option."""

from __future__ import annotations

import os
from datetime import timedelta
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SLALOM = str(ROOT / "missions" / "slalom.yaml")
IMAGE = str(ROOT / "tests" / "data" / "smarties.png")
FUZZ = settings(max_examples=int(os.environ.get("MARKNAV_FUZZ_EXAMPLES", "20")),
                deadline=timedelta(seconds=20),
                suppress_health_check=[HealthCheck.function_scoped_fixture])


def outside(low: float, high: float) -> st.SearchStrategy[str]:
    """Numbers written as a user might, all outside [low, high]: huge, tiny, nan, infinite."""
    return st.one_of(
        st.floats(max_value=low, exclude_max=True).map(repr),
        st.floats(min_value=high, exclude_min=True).map(repr),
        st.sampled_from(["nan", "inf", "-inf", "1e309", "-1e309"]),
        st.integers(min_value=10**20, max_value=10**400).map(str),
    )


def whole_outside(low: int, high: int) -> st.SearchStrategy[str]:
    return st.one_of(st.integers(max_value=low - 1).map(str),
                     st.integers(min_value=high + 1).map(str))


CASES = [
    (["evaluate", SLALOM, "--runs"], whole_outside(1, 100_000), "--runs"),
    (["evaluate", SLALOM, "--runs", "2", "--jobs"], whole_outside(1, 64), "--jobs"),
    (["evaluate", SLALOM, "--runs", "2", "--seed"], whole_outside(0, 2**63 - 3), "--seed"),
    (["calibrate-odometry", SLALOM, "--speed-mm-s"], outside(20, 500), "--speed-mm-s"),
    (["calibrate-odometry", SLALOM, "--distance-mm"], outside(10, 10_000), "--distance-mm"),
    (["calibrate-odometry", SLALOM, "--turn-deg"], outside(0, 3600), "--turn-deg"),
    (["calibrate-odometry", SLALOM, "--seed"], whole_outside(0, 2**63 - 1), "--seed"),
    (["palette", "--camera", IMAGE, "--colours", "red", "--interval"], outside(0, 600),
     "--interval"),
    (["palette", "--camera", IMAGE, "--colours", "red", "--frames"], whole_outside(1, 200),
     "--frames"),
    (["serve-camera", "--camera", IMAGE, "--fps"], outside(0.2, 1000), "--fps"),
    (["calibrate-camera", IMAGE, IMAGE, IMAGE, "--board", "9x6", "--square-mm"],
     outside(0.5, 1000), "--square-mm"),
]


@pytest.mark.parametrize(("argv", "values", "option"), CASES, ids=[c[2] + " " + c[0][0]
                                                                   for c in CASES])
def test_out_of_range_is_exit_2_naming_the_option(
        argv: list[str], values: st.SearchStrategy[str], option: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    @FUZZ
    @given(value=values)
    def check(value: str) -> None:
        code = main([*argv[:-1], f"{argv[-1]}={value}"])  # "=": "-5" is no option
        err = capsys.readouterr().err
        assert code == 2, (value, err)
        assert option in err and "Traceback" not in err, (value, err)

    check()
