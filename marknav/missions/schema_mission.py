"""The mission as a whole: the ``Mission`` model that gathers the sections, the checks that span
them (route colours defined, a custom tree that fits the route, speeds, clearances and timeouts
consistent with each other, each problem blamed on the field the author most likely has to
change), and what the rest of marknav asks of a loaded mission (its palette, pass sides, the
file position of any field).
"""

from __future__ import annotations

import difflib
import math
import unicodedata
from collections.abc import Iterable
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails

from marknav.core.errors import InputError
from marknav.core.yamlio import Loc, Position, YamlDocument
from marknav.missions.plugins import default_registry
from marknav.missions.registry import NodeRegistry, TreeNode
from marknav.missions.schema_camera import Camera
from marknav.missions.schema_drive import Control, Navigation, Robot, Safety, Sim
from marknav.missions.schema_marks import Marks
from marknav.missions.schema_problems import field_path, problem_detail, raise_problems
from marknav.missions.tree_checks import check_tree
from marknav.vision.palette import ColourRange, Palette

__all__ = ["Mission"]


class Mission(BaseModel):
    """A marknav mission: the route of coloured marks to pass, and how to drive it."""

    model_config = ConfigDict(extra="forbid", title="marknav mission")

    name: str = Field(min_length=1, description="Name of the mission (shown in reports).")
    marks: Marks = Field(description="The marks: their radius, colours and pass sides.")
    route: list[str] = Field(
        min_length=1, description="Marks to pass, in order, by colour name (from marks.colours)."
    )
    robot: Robot = Field(default=Robot(), description="The robot base.")
    camera: Camera = Field(default=Camera(), description="The camera and range model.")
    navigation: Navigation = Field(
        default=Navigation(), description="Approach, bypass and search settings."
    )
    safety: Safety = Field(default=Safety(), description="Safety layer timeouts and limits.")
    control: Control = Field(default=Control(), description="The control loop.")
    sim: Sim | None = Field(default=None, description="Simulator settings: world file and seed.")
    plugins: list[Annotated[str, Field(min_length=1)]] = Field(
        default_factory=list,
        description="Python modules that register node types for tree: (each provides "
        "register(registry)); found on sys.path or in this file's folder. Installed packages "
        "can also register node types through the entry-point group marknav.nodes.",
    )
    tree: TreeNode | None = Field(
        default=None,
        description="A custom behaviour tree built from py_trees composites, decorators and "
        "registered behaviours. Without it the default route tree is used.",
    )

    _document: YamlDocument | None = PrivateAttr(None)
    _source_path: Path | None = PrivateAttr(None)
    _registry: NodeRegistry | None = PrivateAttr(None)
    _overrides: tuple[str, ...] = PrivateAttr(())

    # validation -----------------------------------------------------------------------------

    @field_validator("name")
    @classmethod
    def _name_printable(cls, name: str) -> str:
        # The name is shown on the terminal and names the run folder (made safe there):
        # a NUL, newline or ESC would garble one and the other.
        bad = next((c for c in name if unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp")),
                   None)
        if bad is not None:
            raise ValueError(f"the name contains the control character U+{ord(bad):04X}; "
                             "use printable characters")
        if len(name) > 200:
            raise ValueError(f"the name is {len(name)} characters long; at most 200")
        return name

    @field_validator("route")
    @classmethod
    def _route_colours_exist(cls, route: list[str], info: ValidationInfo) -> list[str]:
        marks = info.data.get("marks")
        if not isinstance(marks, Marks):
            return route  # marks has its own errors
        known = list(marks.colours)
        problems: list[InitErrorDetails] = []
        for i, colour in enumerate(route):
            if colour in marks.colours:
                continue
            close = difflib.get_close_matches(colour, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f" (colours: {', '.join(known)})"
            problems.append(problem_detail(
                "route_colour", f"colour {colour!r} is not defined in marks.colours{hint}",
                (i,), colour,
            ))
        raise_problems("Mission", problems)
        return route

    @field_validator("tree")
    @classmethod
    def _tree_against_route(cls, tree: TreeNode | None, info: ValidationInfo) -> TreeNode | None:
        marks, route = info.data.get("marks"), info.data.get("route")
        if tree is None or not isinstance(marks, Marks) or not isinstance(route, list):
            return tree  # marks or route have their own errors
        context = info.context if isinstance(info.context, dict) else {}
        registry = context.get("registry") or default_registry()
        raise_problems("Mission", check_tree(tree, marks.colours, route, registry))
        return tree

    @model_validator(mode="after")
    def _cross_checks(self) -> Mission:
        nav, robot, marks = self.navigation, self.robot, self.marks
        problems: list[InitErrorDetails] = []

        def blame(*candidates: Loc) -> Loc:
            # The first candidate written in the file; the first of all if none was written.
            return next((loc for loc in candidates if self._written(loc)), candidates[0])

        if nav.approach_speed_mm_s > robot.max_speed_mm_s:
            problems.append(problem_detail(
                "speed_order",
                f"approach_speed_mm_s {nav.approach_speed_mm_s:g} exceeds "
                f"robot.max_speed_mm_s {robot.max_speed_mm_s:g}",
                blame(("navigation", "approach_speed_mm_s"), ("robot", "max_speed_mm_s")),
                nav.approach_speed_mm_s,
            ))
        touch = robot.radius_mm + marks.radius_mm
        if nav.clearance_mm <= touch:
            problems.append(problem_detail(
                "clearance",
                f"clearance_mm {nav.clearance_mm:g} must exceed robot.radius_mm + "
                f"marks.radius_mm = {robot.radius_mm:g} + {marks.radius_mm:g} = {touch:g}: "
                "clearance is robot centre to mark centre, so with less the robot touches the mark",
                blame(("navigation", "clearance_mm"), ("robot", "radius_mm"),
                      ("marks", "radius_mm")),
                nav.clearance_mm,
            ))
        if nav.bypass_distance_mm <= nav.clearance_mm:
            problems.append(problem_detail(
                "bypass_distance",
                f"bypass_distance_mm {nav.bypass_distance_mm:g} must exceed clearance_mm "
                f"{nav.clearance_mm:g}: the bypass starts farther from the mark than it passes it",
                blame(("navigation", "bypass_distance_mm"), ("navigation", "clearance_mm")),
                nav.bypass_distance_mm,
            ))
        turn_wheel = math.radians(nav.search.turn_speed_deg_s) * robot.wheel_base_mm / 2.0
        if turn_wheel > robot.max_speed_mm_s:
            problems.append(problem_detail(
                "turn_speed",
                f"turn_speed_deg_s {nav.search.turn_speed_deg_s:g} needs wheel speeds of "
                f"{turn_wheel:.0f} mm/s (turn rate × wheel_base_mm / 2), more than "
                f"robot.max_speed_mm_s {robot.max_speed_mm_s:g}",
                blame(("navigation", "search", "turn_speed_deg_s"), ("robot", "max_speed_mm_s"),
                      ("robot", "wheel_base_mm")),
                nav.search.turn_speed_deg_s,
            ))
        if nav.search.drive_speed_mm_s > robot.max_speed_mm_s:
            problems.append(problem_detail(
                "search_speed",
                f"search.drive_speed_mm_s {nav.search.drive_speed_mm_s:g} is more than "
                f"robot.max_speed_mm_s {robot.max_speed_mm_s:g}",
                blame(("navigation", "search", "drive_speed_mm_s"), ("robot", "max_speed_mm_s")),
                nav.search.drive_speed_mm_s,
            ))
        min_timeout = 2.0 / self.control.rate_hz
        if self.safety.command_timeout_s < min_timeout:
            problems.append(problem_detail(
                "command_timeout",
                f"command_timeout_s {self.safety.command_timeout_s:g} must be at least two "
                f"control periods (2 / control.rate_hz = {min_timeout:g} s), or the watchdog "
                "stops the wheels between commands",
                blame(("safety", "command_timeout_s"), ("control", "rate_hz")),
                self.safety.command_timeout_s,
            ))
        raise_problems("Mission", problems)
        return self

    def _written(self, loc: Loc) -> bool:
        """Whether the field at ``loc`` was given explicitly (not left to its default)."""
        node: Any = self
        for key in loc:
            if not isinstance(node, BaseModel) or key not in node.model_fields_set:
                return False
            node = getattr(node, str(key))
        return True

    # use ------------------------------------------------------------------------------------

    def palette(self) -> Palette:
        """The mark colours as the detector's palette, in the order they are listed."""
        return tuple(
            ColourRange(name, spec.hue[0], spec.hue[1], sat_min=spec.sat_min, val_min=spec.val_min)
            for name, spec in self.marks.colours.items()
        )

    def side_of(self, colour: str) -> Literal["left", "right"]:
        """The side the robot passes a mark of ``colour`` on."""
        try:
            return self.marks.colours[colour].side
        except KeyError:
            raise KeyError(f"colour {colour!r} is not in the mission's marks.colours") from None

    def route_summary(self) -> str:
        """``red → green → red → blue, 4 waypoints``."""
        n = len(self.route)
        return f"{' → '.join(self.route)}, {n} waypoint{'s' if n != 1 else ''}"

    @property
    def registry(self) -> NodeRegistry:
        """The node types this mission's tree is built from: the default registry plus its
        ``plugins``."""
        return self._registry if self._registry is not None else default_registry()

    @property
    def overrides(self) -> tuple[str, ...]:
        """The ``--set KEY=VALUE`` settings applied on top of the file, as given."""
        return self._overrides

    @property
    def document(self) -> YamlDocument | None:
        """The YAML document the mission was loaded from (positions of every key), if any."""
        return self._document

    @property
    def source_path(self) -> Path | None:
        """The file the mission was loaded from, if any."""
        return self._source_path

    def position(self, loc: Iterable[str | int]) -> Position | None:
        """Where the field at ``loc`` (e.g. ``("route", 2)``) is written, or its nearest
        written ancestor; ``None`` when the mission did not come from a file."""
        return self._document.position(tuple(loc)) if self._document is not None else None

    def input_error(self, loc: Iterable[str | int], message: str) -> InputError:
        """An :class:`InputError` pointing at the field ``loc`` of the mission file."""
        path = tuple(loc)
        pos = self.position(path)
        return InputError(
            message,
            file=self._document.path if self._document is not None else None,
            line=pos.line if pos else None,
            column=pos.column if pos else None,
            field=field_path(path) or None,
        )
