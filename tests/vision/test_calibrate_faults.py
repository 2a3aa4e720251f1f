"""Calibration tables under faults (issue 15, item 14): over-long lines, tables that cannot
be a range law, values out of range, bad CSV, and a spreadsheet's byte-order mark (accepted).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from tests.faultkit import ROOT


@pytest.mark.parametrize(("rows", "message"), [
    ("1," + "9" * 140_000 + "\n", ":2: line too long"),
    ("10,100\n20,200\n40,400\n", "grows with the radius"),
    ("10,1e200\n11,1e100\n12,1\n", ":2: distance_mm: out of range"),
    ("1,100\n1.0000000000000002,200\n1,300\n", "differ by less than 1 %"),
    ('"10,100\n', ":2: expected 2 values, got 1"),
])
def test_bad_calibration_tables(tmp_path: Path, rows: str, message: str,
                                capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.csv"
    table.write_text("radius_px,distance_mm\n" + rows, encoding="utf-8")
    assert main(["calibrate", str(table)]) == 2
    err = capsys.readouterr().err
    assert f"{table}" in err and message in err, err


def test_a_spreadsheet_bom_is_accepted(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.csv"
    text = (ROOT / "tests" / "data" / "paper_table1.csv").read_text(encoding="utf-8")
    table.write_bytes("\ufeff".encode() + text.replace("\n", "\r\n").encode())
    assert main(["calibrate", str(table)]) == 0
    assert "range: {model: power, a: 58957.7, b: -0.943419}" in capsys.readouterr().out
