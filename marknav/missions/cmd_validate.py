"""``marknav validate MISSION...``: check mission files without running them.

Each mission is loaded through :func:`marknav.missions.schema.load_mission` (every problem, with
its file, line, column and field); when it names a simulator world (``sim.world``), the world
file is checked too — its own format, its mark colours against the mission's palette, and that
every colour of the route has at least one mark in it. Valid files print
``MISSION: ok (route: red → green → red → blue, 4 waypoints)`` on stdout; problems go to stderr,
one ``FILE:LINE:COLUMN: field: message`` line each. Exit code 0 if all files are valid, 2
otherwise (design brief, "Commands").
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from types import ModuleType

from marknav.errors import InputError, InputErrors
from marknav.missions.schema import Mission, load_mission

EXIT_OK = 0
EXIT_BAD_INPUT = 2


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "validate",
        help="check mission files (and their simulator worlds) without running them",
        description="Check mission files: every problem is reported as FILE:LINE:COLUMN: field: "
        "message. A mission's sim.world file is checked too. Exit code 0 when all files are "
        "valid, 2 otherwise.",
    )
    p.add_argument("missions", nargs="+", metavar="MISSION", help="mission YAML files")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    invalid = 0
    for path in args.missions:
        mission, errors = check_mission_file(path)
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


def check_mission_file(path: str | Path) -> tuple[Mission | None, list[InputError]]:
    """The loaded mission (``None`` if it does not load) and every problem found."""
    try:
        mission = load_mission(path)
    except InputErrors as exc:
        return None, list(exc.errors)
    except InputError as exc:
        return None, [exc]
    return mission, check_world(mission)


def _world_module() -> ModuleType | None:
    try:
        return importlib.import_module("marknav.sim.world")
    except ModuleNotFoundError as exc:
        if exc.name in ("marknav.sim.world", "marknav.sim"):
            return None
        raise


def check_world(mission: Mission) -> list[InputError]:
    """Problems of the mission's simulator world, if it names one (none otherwise)."""
    if mission.sim is None or mission.sim.world is None:
        return []
    world_path = mission.sim.world
    if not world_path.is_file():
        return [mission.input_error(("sim", "world"), f"no such world file: {world_path}")]
    module = _world_module()
    if module is None:  # the simulator is not installed: the world cannot be checked
        return []
    try:
        world = module.load_world(world_path)
        module.check_against_palette(world, mission.palette(), str(world_path))
    except InputErrors as exc:
        return list(exc.errors)
    except InputError as exc:
        return [exc]
    present = {mark.colour for mark in world.marks}
    errors: list[InputError] = []
    reported: set[str] = set()
    for i, colour in enumerate(mission.route):
        if colour not in present and colour not in reported:
            reported.add(colour)
            errors.append(mission.input_error(
                ("route", i), f"no {colour} mark in the world {world_path}"))
    if not errors:
        try:
            module.check_course(world, mission.route, str(world_path))
        except InputErrors as exc:
            errors.extend(exc.errors)
    return errors
