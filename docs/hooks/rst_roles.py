"""Griffe extension: marknav's docstrings use reStructuredText roles (``:class:`Name```,
``:func:`~module.name```, ``:data:``, ``:mod:``, ``:meth:``, ``:attr:``); the API reference
renders Markdown, where they would show as raw text. Each role becomes inline code of the name
(``~`` keeps its last part, as Sphinx shows it), and ``::`` closing a line becomes ``:`` (the
indented block after it is already a Markdown code block)."""

from __future__ import annotations

import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:class|func|meth|attr|data|mod|obj|exc):`(~?)([^`]+)`")
_LITERAL = re.compile(r"::[ \t]*$", re.M)


def _name(match: re.Match[str]) -> str:
    tilde, target = match.group(1), match.group(2)
    return f"`{target.rsplit('.', 1)[-1] if tilde else target}`"


def markdown_of(text: str) -> str:
    return _LITERAL.sub(":", _ROLE.sub(_name, text))


class RstRoles(griffe.Extension):
    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown_of(obj.docstring.value)
