"""Course checks: does a world fit a mission? One mark per waypoint, of the waypoint's colour
(:func:`check_course`), and every mark's colour in the mission's palette
(:func:`check_against_palette`), and every condition it sets drawn by the engine that runs it
(:func:`check_engine_conditions`). Errors name the world file's line and column."""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from pathlib import Path

from marknav.core.errors import InputError, InputErrors
from marknav.core.yamlio import Position, load_yaml_file
from marknav.sim.world.schema import World
from marknav.vision.palette import ColourRange

__all__ = [
    "BUILTIN_ONLY_CONDITIONS", "check_against_palette", "check_course", "check_engine_conditions",
]


def _error(message: str, where: str | None, pos: Position | None, field: str) -> InputError:
    return InputError(message, file=where, line=pos.line if pos else None,
                      column=pos.column if pos else None, field=field)


def _count_error(world: World, route: Sequence[str], where: str | None) -> InputError | None:
    """The error when the world has too few marks, or a course of the wrong length."""
    pos = world._course_position
    if world.course is None:
        if len(world.marks) < len(route):
            return _error(
                f"the route has {len(route)} waypoints but the world only {len(world.marks)} "
                f"marks: say which mark each waypoint passes with course: [i, ...] (mark "
                f"indices, repeats allowed)", where, pos, "course")
    elif len(world.course) != len(route):
        return _error(
            f"{len(world.course)} entries for a route of {len(route)} waypoints (one mark index "
            f"per waypoint)", where, pos, "course")
    return None


def _colour_errors(world: World, route: Sequence[str], where: str | None) -> list[InputError]:
    """An error for each waypoint whose mark is of another colour."""
    errors: list[InputError] = []
    course = world.course_for(len(route))
    for w, (colour, i) in enumerate(zip(route, course, strict=True)):
        mark = world.marks[i]
        if mark.colour == colour:
            continue
        if world.course is None:
            pos, fld = world._colour_positions.get(i), f"marks[{i}].colour"
            hint = " (the default course is the marks in file order; or give course:)"
        else:
            pos = world._course_item_positions.get(w, world._course_position)
            fld, hint = f"course[{w}]", ""
        errors.append(_error(f"waypoint {w + 1} of the route is {colour!r} but its mark {i} is "
                             f"{mark.colour!r}{hint}", where, pos, fld))
    return errors


def check_course(world: World, route: Sequence[str], file: str | Path | None = None) -> None:
    """Raise :class:`~marknav.core.errors.InputError` if the world's course does not fit the
    route: one mark per waypoint, each of the waypoint's colour (errors name the file and the
    ``course`` line — the ``marks`` line when the world has no ``course`` — or the mark's line for
    a colour)."""
    where = str(file) if file is not None else world.source
    count = _count_error(world, route, where)
    errors = [count] if count is not None else _colour_errors(world, route, where)
    if errors:
        raise InputErrors(errors)


def check_against_palette(
    world: World, palette: Sequence[ColourRange], file: str | Path | None = None
) -> None:
    """Raise :class:`~marknav.core.errors.InputError` (one per offending mark, with the mark's
    line when the world came from a file) if a mark's colour is not in the mission's palette."""
    names = [c.name for c in palette]
    where = str(file) if file is not None else world.source
    errors: list[InputError] = []
    for i, mark in enumerate(world.marks):
        if mark.colour in names:
            continue
        close = difflib.get_close_matches(mark.colour, names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        errors.append(_error(
            f"colour {mark.colour!r} is not in the mission's palette "
            f"({', '.join(sorted(names)) or 'empty'}){hint}",
            where, world._colour_positions.get(i), f"marks[{i}].colour"))
    if errors:
        raise InputErrors(errors)


#: The conditions only the built-in engine draws: its painted room (:mod:`marknav.sim.scenery`).
#: The MuJoCo engine's room is the world's ``mujoco`` section
#: (:class:`marknav.sim.mujoco.scene.MujocoScene`: lamps, textures, occluders, distractors).
#: Every other condition acts in both engines.
BUILTIN_ONLY_CONDITIONS = (
    "floor", "floor_saturation", "wall", "wall_hue", "occluders", "distractors",
)


def check_engine_conditions(world: World, engine: str, file: str | Path | None = None,
                            keys: Sequence[str] | None = None, prefix: str = "conditions"
                            ) -> None:
    """Raise :class:`~marknav.core.errors.InputError` (one per key, at its line in ``file``
    when it is there) when ``engine`` cannot draw a condition the world sets away from its
    default (of ``keys`` only, when given; ``prefix`` is where the conditions sit in ``file``):
    a condition silently ignored would make a run look tested under it when it was not."""
    if engine != "mujoco":
        return
    default = type(world.conditions)()
    where = str(file) if file is not None else world.source
    refused = [key for key in BUILTIN_ONLY_CONDITIONS
               if (keys is None or key in keys)
               and getattr(world.conditions, key) != getattr(default, key)]
    if not refused:
        return
    doc = None
    if where is not None:
        try:
            doc = load_yaml_file(where)
        except InputError:  # not a file (a generated world's name): no lines to give
            doc = None
    errors = []
    for key in refused:
        pos = doc.position((*prefix.split("."), key)) if doc is not None else None
        errors.append(_error(
            f"the MuJoCo engine does not draw the built-in room's {key} (set to "
            f"{getattr(world.conditions, key)!r}): its room is the world's mujoco section; "
            "remove it or use --engine builtin", where, pos, f"{prefix}.{key}"))
    raise InputErrors(errors)
