"""How the mission schema reports a problem: as a pydantic error at the field it concerns.

The validators of the mission's sections find problems that span several values (overlapping
hue ranges, a route colour not defined, a clearance smaller than the robot and the mark); each
becomes one error with its own location (:func:`problem_detail`), all of a check raised together
(:func:`raise_problems`), so the loader can point every one at its line. :func:`field_path`
writes a location the way error messages name fields (``route[2]``, ``camera.range.a``), and
:func:`known_key` guards table look-ups with values read from a file.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError
from pydantic_core import InitErrorDetails, PydanticCustomError

from marknav.core.yamlio import Loc

__all__ = ["field_path", "known_key", "problem_detail", "raise_problems"]


def problem_detail(kind: str, message: str, loc: Loc, value: Any) -> InitErrorDetails:
    """One problem of kind ``kind`` at ``loc`` (relative to the model being validated)."""
    return InitErrorDetails(type=PydanticCustomError(kind, message), loc=loc, input=value)


def raise_problems(title: str, problems: list[InitErrorDetails]) -> None:
    """Raise the problems (with their own locations) as one ValidationError, if there are any."""
    if problems:
        raise ValidationError.from_exception_data(title, problems)


def known_key(value: Any, table: Mapping[str, Any]) -> str | None:
    """``value`` if it is one of ``table``'s names, else None. A value from a file is checked
    for its type before it is used as a key (a list there is unhashable: ``TypeError``); what is
    wrong with it is the field's own validation error."""
    return value if isinstance(value, str) and value in table else None


def field_path(loc: Loc) -> str:
    """``loc`` in the notation of error messages: ``route[2]``, ``camera.range.a``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out
