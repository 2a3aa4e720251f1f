"""The site as a reader gets it: a console block's copy button copies its commands only (no
``$ `` prompt, no output), and nothing is loaded from another host.

Material copies a block's ``innerText`` while it marks the block ``data-md-copying``;
``docs/stylesheets/console.css`` hides the prompt (Pygments' ``.gp``) and the output (``.go``)
then. Here every ``console`` block of the site is highlighted as the site highlights it
(``pymdownx.highlight``), and the text left once those spans are dropped must be exactly the
block's commands, continuation lines included.
"""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import markdown
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
BLOCK = re.compile(r"^```console[^\n]*\n(?P<body>.*?)^```", re.S | re.M)
HIDDEN = {"gp", "go"}


class _Copied(HTMLParser):
    """The text of the ``<code>`` element, without the spans the stylesheet hides."""

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[bool] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        classes = set((dict(attrs).get("class") or "").split())
        self.stack.append(bool(classes & HIDDEN) or bool(self.stack and self.stack[-1]))

    def handle_endtag(self, tag: str) -> None:
        if self.stack:
            self.stack.pop()

    def handle_data(self, data: str) -> None:
        if not (self.stack and self.stack[-1]):
            self.text.append(data)


def _blocks() -> list[tuple[str, str]]:
    out = []
    for page in sorted(DOCS.rglob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in BLOCK.finditer(text):
            where = f"{page.relative_to(DOCS)}:{text.count(chr(10), 0, m.start()) + 1}"
            out.append((where, m["body"]))
    return out


def _commands(body: str) -> str:
    """The block's commands as a reader types them: each ``$ `` line and the lines its
    trailing backslash continues."""
    out, going = [], False
    for line in body.splitlines():
        if line.startswith("$ ") or going:
            out.append(line[2:] if line.startswith("$ ") and not going else line)
            going = line.endswith("\\")
    return "\n".join(out)


def _copied(body: str) -> str:
    html = markdown.markdown(f"```console\n{body}```\n",
                             extensions=["pymdownx.highlight", "pymdownx.superfences"])
    parser = _Copied()
    parser.feed(html)
    return "".join(parser.text).strip("\n")


@pytest.mark.parametrize(("where", "body"), _blocks(), ids=[w for w, _ in _blocks()])
def test_a_console_block_copies_its_commands_only(where: str, body: str) -> None:
    assert _copied(body) == _commands(body), where


def test_the_site_hides_prompts_and_output_while_copying() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8").replace(
        "!!python/name:", ""))
    assert "content.code.copy" in config["theme"]["features"]
    assert "stylesheets/console.css" in config["extra_css"]
    css = (DOCS / "stylesheets" / "console.css").read_text(encoding="utf-8")
    assert re.search(r"\[data-md-copying\] \.gp,\s*\[data-md-copying\] \.go\s*\{\s*"
                     r"display: none;", css)


def test_the_check_sees_a_prompt_that_would_be_copied() -> None:
    body = "$ marknav run slalom\nslalom: success\n"
    assert _copied(body) == "marknav run slalom"
    HIDDEN.discard("gp")
    try:
        assert _copied(body) == "$ marknav run slalom"
    finally:
        HIDDEN.add("gp")


def test_the_site_loads_nothing_from_another_host() -> None:
    """No CDN: every script and stylesheet the site adds is one of its own files (no page has
    mathematics, so no MathJax)."""
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8").replace(
        "!!python/name:", ""))
    added = [*config.get("extra_javascript", []), *config.get("extra_css", [])]
    assert all("//" not in str(a) and (DOCS / str(a)).is_file() for a in added), added
    for page in DOCS.rglob("*.md"):
        text = page.read_text(encoding="utf-8")
        assert "$$" not in text and "\\(" not in text, f"{page}: mathematics needs a renderer"


def test_the_command_line_reference_fits_the_page() -> None:
    """Every line of every ``--help`` block on the CLI reference page fits the text column."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("reference_hook",
                                                  DOCS / "hooks" / "reference.py")
    assert spec is not None and spec.loader is not None
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    page = hook.cli_page()
    blocks = re.findall(r"^```text\n(.*?)^```", page, re.S | re.M)
    assert len(blocks) > 15  # the top-level help and every command's
    wide = [ln for b in blocks for ln in b.splitlines() if len(ln) > hook.HELP_COLUMNS]
    assert not wide, wide[:5]
