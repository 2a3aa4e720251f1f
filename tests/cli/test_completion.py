"""``marknav completion``: scripts generated from the parser; the bash one run in bash."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from marknav.cli.main import main


def _script(shell: str, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["completion", shell]) == 0
    return capsys.readouterr().out


@pytest.mark.skipif(shutil.which("bash") is None, reason="no bash")
@pytest.mark.parametrize(("words", "expected"), [
    (["marknav", "ru"], ["run"]),
    (["marknav", "-v", "tu"], ["tune"]),
    (["marknav", "run", "sla"], ["slalom"]),  # a built-in example's name
    (["marknav", "run", "slalom", "--max-t"], ["--max-time"]),
    (["marknav", "run", "slalom", "--tree", ""], ["auto", "ascii", "unicode", "none"]),
    (["marknav", "bench", ""],
     ["vision", "tree", "loop", "safety", "render", "mujoco", "groot2", "dask", "recording",
      "all"]),
    (["marknav", "completion", "f"], ["fish"]),
])
def test_bash_completes_commands_options_values_and_examples(
        words: list[str], expected: list[str], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    script = tmp_path / "marknav.bash"
    script.write_text(_script("bash", capsys))
    quoted = " ".join(f"'{w}'" for w in words)
    probe = (f"source {script}; COMP_WORDS=({quoted}); COMP_CWORD={len(words) - 1}; "
             'cd "$1"; _marknav; printf "%s\\n" "${COMPREPLY[@]}"')
    empty = tmp_path / "empty"
    empty.mkdir()  # no file names among the answers
    done = subprocess.run(["bash", "-c", probe, "probe", str(empty)], capture_output=True,
                          text=True, timeout=30, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == expected


def test_zsh_and_fish_scripts(capsys: pytest.CaptureFixture[str]) -> None:
    zsh = _script("zsh", capsys)
    assert zsh.startswith("#compdef marknav\n") and "bashcompinit" in zsh
    assert "complete -o filenames -F _marknav marknav" in zsh
    fish = _script("fish", capsys)
    assert ("complete -c marknav -n __fish_use_subcommand -a run -d 'run a mission "
            "(simulator by default)'") in fish
    assert ("complete -c marknav -n '__fish_seen_subcommand_from run' -l tree -r -x -a "
            "'auto ascii unicode none'") in fish
    assert "complete -c marknav -n '__fish_seen_subcommand_from run' -l max-time -r" in fish
    if shutil.which("fish"):
        done = subprocess.run(["fish", "--no-execute", "-c", fish], capture_output=True,
                              text=True, timeout=30, check=False)
        assert done.returncode == 0, done.stderr


def test_an_unknown_shell_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["completion", "tcsh"])
    assert exc.value.code == 2
    assert "usage: marknav completion" in capsys.readouterr().err
