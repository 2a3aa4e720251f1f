"""What the README and the tutorial show of a run is what the run prints: the slalom is
deterministic, so the documented lines are compared with a real run's, word for word (only the
"x real time" figure, which depends on the computer, is left out). And the tutorial writes
nothing outside ``runs/``, which git ignores."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "tutorials" / "first-simulator-run.md"
RUN = "marknav run missions/slalom.yaml --tree none --report runs/tutorial/slalom.json"
SPEED = re.compile(r", [\d.]+x real time\)")
#: Options whose value is a file a command writes.
OUTPUTS = ("--report", "--events", "--plot", "--record", "--save")


def _documented(text: str, first: str) -> list[str]:
    """The lines of the code block whose first line starts with ``first``, from that line."""
    for block in re.findall(r"^```\w*\n(.*?)^```", text, re.S | re.M):
        lines = block.splitlines()
        for k, line in enumerate(lines):
            if line.startswith(first):
                return lines[k:]
    raise AssertionError(f"no block with a line starting {first!r}")


def _same(lines: list[str]) -> list[str]:
    return [SPEED.sub(", …x real time)", ln) for ln in lines]


@pytest.mark.slow  # a whole simulated slalom: seconds
def test_the_documented_slalom_output_is_a_real_runs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "missions").symlink_to(ROOT / "missions")
    (tmp_path / "runs" / "tutorial").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)
    page = TUTORIAL.read_text(encoding="utf-8")
    command = next(ln[2:] for ln in page.splitlines()
                   if ln.startswith(f"$ {RUN}"))
    assert main(shlex.split(command)[1:]) == 0
    printed = capsys.readouterr().out.splitlines()
    tutorial = _documented(page, "slalom: success")
    assert _same(tutorial) == _same(printed), "the tutorial's run output is stale"
    readme = _documented((ROOT / "README.md").read_text(encoding="utf-8"), "slalom: success")
    assert _same(readme) == _same(printed[:len(readme)]), "the README's run output is stale"


def test_the_tutorial_writes_only_under_runs() -> None:
    commands = [shlex.split(ln[2:]) for ln in TUTORIAL.read_text(encoding="utf-8").splitlines()
                if ln.startswith("$ marknav ")]
    written = [words[k + 1] for words in commands for k, w in enumerate(words[:-1])
               if w in OUTPUTS]
    assert len(written) >= 5
    assert all(p.startswith("runs/") for p in written), written
    # a run without --report makes its own folder under runs/ too
    assert all("--report" in words for words in commands if words[1] == "run")
