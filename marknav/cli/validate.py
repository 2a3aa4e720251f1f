"""``marknav validate MISSION...``: check mission files without running them.

Each mission goes through :func:`marknav.runs.loop.checks.check_mission`, the checks ``run`` and
``tree`` make before they start (the schema, ``--set`` settings, plugins, the tree against the
palette and the route, building the tree, the simulator world named by ``sim.world``, and the
conditions it and ``sim.conditions`` set against the engine, ``--engine`` or ``sim.engine``; for
MuJoCo the world's model is built, without rendering, when MuJoCo is installed). Valid
files print ``MISSION: ok (route: red → green → red → blue, 4 waypoints)`` on stdout; problems go
to stderr, one ``FILE:LINE:COLUMN: field: message`` line each, every problem of a file at once.
Exit code 0 if all files are valid, 2 otherwise (design brief, "Commands").
"""

from __future__ import annotations

import argparse
import sys

from marknav.core.errors import EXIT_BAD_INPUT, EXIT_OK, InputError


def set_item(text: str) -> str:
    """The type of ``--set``: ``KEY=VALUE`` in one word, so ``--set a.b 350`` is a usage error
    of the command it was given to (``parse_overrides`` checks the key and the value)."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(
            f"expected KEY=VALUE in one word, got {text!r}: write --set {text}=VALUE "
            "(no spaces around '=')")
    return text


SET_HELP = ("change a mission setting, e.g. --set navigation.clearance_mm=350 (dotted key, YAML "
            "value; repeatable; checked like the file)")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "validate",
        help="check mission files (and their simulator worlds) without running them",
        description="Check mission files with every check 'run' and 'tree' make: every problem "
        "is reported as FILE:LINE:COLUMN: field: message. A mission's sim.world file is checked "
        "too. Exit code 0 when all files are valid, 2 otherwise.",
    )
    p.add_argument("missions", nargs="+", metavar="MISSION",
                   help="mission YAML files (or names of built-in examples)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", dest="overrides",
                   type=set_item, help=SET_HELP)
    p.add_argument("--world", metavar="WORLD",
                   help="check against this simulator world file instead of each mission's "
                        "sim.world (as 'run --world WORLD' would run)")
    p.add_argument("--engine", choices=("builtin", "mujoco"),
                   help="check for this simulator engine (default: each mission's sim.engine): "
                        "conditions the engine does not draw are refused and, for mujoco, the "
                        "world's MuJoCo model is built, as 'run --engine' would")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.missions.examples import mission_path
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.loop.checks import check_mission

    overrides = parse_overrides(args.overrides)
    invalid = 0
    for path in args.missions:
        try:
            mission, errors = check_mission(mission_path(path), overrides, world=args.world,
                                            engine=args.engine, try_engine=True)
        except InputError as exc:
            mission, errors = None, [exc]
        if errors:
            invalid += 1
            for error in errors:
                print(error, file=sys.stderr)
        elif mission is not None:
            print(f"{path}: ok (route: {mission.route_summary()})")
    if invalid:
        total = len(args.missions)
        noun = "file" if total == 1 else "files"
        print(f"marknav validate: {invalid} of {total} mission {noun} invalid", file=sys.stderr)
        return EXIT_BAD_INPUT
    return EXIT_OK
