"""YAML files in, line-numbered errors out.

Missions and worlds are YAML validated by pydantic models. This module loads YAML with PyYAML's
*safe* loader only (so ``!!python/...`` tags are rejected), remembers where every key and value
sits in the file, rejects duplicate keys, and turns pydantic's error locations back into
``FILE:LINE:COLUMN: field.path: message`` — with a did-you-mean for unknown keys.

Files are read through :mod:`marknav.core.inputfile` (regular files only, at most
:data:`~marknav.core.inputfile.MAX_YAML_BYTES`, no control characters), and the document is bounded
before anything is built from it: nesting deeper than :data:`MAX_DEPTH` and more than
:data:`MAX_NODES` nodes once aliases are expanded (an "alias bomb", or an alias inside its own
anchor) are input errors at the line where the limit was crossed.
"""

from __future__ import annotations

import difflib
import re
import sys
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, TypeVar

import yaml
from pydantic import BaseModel, Strict, ValidationError

from marknav.core.errors import InputError, InputErrors, MarknavError
from marknav.core.inputfile import MAX_YAML_BYTES, check_no_control, read_text

Loc = tuple[str | int, ...]
M = TypeVar("M", bound=BaseModel)

#: A number in a schema: an integer or a decimal in the file, never ``true`` or ``"30"`` (which
#: pydantic's lax mode would read as 1 and 30: a quoted value is a mistake to show, not guess).
Number = Annotated[float, Strict()]
#: A whole number in a schema: ``5``, never ``5.0``, ``true`` or ``"5"``.
Integer = Annotated[int, Strict()]

#: Deepest nesting of mappings and sequences accepted (a mission needs about 12, a tree ~40).
MAX_DEPTH = 100
#: Most nodes a document may expand to, counting every alias as a copy of its anchor.
MAX_NODES = 100_000
#: Longest piece of a bad value quoted back in an error message (characters).
_SHOWN_CHARS = 40
#: YAML's names of its scalar tags, as an error message says them.
_KINDS = {"int": "an integer", "float": "a number", "bool": "true or false",
          "timestamp": "a date or time", "null": "null", "binary": "base64 data"}


# A double-quoted scalar can spell control characters as escapes ("\e", "\0", "\x1b"): they
# would reach the terminal and file names. Values may hold TAB and line breaks; keys may not.
_ESCAPED_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u2028\u2029]")
_KEY_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


class _BoundedLoader(yaml.SafeLoader):
    """The safe loader, refusing documents nested deeper than :data:`MAX_DEPTH` while it
    composes them (PyYAML's composer recurses once per level: deep input would otherwise end in
    a RecursionError)."""

    def __init__(self, stream: str, path: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._path = path

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise InputError(f"nested deeper than {MAX_DEPTH} levels", file=self._path,
                                 line=mark.line + 1, column=mark.column + 1)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        """PyYAML's constructors raise plain Python errors for values they cannot build — a
        ValueError for ``2023-02-29`` or an integer over Python's 4,300 digits, a KeyError for
        ``!!bool maybe``, an IndexError for ``!!int ""``, a TypeError for ``!!timestamp abc``
        — with no position: each becomes an input error at the value's own line."""
        try:
            return super().construct_object(node, deep)
        except (yaml.YAMLError, MarknavError):
            raise
        except Exception as exc:  # any constructor failure is bad input
            p = _mark(node)
            value = node.value if isinstance(node, yaml.ScalarNode) else ""
            shown = value if len(value) <= _SHOWN_CHARS else f"{value[:_SHOWN_CHARS]}…"
            kind = node.tag.rsplit(":", 1)[-1]
            why = "" if isinstance(exc, LookupError | TypeError | AttributeError) else str(exc)
            if "limit" in why and kind == "int":  # Python's own bound on int("9" * 5000)
                why = f"over {sys.get_int_max_str_digits():,} digits"
            raise InputError(f"cannot read {shown!r} as {_KINDS.get(kind, kind)}"
                             + (f" ({why})" if why else ""), file=self._path, line=p.line,
                             column=p.column) from None


@dataclass(frozen=True)
class Position:
    line: int  # 1-based
    column: int  # 1-based


@dataclass
class YamlDocument:
    """Parsed YAML data plus the position of every node, keyed by its path."""

    path: str
    data: Any
    positions: dict[Loc, Position]
    key_positions: dict[Loc, Position]

    def position(self, loc: Loc, *, at_key: bool = False) -> Position | None:
        """Position of the node at ``loc``, or of its deepest ancestor that exists in the file.

        ``at_key`` points at the key instead of its value (for unknown keys).
        """
        for n in range(len(loc), -1, -1):
            prefix = tuple(loc[:n])
            if at_key and n == len(loc) and prefix in self.key_positions:
                return self.key_positions[prefix]
            if prefix in self.positions:
                return self.positions[prefix]
        return None


def _mark(node: yaml.Node) -> Position:
    return Position(node.start_mark.line + 1, node.start_mark.column + 1)


def _walk(
    node: yaml.Node,
    loc: Loc,
    positions: dict[Loc, Position],
    key_positions: dict[Loc, Position],
    path: str,
) -> None:
    if len(loc) > MAX_DEPTH:  # only an alias inside its own anchor gets here
        p = _mark(node)
        raise InputError(f"nested deeper than {MAX_DEPTH} levels (an alias inside its own "
                         "anchor?)", file=path, line=p.line, column=p.column)
    if len(positions) >= MAX_NODES:
        p = _mark(node)
        raise InputError(f"the document expands to more than {MAX_NODES} nodes (aliases "
                         "repeating aliases?)", file=path, line=p.line, column=p.column)
    positions[loc] = _mark(node)
    if isinstance(node, yaml.ScalarNode) and _ESCAPED_CONTROL.search(node.value):
        p = _mark(node)
        bad = _ESCAPED_CONTROL.search(node.value)
        assert bad is not None
        raise InputError(f"control character U+{ord(bad.group()):04X} in a string (written as "
                         "an escape); use printable characters", file=path, line=p.line,
                         column=p.column, field=_fmt(loc) or None)
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, Position] = {}
        for key_node, value_node in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else str(key_node.value)
            child: Loc = (*loc, key)
            if key in seen:
                p = _mark(key_node)
                raise InputError(
                    f"duplicate key {key!r} (first at line {seen[key].line})",
                    file=path, line=p.line, column=p.column, field=_fmt(child),
                )
            if isinstance(key, str) and _KEY_CONTROL.search(key):
                p = _mark(key_node)
                raise InputError(f"control character in the key {key!r}", file=path,
                                 line=p.line, column=p.column, field=_fmt(loc) or None)
            seen[key] = _mark(key_node)
            key_positions[child] = _mark(key_node)
            _walk(value_node, child, positions, key_positions, path)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _walk(item, (*loc, i), positions, key_positions, path)


def load_yaml_text(text: str, path: str = "<string>") -> YamlDocument:
    """Parse ``text`` with the safe loader; raise :class:`InputError` with the line on failure."""
    check_no_control(text, path)
    loader = _BoundedLoader(text, path)
    try:
        node = loader.get_single_node()
        if node is None:
            raise InputError("the file is empty", file=path, line=1)
        positions: dict[Loc, Position] = {}
        key_positions: dict[Loc, Position] = {}
        _walk(node, (), positions, key_positions, path)
        data = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = exc.problem or "invalid YAML"
        if exc.context and "constructor" in type(exc).__name__.lower():
            problem = f"{exc.context}; {problem}"
        raise InputError(
            f"{problem} (only plain YAML is accepted: no Python tags)"
            if "tag" in problem else problem,
            file=path,
            line=mark.line + 1 if mark else None,
            column=mark.column + 1 if mark else None,
        ) from None
    except yaml.YAMLError as exc:
        raise InputError(f"invalid YAML: {exc}", file=path) from None
    finally:
        loader.dispose()
    return YamlDocument(path=path, data=data, positions=positions, key_positions=key_positions)


def load_yaml_file(path: str | Path) -> YamlDocument:
    """Read and parse a YAML file; a missing or unreadable file is an :class:`InputError`."""
    text = read_text(path, limit=MAX_YAML_BYTES, what="a YAML file")
    return load_yaml_text(text, str(path))


def _fmt(loc: Loc) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _model_in(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation like ``Foo``, ``Foo | None``, ``list[Foo]``."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    origin = typing.get_origin(annotation)
    if origin is not None or isinstance(annotation, types.UnionType):
        for arg in typing.get_args(annotation):
            found = _model_in(arg)
            if found is not None:
                return found
    return None


def _fields_at(model: type[BaseModel], loc: Loc) -> list[str]:
    """Field names of the model that owns the last element of ``loc``."""
    current: type[BaseModel] | None = model
    for part in loc[:-1]:
        if current is None:
            return []
        if isinstance(part, int):
            continue
        field = current.model_fields.get(str(part))
        if field is None:
            # A dict of models (e.g. colours: {red: {...}}): the key is a user name.
            continue
        current = _model_in(field.annotation)
    if current is None:
        return []
    names: list[str] = []
    for name, info in current.model_fields.items():
        names.append(info.alias or name)
    return names


#: pydantic's errors for a value that is not a number where a :data:`Number` or an
#: :data:`Integer` belongs (strict mode).
_STRICT_NUMBER_ERRORS = {"float_type", "int_type"}


def _strict_number_message(msg: str, value: Any) -> str:
    """Say what was written instead of a number: the YAML reader made it a string or a bool."""
    if isinstance(value, bool):
        return f"{msg}, not {str(value).lower()}"
    if isinstance(value, str):
        shown = value if len(value) <= _SHOWN_CHARS else f"{value[:_SHOWN_CHARS]}…"
        try:
            float(value)
        except ValueError:
            return f"{msg}, not the text {shown!r}"
        return f"{msg}, not the text {shown!r} (write a number without quotes)"
    if isinstance(value, float) and msg.endswith("integer"):
        return f"{msg}, not {value!r}"  # 7.0, not 7: what the file says
    return msg


def validation_errors(
    exc: ValidationError, doc: YamlDocument, model: type[BaseModel]
) -> InputErrors:
    """Map a pydantic :class:`ValidationError` back to file positions, one error per problem."""
    errors: list[InputError] = []
    for err in exc.errors(include_url=False):
        # pydantic adds tagged-union/function tags like "function-after[...]" to locations.
        loc: Loc = tuple(
            p for p in err["loc"] if not (isinstance(p, str) and "[" in p and "]" in p)
        )
        msg = err["msg"]
        if err["type"] == "extra_forbidden" and loc and isinstance(loc[-1], str):
            known = _fields_at(model, loc)
            close = difflib.get_close_matches(str(loc[-1]), known, n=1)
            msg = f"unknown key {loc[-1]!r}" + (f"; did you mean {close[0]!r}?" if close else "")
            if known and not close:
                msg += f" (allowed: {', '.join(sorted(known))})"
        elif msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
        elif err["type"] in _STRICT_NUMBER_ERRORS:
            msg = _strict_number_message(msg, err.get("input"))
        pos = doc.position(loc, at_key=err["type"] == "extra_forbidden")
        errors.append(
            InputError(
                msg,
                file=doc.path,
                line=pos.line if pos else None,
                column=pos.column if pos else None,
                field=_fmt(loc) or None,
            )
        )
    errors.sort(key=lambda e: (e.line or 0, e.column or 0))
    return InputErrors(errors)


def parse_model(doc: YamlDocument, model: type[M]) -> M:
    """Validate a parsed YAML document against ``model``; raise line-numbered errors."""
    try:
        return model.model_validate(doc.data)
    except ValidationError as exc:
        raise validation_errors(exc, doc, model) from None
