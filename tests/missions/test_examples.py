"""The example missions shipped in the package: the same as the checkout's ``missions/``,
found by name, copied out without overwriting."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputError
from marknav.missions.examples import (
    EXAMPLES_DIR,
    copy_examples,
    example_files,
    example_names,
    mission_path,
)

ROOT_MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def test_the_packaged_examples_are_the_checkouts_missions() -> None:
    root = sorted(p.relative_to(ROOT_MISSIONS) for p in ROOT_MISSIONS.rglob("*.yaml"))
    assert sorted(example_files()) == root
    different = [str(f) for f in root
                 if (EXAMPLES_DIR / f).read_bytes() != (ROOT_MISSIONS / f).read_bytes()]
    # edit missions/ and copy: cp -r missions/* marknav/missions/examples/
    assert different == []
    assert "slalom" in example_names()


def test_a_bare_name_finds_the_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert mission_path("slalom") == str(EXAMPLES_DIR / "slalom.yaml")
    (tmp_path / "slalom").write_text("name: mine\n")
    assert mission_path("slalom") == "slalom"  # a file of that name wins
    assert mission_path("nowhere/mine.yaml") == "nowhere/mine.yaml"  # a path stays a path
    with pytest.raises(InputError, match="slalom is a built-in example"):
        mission_path("nowhere/slalom.yaml")  # ... and a missing example's path says so
    with pytest.raises(InputError) as exc:
        mission_path("slaom")
    assert str(exc.value).startswith("slaom: no such file, and no built-in example of that "
                                     "name; did you mean slalom? examples: figure-eight, ")


def test_unknown_name_exits_2_listing_the_examples(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["tree", "slalom"]) == 0
    assert capsys.readouterr().out.startswith("# slalom: red → green → red → blue")
    assert main(["run", "salom", "--tree", "none"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("marknav run: error: salom: no such file, and no built-in example")
    assert "slalom, zigzag" in err


def test_examples_copies_out_and_never_overwrites(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    dest = tmp_path / "ex"
    assert main(["examples", str(dest)]) == 0
    worlds = len(example_files()) - len(example_names())
    assert f"copied {len(example_names())} missions and {worlds} worlds" in (
        capsys.readouterr().out)
    assert (dest / "slalom.yaml").read_bytes() == (EXAMPLES_DIR / "slalom.yaml").read_bytes()
    assert main(["validate", str(dest / "slalom.yaml")]) == 0  # its world is found beside it
    (dest / "slalom.yaml").write_text("name: edited\n")
    assert main(["examples", str(dest)]) == 2
    assert f"would overwrite {len(example_files())} files" in capsys.readouterr().err
    assert (dest / "slalom.yaml").read_text() == "name: edited\n"
    with pytest.raises(InputError, match="not a folder"):
        copy_examples(dest / "slalom.yaml")
