"""The documentation works as written: its runnable examples run, and the site builds.

A runnable example is a ``console`` block right after a marker comment, in any page under
``docs/``::

    <!-- test: exit=0 -->
    ```console
    $ marknav validate missions/slalom.yaml
    missions/slalom.yaml: ok (...)
    ```

Every line starting with ``$ `` is run by ``bash`` in a folder holding links to the
repository's ``missions/`` and ``tests/`` (so the pages' relative paths work and nothing is
written into the checkout), with ``marknav`` and ``pytest`` meaning this checkout's code; each
must exit with the marker's code. A page's examples share one folder and run in page order, as
a reader would run them (a replay reads the run an earlier example made). Other lines are the
output a reader sees and are not compared. A marker's ``slow`` puts the block under
``@pytest.mark.slow`` (whole simulator runs, seconds each). Blocks without a marker (hardware,
servers, long evaluations) are not run.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
TUTORIALS = ("tutorials/first-simulator-run.md", "tutorials/first-real-run.md")

MARKER = re.compile(r"<!--\s*test:(?P<options>[^>]*)-->")
BLOCK = re.compile(r"[ \t]*\n?```console[ \t]*\n(?P<body>.*?)^```", re.S | re.M)
#: Seconds one command may take (a whole slalom run takes 5-15 s on a 2-core machine).
COMMAND_TIMEOUT_S = 300


@dataclass(frozen=True)
class Example:
    page: str
    line: int
    exit_code: int
    slow: bool
    commands: tuple[str, ...]

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"


def parse_options(text: str, where: str) -> tuple[int, bool]:
    exit_code, slow = None, False
    for word in text.split():
        if word.startswith("exit="):
            exit_code = int(word.removeprefix("exit="))
        elif word == "slow":
            slow = True
        else:
            raise ValueError(f"{where}: unknown option {word!r} in a test marker")
    if exit_code is None:
        raise ValueError(f"{where}: a test marker needs exit=N")
    return exit_code, slow


def examples_in(page: Path) -> list[Example]:
    text = page.read_text(encoding="utf-8")
    rel = page.relative_to(DOCS).as_posix()
    found = []
    for marker in MARKER.finditer(text):
        line = text.count("\n", 0, marker.start()) + 1
        where = f"{rel}:{line}"
        block = BLOCK.match(text, marker.end())
        if block is None:
            raise ValueError(f"{where}: a test marker must be followed by a ```console block")
        commands = tuple(ln[2:] for ln in block["body"].splitlines() if ln.startswith("$ "))
        if not commands:
            raise ValueError(f"{where}: the block has no '$ ' command")
        exit_code, slow = parse_options(marker["options"], where)
        found.append(Example(rel, line, exit_code, slow, commands))
    return found


def all_examples() -> list[Example]:
    return [ex for page in sorted(DOCS.rglob("*.md")) for ex in examples_in(page)]


def _param(ex: Example) -> object:
    return pytest.param(ex, id=ex.id, marks=[pytest.mark.slow] if ex.slow else [])


def _wrapper(folder: Path, name: str, module: str) -> None:
    script = folder / name
    script.write_text(
        "#!/bin/sh\n"
        f'PYTHONPATH="{ROOT}${{PYTHONPATH:+:$PYTHONPATH}}" '
        f'exec "{sys.executable}" -m {module} "$@"\n',
        encoding="utf-8",
    )
    script.chmod(0o755)


Shell = tuple[Path, dict[str, str]]


@pytest.fixture(scope="module")
def docs_shells(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Shell]:
    """One shell per page, made on first use."""
    return {}


def _shell(tmp_path: Path) -> Shell:
    """A working folder like the repository's root, and an environment whose ``marknav`` and
    ``pytest`` run this checkout's code."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    _wrapper(bin_dir, "marknav", "marknav")
    _wrapper(bin_dir, "pytest", "pytest")
    work = tmp_path / "work"
    work.mkdir()
    for name in ("missions", "tests"):
        (work / name).symlink_to(ROOT / name)
    env = dict(os.environ)
    env.update(
        PATH=f"{bin_dir}{os.pathsep}{env.get('PATH', '')}",
        PY_TREES_DISABLE_COLORS="1",
        PYTEST_ADDOPTS="-p no:cacheprovider",
        MPLBACKEND="Agg",
        RERUN_ANALYTICS="0",
        COLUMNS="100",
    )
    env.pop("PYTHONPATH", None)
    return work, env


@pytest.mark.parametrize("example", [_param(ex) for ex in all_examples()])
def test_runnable_example(example: Example, docs_shells: dict[str, Shell],
                          tmp_path_factory: pytest.TempPathFactory) -> None:
    if example.page not in docs_shells:
        docs_shells[example.page] = _shell(tmp_path_factory.mktemp("docs"))
    work, env = docs_shells[example.page]
    for command in example.commands:
        done = subprocess.run(["bash", "-c", command], cwd=work, env=env, capture_output=True,
                              text=True, timeout=COMMAND_TIMEOUT_S)
        assert done.returncode == example.exit_code, (
            f"{example.id}: `{command}` exited {done.returncode}, the page says "
            f"{example.exit_code}\n--- stdout\n{done.stdout[-3000:]}\n--- stderr\n"
            f"{done.stderr[-3000:]}")


def test_each_tutorial_has_runnable_examples() -> None:
    for page in TUTORIALS:
        assert len(examples_in(DOCS / page)) >= 3, page


def test_a_marker_without_its_block_is_an_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                                ) -> None:
    monkeypatch.setattr(sys.modules[__name__], "DOCS", tmp_path)
    page = tmp_path / "p.md"
    page.write_text("text\n<!-- test: exit=0 -->\n```sh\n$ marknav tree m.yaml\n```\n")
    with pytest.raises(ValueError, match=r"p\.md:2: a test marker must be followed"):
        examples_in(page)
    page.write_text("<!-- test: exit=1 slow -->\n```console\n$ a\nout\n$ b\n```\n")
    assert examples_in(page) == [Example("p.md", 1, 1, True, ("a", "b"))]
    page.write_text("<!-- test: slow -->\n```console\n$ a\n```\n")
    with pytest.raises(ValueError, match="needs exit=N"):
        examples_in(page)


def _have(*modules: str) -> bool:
    return all(importlib.util.find_spec(m) is not None for m in modules)


@pytest.mark.skipif(not _have("mkdocs", "material", "mkdocstrings_handlers.python"),
                    reason="needs the docs extra: pip install -e '.[docs]'")
def test_the_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT), NO_MKDOCS_2_WARNING="1")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site"),
         "--config-file", str(ROOT / "mkdocs.yml")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-5000:]
    site = tmp_path / "site"
    cli = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for command in ("marknav run", "marknav evaluate", "marknav serve-robot"):
        assert command in cli
    assert "clearance_mm" in (site / "reference" / "mission-schema" / "index.html").read_text(
        encoding="utf-8")
    assert "FakeRobot" in (site / "reference" / "testing-api" / "index.html").read_text(
        encoding="utf-8")
