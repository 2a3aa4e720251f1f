"""Course checks: does a world fit a mission? One mark per waypoint, of the waypoint's colour
(:func:`check_course`), and every mark's colour in the mission's palette
(:func:`check_against_palette`). Errors name the world file's line and column."""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from pathlib import Path

from marknav.core.errors import InputError, InputErrors
from marknav.core.yamlio import Position
from marknav.sim.world.schema import World
from marknav.vision.palette import ColourRange

__all__ = ["check_against_palette", "check_course"]


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
