"""``marknav schema``: print the JSON Schema of mission files (or of world files), for editors.

Save it (``marknav schema > mission.schema.json``) and start a mission with
``# yaml-language-server: $schema=mission.schema.json``: editors using the YAML language server
then complete keys, show each key's description and flag wrong values while typing. The schema is
:func:`marknav.missions.schema.mission_json_schema`: the mission model's schema (JSON Schema
2020-12) plus the tree node types registered at the time — built-ins, installed packages'
``marknav.nodes`` entry points and any ``--plugin`` modules — with each type's parameters.
``--world`` prints the schema of simulator world files instead, generated from the
:class:`marknav.sim.world.World` model (:mod:`marknav.sim.world.json_schema`).
"""

from __future__ import annotations

import argparse
import json

from marknav.core.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "schema",
        help="print the JSON Schema of mission files, or of world files (for editors)",
        description="Print the JSON Schema of mission files on stdout. Save it, e.g. "
        "`marknav schema > mission.schema.json`, and start a mission with "
        "`# yaml-language-server: $schema=mission.schema.json` for completion in editors.",
    )
    p.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                   help="also list the node types this module registers (as a mission's "
                   "plugins: does); repeatable")
    p.add_argument("--world", action="store_true",
                   help="print the schema of simulator world files instead")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.missions.schema import mission_json_schema

    if args.world:
        if args.plugin:
            raise InputError("does not apply with --world", field="--plugin")
        from marknav.sim.world.json_schema import world_json_schema

        schema = world_json_schema()
    else:
        schema = mission_json_schema(plugins=args.plugin)
    print(json.dumps(schema, indent=2, ensure_ascii=False))
    return 0
