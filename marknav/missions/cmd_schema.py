"""``marknav schema``: print the JSON Schema of mission files, for editors.

Save it (``marknav schema > mission.schema.json``) and start a mission with
``# yaml-language-server: $schema=mission.schema.json``: editors using the YAML language server
then complete keys, show each key's description and flag wrong values while typing. The schema is
:func:`marknav.missions.schema.mission_json_schema`: the mission model's schema (JSON Schema
2020-12) plus the tree node types registered at the time, with each type's parameters.
"""

from __future__ import annotations

import argparse
import json

from marknav.missions.schema import mission_json_schema


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "schema",
        help="print the JSON Schema of mission files (for editor completion)",
        description="Print the JSON Schema of mission files on stdout. Save it, e.g. "
        "`marknav schema > mission.schema.json`, and start a mission with "
        "`# yaml-language-server: $schema=mission.schema.json` for completion in editors.",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print(json.dumps(mission_json_schema(), indent=2, ensure_ascii=False))
    return 0
