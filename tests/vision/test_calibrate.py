"""Power-law calibration (eq. 19) and ``marknav calibrate``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.vision.calibrate import fit_power_law, fit_table

DATA = Path(__file__).resolve().parents[1] / "data"
TABLE1 = DATA / "paper_table1.csv"


def test_table_1_gives_eq_19() -> None:
    fit = fit_table(TABLE1)
    assert fit.a == pytest.approx(58958, abs=1)
    assert fit.b == pytest.approx(-0.9434, abs=1e-4)
    assert len(fit.rows) == 18
    assert 0.998 < fit.r2 < 1.0
    # The paper's table is noisy at 400 mm (r = 210 px): the worst row, about 5 % off.
    worst = fit.worst_rows(1)[0]
    assert (worst.radius_px, worst.distance_mm, worst.line) == (210, 400, 18)
    assert fit.max_rel_error == pytest.approx(0.0502, abs=5e-4)


def test_exact_power_law_is_recovered_exactly() -> None:
    radii = [20.0, 30.0, 45.0, 80.0, 150.0]
    fit = fit_power_law(radii, [1234.5 * r**-1.02 for r in radii])
    assert fit.a == pytest.approx(1234.5)
    assert fit.b == pytest.approx(-1.02)
    assert fit.r2 == pytest.approx(1.0)
    assert fit.max_rel_error < 1e-9


def test_fit_rejects_degenerate_tables() -> None:
    with pytest.raises(ValueError, match="at least 3 rows"):
        fit_power_law([1, 2], [3, 4])
    with pytest.raises(ValueError, match="all radii are equal"):
        fit_power_law([5, 5, 5], [3, 4, 5])
    with pytest.raises(ValueError, match="positive"):
        fit_power_law([5, -1, 6], [3, 4, 5])


def test_cli_prints_the_mission_snippet(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", str(TABLE1)]) == 0
    out = capsys.readouterr().out
    assert "range: {model: power, a: 58957.7, b: -0.943419}" in out
    assert "line 18: r = 210 px, measured 400 mm" in out


def test_cli_json_keys(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", str(TABLE1), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {"a", "b", "r2", "max_rel_error", "rows"} <= set(data)
    assert round(data["a"]) == 58958
    assert data["rows"][0] == {
        "radius_px": 36.0, "distance_mm": 2000.0, "fitted_mm": pytest.approx(2005.8, abs=0.1),
        "residual_mm": pytest.approx(-5.8, abs=0.1), "rel_error": pytest.approx(0.0029, abs=1e-4),
        "line": 2,
    }


def test_cli_plot(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "fit.png"
    assert main(["calibrate", str(TABLE1), "--plot", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ("radius,dist\n1,2\n",
         ":1: expected the header 'radius_px,distance_mm', got 'radius,dist'"),
        ("radius_px,distance_mm\n36,2000\n38,abc\n40,1800\n",
         ":3: distance_mm: not a number: 'abc'"),
        ("radius_px,distance_mm\n36,2000\n-38,1900\n40,1800\n",
         ":3: radius_px: must be a positive number, got -38"),
        ("radius_px,distance_mm\n36,2000\n38,0\n40,1800\n",
         ":3: distance_mm: must be a positive number, got 0"),
        ("radius_px,distance_mm\n36,2000\n38,1900,7\n", ":3: expected 2 values, got 3"),
        ("radius_px,distance_mm\n36,2000\n38,1900\n", ": need at least 3 rows to fit, got 2"),
        ("", ":1: empty table"),
    ],
)
def test_cli_bad_tables_exit_2_naming_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, expected: str
) -> None:
    table = tmp_path / "t.csv"
    table.write_text(content)
    assert main(["calibrate", str(table)]) == 2
    err = capsys.readouterr().err
    assert f"{table}{expected}" in err
    assert "Traceback" not in err


def test_cli_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope.csv"
    assert main(["calibrate", str(missing)]) == 2
    assert f"{missing}: no such file" in capsys.readouterr().err
