"""Values PyYAML parses but cannot construct (issue 41, R3) are input errors at their line, on
every path that reads YAML; numbers in the mission schema are strict (no ``true``, no ``"30"``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputError
from marknav.core.yamlio import load_yaml_text

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"
WORLD = ROOT / "missions" / "worlds" / "slalom-world.yaml"

#: (value as written, what the message says)
UNCONSTRUCTIBLE = [
    ("2023-02-29", "cannot read '2023-02-29' as a date or time (day is out of range"),
    ("2023-01-01 25:00:00", "as a date or time (hour must be in 0..23)"),
    ("!!int abc", "cannot read 'abc' as an integer"),
    ('!!int ""', "cannot read '' as an integer"),
    ("!!bool maybe", "cannot read 'maybe' as true or false"),
    ("!!timestamp abc", "cannot read 'abc' as a date or time"),
    ("!!float x", "cannot read 'x' as a number"),
    ("9" * 4301, "as an integer (over 4,300 digits)"),
]


@pytest.mark.parametrize(("value", "message"), UNCONSTRUCTIBLE)
def test_the_loader_names_the_line_and_column(value: str, message: str) -> None:
    with pytest.raises(InputError) as info:
        load_yaml_text(f"a: 1\nb:\n  - c: {value}\n", "f.yaml")
    assert str(info.value).startswith("f.yaml:3:8: ")
    assert message in str(info.value)


def _mission_with(tmp_path: Path, line: str, value: str) -> Path:
    text = SLALOM.read_text(encoding="utf-8").replace("world: worlds/",
                                                      f"world: {SLALOM.parent}/worlds/")
    out = [f"{ln.split(':', 1)[0]}: {value}" if ln.startswith(line) else ln
           for ln in text.splitlines()]
    path = tmp_path / "m.yaml"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(("value", "message"), UNCONSTRUCTIBLE)
def test_every_command_reading_yaml_exits_2_at_the_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, message: str) -> None:
    mission = _mission_with(tmp_path, "name:", value)
    line = next(n for n, ln in enumerate(mission.read_text().splitlines(), 1)
                if ln.startswith("name:"))
    world = tmp_path / "w.yaml"
    world.write_text(f"conditions:\n  encoder_scale: {value}\n", encoding="utf-8")
    for argv, where in [
        (["validate", str(mission)], f"{mission}:{line}:"),
        (["run", str(mission), "--max-time", "1"], f"{mission}:{line}:"),
        (["evaluate", str(mission), "--runs", "1"], f"{mission}:{line}:"),
        (["palette", "--check", str(mission)], f"{mission}:{line}:"),
        (["run", str(SLALOM), "--set", f"name={value}"], "--set: the value of name"),
        (["run", str(SLALOM), "--world", str(world), "--max-time", "1"], f"{world}:2:"),
        (["calibrate-odometry", str(SLALOM), "--world", str(world)], f"{world}:2:"),
    ]:
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2, (argv, err)
        assert where in err and message in err, (argv, err)
        assert "Traceback" not in err


@pytest.mark.parametrize(("value", "message"), [
    ("true", "Input should be a valid number, not true"),
    ('"30"', "Input should be a valid number, not the text '30' (write a number without quotes)"),
    ("fast", "Input should be a valid number, not the text 'fast'"),
])
def test_a_number_is_a_number(tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str,
                              message: str) -> None:
    mission = _mission_with(tmp_path, "  rate_hz:", value)
    assert main(["validate", str(mission)]) == 2
    assert f"control.rate_hz: {message}" in capsys.readouterr().err


def test_a_whole_number_is_whole(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = _mission_with(tmp_path, "  max_bump_recoveries:", "2.5")
    assert main(["validate", str(mission)]) == 2
    assert ("safety.max_bump_recoveries: Input should be a valid integer, not 2.5"
            in capsys.readouterr().err)
