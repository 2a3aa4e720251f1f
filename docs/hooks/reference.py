"""MkDocs hook: the reference pages generated from the code at build time.

Adds three pages to the site, so they can never disagree with the installed marknav:

- ``reference/cli.md``: every command's ``--help``, as ``marknav COMMAND --help`` prints it;
- ``reference/mission-schema.md``: every key of a mission file, from ``marknav schema``
  (:func:`marknav.missions.schema.mission_json_schema`), with the tree node types and their
  ``params``; the raw schema is published beside it as ``reference/mission.schema.json``;
- ``reference/world-schema.md``: every key of a simulator world file, from
  ``marknav schema --world``; raw schema ``reference/world.schema.json``.

The help texts come from the parser itself (:func:`marknav.cli.main.build_parser`), formatted
for an 80-column terminal (:data:`HELP_COLUMNS`), which is what ``python -m marknav COMMAND
--help`` prints with ``COLUMNS=80``.
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files

#: The width the help is wrapped to: Material's text column shows about 80 characters of a code
#: block at its default font size before it scrolls sideways (100 made 198 of 532 lines scroll).
HELP_COLUMNS = 80


@contextmanager
def _columns(width: int) -> Iterator[None]:
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # argparse keeps sub-commands only here
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    raise RuntimeError("marknav's parser has no sub-commands")


def cli_page() -> str:
    from marknav.cli.main import build_parser

    with _columns(HELP_COLUMNS):
        parser = build_parser()
        top = parser.format_help()
        commands = {name: p.format_help() for name, p in _subparsers(parser).items()}
    out = [
        "# Command line",
        "",
        "Generated from the code when this site was built: each block is what "
        "`marknav COMMAND --help` prints.",
        "",
        "Exit codes, for every command: **0** success; **1** the mission (or evaluation) failed "
        "or was aborted, with one line saying why; **2** bad input (usage, an invalid mission, "
        "world or table, an unreadable image or port), with a message naming the file, line and "
        "field; **130** interrupted (Ctrl-C or SIGTERM), after the wheels were stopped and the "
        "port closed.",
        "",
        "## marknav",
        "",
        "```text",
        top.rstrip(),
        "```",
        "",
    ]
    for name, text in commands.items():
        out += [f"## marknav {name}", "", "```text", text.rstrip(), "```", ""]
    return "\n".join(out)


# --- JSON Schema to tables ------------------------------------------------------------------


def _anchor(name: str) -> str:
    return "def-" + name.lower()


def _type(prop: dict[str, Any]) -> str:
    """A short human type for one schema property: ``integer``, ``list of Wall``, ..."""
    if "$ref" in prop:
        name = prop["$ref"].rsplit("/", 1)[-1]
        return f"[{name}](#{_anchor(name)})"
    if "const" in prop:
        return f"`{json.dumps(prop['const'])}`"
    if "enum" in prop:
        return " or ".join(f"`{json.dumps(v)}`" for v in prop["enum"])
    if "anyOf" in prop or "oneOf" in prop:
        options = [o for o in prop.get("anyOf", prop.get("oneOf", []))]
        parts = [_type(o) for o in options if o.get("type") != "null"]
        nullable = any(o.get("type") == "null" for o in options)
        text = " or ".join(parts)
        return f"{text} or null" if nullable else text
    kind = prop.get("type")
    if kind == "array":
        if "prefixItems" in prop:
            return "[" + ", ".join(_type(p) for p in prop["prefixItems"]) + "]"
        items = prop.get("items")
        return f"list of {_type(items)}" if items else "list"
    if isinstance(kind, list):
        return " or ".join(kind)
    if kind == "object" and isinstance(prop.get("additionalProperties"), dict):
        return f"map of {_type(prop['additionalProperties'])}"
    return str(kind) if kind else "any"


_LIMITS = (
    ("minimum", "≥ {}"),
    ("exclusiveMinimum", "> {}"),
    ("maximum", "≤ {}"),
    ("exclusiveMaximum", "< {}"),
    ("minLength", "length ≥ {}"),
    ("maxLength", "length ≤ {}"),
    ("minItems", "≥ {} items"),
    ("maxItems", "≤ {} items"),
    ("pattern", "matches `{}`"),
)


def _limits(prop: dict[str, Any]) -> str:
    found = [fmt.format(prop[key]) for key, fmt in _LIMITS if key in prop]
    for option in prop.get("anyOf", []):
        found += [fmt.format(option[key]) for key, fmt in _LIMITS if key in option]
    return ", ".join(found)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _default(prop: dict[str, Any], required: bool) -> str:
    if required:
        return "**required**"
    if "default" not in prop:
        return ""
    text = json.dumps(prop["default"], ensure_ascii=False)
    if len(text) > 40 and ("$ref" in prop or "anyOf" in prop):
        return "its section's defaults"
    return f"`{_cell(text)}`"


def _meaning(prop: dict[str, Any], defs: dict[str, Any]) -> str:
    """A key's description; for a key that is a section of its own and has none, the first
    sentence of that section's."""
    if prop.get("description"):
        return str(prop["description"])
    refs = [prop.get("$ref", "")] + [p.get("$ref", "") for p in prop.get("anyOf", [])]
    for ref in refs:
        section = defs.get(ref.rsplit("/", 1)[-1]) if ref else None
        if section and section.get("description"):
            first = str(section["description"]).split("\n\n")[0].split(". ")[0].rstrip(".")
            return f"{first} (its section below)."
    return ""


def _table(model: dict[str, Any], defs: dict[str, Any] | None = None) -> list[str]:
    props: dict[str, Any] = model.get("properties", {})
    if not props:
        return ["(no keys)", ""]
    required = set(model.get("required", []))
    rows = ["| key | type | default | limits | meaning |", "|---|---|---|---|---|"]
    for key, prop in props.items():
        rows.append(
            f"| `{key}` | {_cell(_type(prop))} | {_default(prop, key in required)} | "
            f"{_cell(_limits(prop))} | {_cell(_meaning(prop, defs or {}))} |"
        )
    return [*rows, ""]


def _model_section(name: str, model: dict[str, Any], defs: dict[str, Any]) -> list[str]:
    out = [f"### {name} {{#{_anchor(name)}}}", ""]
    if model.get("description"):
        out += [model["description"], ""]
    return out + _table(model, defs)


def _node_types(tree_node: dict[str, Any]) -> list[str]:
    """The ``params`` of each node type, from the schema's if/then conditions on ``type``."""
    out: list[str] = []
    for condition in tree_node.get("allOf", []):
        type_name = condition.get("if", {}).get("properties", {}).get("type", {}).get("const")
        params = condition.get("then", {}).get("properties", {}).get("params")
        if type_name is None or params is None:
            continue
        out += [f"### {type_name}", ""]
        if params.get("description"):
            out += [params["description"], ""]
        out += _table(params)
    return out


def schema_page(schema: dict[str, Any], *, title: str, intro: str, command: str,
                raw_name: str) -> str:
    defs: dict[str, Any] = schema.get("$defs", {})
    out = [
        f"# {title}",
        "",
        intro,
        "",
        f"Generated from `{command}` when this site was built "
        f"(the raw JSON Schema: [{raw_name}]({raw_name})).",
        "",
        "## Top level",
        "",
    ]
    if schema.get("description"):
        out += [schema["description"], ""]
    out += _table(schema, defs)
    out += ["## Sections", ""]
    for name in sorted(defs):
        out += _model_section(name, defs[name], defs)
    if "TreeNode" in defs:
        node_types = _node_types(defs["TreeNode"])
        if node_types:
            out += [
                "## Tree node types",
                "",
                "The `params` each `type:` of a mission's `tree:` takes (types without "
                "parameters are listed under `TreeNode.type`'s examples only).",
                "",
                *node_types,
            ]
    return "\n".join(out)


def _add(files: Files, config: MkDocsConfig, uri: str, content: str) -> None:
    existing = files.get_file_from_path(uri)
    if existing is not None:
        files.remove(existing)
    files.append(File.generated(config, uri, content=content))


def on_files(files: Files, config: MkDocsConfig) -> Files:
    from marknav.missions.schema import mission_json_schema
    from marknav.sim.world.json_schema import world_json_schema

    mission = mission_json_schema(plugins=[])
    world = world_json_schema()
    _add(files, config, "reference/cli.md", cli_page())
    _add(files, config, "reference/mission.schema.json",
         json.dumps(mission, indent=2, ensure_ascii=False))
    _add(files, config, "reference/world.schema.json",
         json.dumps(world, indent=2, ensure_ascii=False))
    _add(files, config, "reference/mission-schema.md", schema_page(
        mission,
        title="Mission file keys",
        intro="Every key a mission file may have, its type, default, limits and meaning. "
        "Units are in the key names (`_mm`, `_s`, `_deg`, `_px`); hues are OpenCV units "
        "0..179. How to write a mission: [Mission files](missions.md).",
        command="marknav schema",
        raw_name="mission.schema.json",
    ))
    _add(files, config, "reference/world-schema.md", schema_page(
        world,
        title="World file keys",
        intro="Every key of a simulator world file (a mission's `sim.world`, or "
        "`marknav run --world FILE`). Units: millimetres; degrees only in keys ending in "
        "`_deg`; x east, y north. How to write a world: [Mission files](missions.md#worlds).",
        command="marknav schema --world",
        raw_name="world.schema.json",
    ))
    return files
