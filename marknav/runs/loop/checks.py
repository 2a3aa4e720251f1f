"""One validator: every check ``run`` and ``tree`` make before they start, in one place.

``marknav validate``, ``marknav tree`` and ``marknav run`` all go through :func:`check_mission`,
so whatever ``run`` or ``tree`` would refuse, ``validate`` refuses first, with the same message
and place. ``run`` adds only what needs the hardware (opening the port and the camera).

In order, and all reported together where one does not depend on another:

1. the file: YAML, the mission schema (every key, range and cross-field rule), ``--set``
   settings, ``plugins`` (:func:`marknav.missions.schema.load_mission`), resource limits (the
   camera's pixel budget), and a custom ``tree:`` against the palette and the route
   (:mod:`marknav.missions.tree_checks`, which also derives Waypoint indices);
2. building the tree (each node type's factory with its params: a plugin's own checks);
3. the simulator world, when the mission names one (``sim.world``) or ``run --world FILE`` does:
   its own format, its colours against the mission's palette, a mark of each route colour, and
   the mission's ``marks.radius_mm`` not making its marks overlap;
4. the engine (``--engine``, else ``sim.engine``): every condition the world and the mission's
   ``sim.conditions`` set is one that engine draws
   (:func:`marknav.sim.world.course.check_engine_conditions`); with ``try_engine`` (``validate``),
   for MuJoCo, the world is also built into a MuJoCo model, so whatever MuJoCo would refuse at
   the start of a run is refused here (``run`` builds it anyway, moments later).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from pydantic import ValidationError

from marknav.core.errors import InputError, InputErrors
from marknav.core.inputfile import stat_path
from marknav.core.yamlio import load_yaml_file
from marknav.missions.overrides import Override, apply_overrides, relabel
from marknav.missions.schema import Marks, Mission, Sim, load_mission
from marknav.sim.world.course import check_against_palette, check_course, check_engine_conditions
from marknav.sim.world.schema import Conditions, World, load_world
from marknav.vision.palette import ColourRange

__all__ = ["check_mission", "check_world", "checked_mission", "loaded_mission_problems",
           "read_mission"]


def check_mission(
    path: str | Path,
    overrides: Sequence[Override] = (),
    *,
    world: str | Path | None = None,
    engine: str | None = None,
    try_engine: bool = False,
) -> tuple[Mission | None, list[InputError]]:
    """The mission (``None`` if its file does not load) and every problem found. ``world``
    replaces the mission's ``sim.world`` (``run --world FILE``), ``engine`` its ``sim.engine``
    (``--engine``); ``try_engine`` builds a MuJoCo world's model (step 4)."""
    try:
        mission = read_mission(path, overrides, world=world)
    except InputErrors as exc:
        return None, list(exc.errors)
    except InputError as exc:
        return None, [exc]
    return mission, loaded_mission_problems(mission, overrides, world=world, engine=engine,
                                            try_engine=try_engine)


def read_mission(
    path: str | Path,
    overrides: Sequence[Override] = (),
    *,
    world: str | Path | None = None,
) -> Mission:
    """Step 1 of the checks: the file, its schema, ``--set`` and plugins
    (:func:`~marknav.missions.schema.load_mission`). A file with errors raises them all, with
    the world's own problems where the parts they need are valid. ``run`` has *read* the
    mission once this returns: from then on, whatever happens, it leaves a report."""
    try:
        return load_mission(path, overrides=overrides)
    except InputErrors as exc:
        raise InputErrors(_merge(exc.errors, _world_of_invalid_mission(path, overrides, world))
                          ) from None


def loaded_mission_problems(
    mission: Mission,
    overrides: Sequence[Override] = (),
    *,
    world: str | Path | None = None,
    engine: str | None = None,
    try_engine: bool = False,
) -> list[InputError]:
    """Steps 2 to 4 of the checks, on a mission :func:`read_mission` returned: building the
    tree, the simulator world, and the engine."""
    errors = check_build(mission)
    errors.extend(check_world(mission, world, engine=engine, try_engine=try_engine))
    return relabel(errors, overrides)


def _merge(first: Sequence[InputError], more: Sequence[InputError]) -> list[InputError]:
    seen = {str(e) for e in first}
    return [*first, *(e for e in more if str(e) not in seen)]


def checked_mission(
    path: str | Path,
    overrides: Sequence[Override] = (),
    *,
    world: str | Path | None = None,
) -> Mission:
    """The mission if :func:`check_mission` finds nothing; else :class:`InputErrors` with all."""
    mission, errors = check_mission(path, overrides, world=world)
    if errors:
        raise InputErrors(errors)
    assert mission is not None
    return mission


def check_build(mission: Mission) -> list[InputError]:
    """Problems building the mission's tree (none for the default route tree)."""
    if mission.tree is None:
        return []
    from marknav.behaviours.tree import build_mission_tree

    try:
        build_mission_tree(mission)
    except InputErrors as exc:
        return list(exc.errors)
    except InputError as exc:
        return [exc]
    return []


Locate = Callable[[tuple[str | int, ...], str], InputError]


def check_world(mission: Mission, world: str | Path | None = None, *,
                engine: str | None = None, try_engine: bool = False) -> list[InputError]:
    """Problems of the simulator world the mission would run in (``world``, else its
    ``sim.world``; none of its own when the world is generated) and of the conditions it and
    the mission's ``sim.conditions`` set for ``engine`` (default the mission's ``sim.engine``)."""
    sim = mission.sim if mission.sim is not None else Sim()
    engine = engine if engine is not None else sim.engine
    errors = _condition_problems(sim.conditions, engine, mission.source_path)
    path: Path | None = None
    where: tuple[str, ...] = ()
    if world is not None:
        path = Path(world)
    elif sim.world is not None:
        path, where = sim.world, ("sim", "world")
    if path is not None:
        errors += _world_problems(mission.marks, mission.route, path, where, mission.input_error,
                                  engine=engine, changes=sim.conditions if not errors else None,
                                  try_engine=try_engine)
    return errors


def _condition_problems(changes: dict[str, object], engine: str,
                        source: str | Path | None) -> list[InputError]:
    """The mission's ``sim.conditions`` that ``engine`` does not draw."""
    if not changes:
        return []
    try:
        world = World(conditions=Conditions.model_validate(changes))
        check_engine_conditions(world, engine, source, keys=list(changes),
                                prefix="sim.conditions")
    except InputErrors as exc:
        return list(exc.errors)
    except ValidationError:  # reported with the mission's schema
        return []
    return []


def _engine_builds(world: World, marks: Marks, where: str) -> list[InputError]:
    """What MuJoCo refuses of ``world`` (its model, built without rendering); nothing when
    MuJoCo is not installed (``run`` says so, naming the extra to install)."""
    from marknav.sim.mujoco.gl import import_mujoco
    from marknav.sim.mujoco.model import build_model

    try:
        mj = import_mujoco(rendering=False)
    except InputError:
        return []
    palette = tuple(ColourRange(name, spec.hue[0], spec.hue[1])
                    for name, spec in marks.colours.items())
    built = build_model(world, palette)
    try:
        mj.MjModel.from_xml_string(built.xml, built.assets)
    except ValueError as exc:
        return [InputError(f"MuJoCo cannot build this world: {exc}", file=where)]
    return []


def _world_of_invalid_mission(
    path: str | Path, overrides: Sequence[Override], world: str | Path | None
) -> list[InputError]:
    """The world checks of a mission with errors elsewhere, when the parts they need (marks,
    route, sim.world) are valid on their own: so one round reports the world's problems too."""
    try:
        doc = apply_overrides(load_yaml_file(path), overrides)
    except InputError:
        return []
    data = doc.data if isinstance(doc.data, dict) else {}
    try:
        marks = Marks.model_validate(data.get("marks"))
        sim = Sim.model_validate(data.get("sim") or {})
    except ValidationError:
        return []
    route = data.get("route")
    if not (isinstance(route, list) and route
            and all(isinstance(c, str) and c in marks.colours for c in route)):
        return []

    def locate(loc: tuple[str | int, ...], message: str) -> InputError:
        pos = doc.position(loc)
        field = ""
        for part in loc:
            field += f"[{part}]" if isinstance(part, int) else ("." if field else "") + part
        return InputError(message, file=doc.path, line=pos.line if pos else None,
                          column=pos.column if pos else None, field=field)

    if world is not None:
        return _world_problems(marks, route, Path(world), (), locate, engine=sim.engine)
    if sim.world is None:
        return []
    return _world_problems(marks, route, Path(doc.path).parent / sim.world, ("sim", "world"),
                           locate, engine=sim.engine)


def _world_problems(
    marks: Marks, route: Sequence[str], world_path: Path, where: tuple[str, ...], locate: Locate,
    *, engine: str = "builtin", changes: dict[str, object] | None = None,
    try_engine: bool = False,
) -> list[InputError]:
    try:
        found = stat_path(world_path, field=None if where else "--world") is not None
    except InputError as exc:  # a name too long, a loop of links: at the key that named it
        return [locate(where, f"{exc.message}: {world_path}") if where else exc]
    if not found:  # anything else that is not a world file: the loader says what
        if where:
            return [locate(where, f"no such world file: {world_path}")]
        return [InputError("no such file", file=str(world_path))]
    palette = [ColourRange(name, spec.hue[0], spec.hue[1]) for name, spec in marks.colours.items()]
    errors: list[InputError] = []
    try:
        loaded = load_world(world_path)
    except InputErrors as exc:
        return list(exc.errors)
    except InputError as exc:
        return [exc]
    try:
        check_against_palette(loaded, palette, str(world_path))
    except InputErrors as exc:
        errors.extend(exc.errors)
    except InputError as exc:
        errors.append(exc)
    present = {mark.colour for mark in loaded.marks}
    reported: set[str] = set()
    for i, colour in enumerate(route):
        if colour not in present and colour not in reported:
            reported.add(colour)
            errors.append(locate(("route", i), f"no {colour} mark in the world {world_path}"))
    if not errors:  # the world's course: one mark per waypoint, of the waypoint's colour
        try:
            check_course(loaded, route, str(world_path))
        except InputErrors as exc:
            errors.extend(exc.errors)
        except InputError as exc:
            errors.append(exc)
    try:
        loaded.with_mark_radius(marks.radius_mm)
    except ValidationError as exc:
        detail = exc.errors(include_url=False)[0]["msg"].removeprefix("Value error, ")
        errors.append(locate(
            ("marks", "radius_mm"),
            f"with marks {marks.radius_mm:g} mm in radius, the marks of the world "
            f"{world_path} overlap: {detail}"))
    return errors + _engine_problems(loaded, marks, str(world_path), engine,
                                     changes if try_engine and not errors else None)


def _engine_problems(world: World, marks: Marks, where: str, engine: str,
                     build_with: dict[str, object] | None) -> list[InputError]:
    """The world's conditions ``engine`` does not draw; with ``build_with`` (the mission's
    ``sim.conditions``) and no such condition, what MuJoCo refuses of the world."""
    try:
        check_engine_conditions(world, engine, where)
    except InputErrors as exc:
        return list(exc.errors)
    if engine != "mujoco" or build_with is None:
        return []
    conditions = Conditions.model_validate({**world.conditions.model_dump(), **build_with})
    return _engine_builds(world.model_copy(update={"conditions": conditions}), marks, where)
