"""The mission file: its schema, its checks and loading it with line-numbered errors.

Implements the design brief's "Mission file" section (every key it lists, with its meaning),
plus optional keys with defaults so a minimal mission is ``name``, ``route`` and ``marks``.
Ranges come from the hardware and the paper:

- wheel speeds are limited to ±500 mm/s by the Create Open Interface (Drive/Drive Direct, both
  Create 1 and Create 2 specifications);
- ``camera.range`` is the paper's range model: ``power`` is eq. 19 (d = a·r^b, the fit of Table 1,
  a = 58958, b = −0.9434), ``pinhole`` is eq. 18 in the far-field form d = f·R / r;
- ``navigation.clearance_mm`` is the distance from the robot's centre to the mark's centre while
  passing it, so it must exceed the robot's radius plus the mark's radius.

Loading goes through :mod:`marknav.core.yamlio` (safe loader, duplicate keys rejected, positions of
every node kept). Every problem is reported, as ``FILE:LINE:COLUMN: field.path: message``;
cross-field problems point at the field the author most likely has to change: the one written in
the file, and among those the first listed in each check.

This module is where the rest of marknav imports the mission from; the parts live beside it,
each about one thing: :mod:`~marknav.missions.schema_marks` (``marks``),
:mod:`~marknav.missions.schema_camera` (``camera``), :mod:`~marknav.missions.schema_drive`
(``robot``, ``navigation``, ``safety``, ``control``, ``sim``),
:mod:`~marknav.missions.schema_mission` (the whole mission and its cross-field checks),
:mod:`~marknav.missions.schema_load` (loading, with every problem at its line),
:mod:`~marknav.missions.schema_json` (the JSON Schema for editors) and
:mod:`~marknav.missions.schema_problems` (how a check reports a problem).
"""

from __future__ import annotations

from marknav.missions.schema_camera import (
    MAX_CAMERA_PIXELS,
    MAX_CAMERA_SIDE_PX,
    PAPER_POWER_A,
    PAPER_POWER_B,
    ROBOT_TINT_LIMIT,
    SIM_BYTES_PER_PIXEL,
    Camera,
    CameraIntrinsics,
    DetectSettings,
    PinholeRange,
    PowerRange,
    RangeModel,
)
from marknav.missions.schema_drive import (
    CREATE_MAX_SPEED_MM_S,
    WHEEL_BASE_MM,
    Control,
    Navigation,
    Robot,
    Safety,
    Search,
    Sim,
    VerifyPass,
)
from marknav.missions.schema_json import mission_json_schema
from marknav.missions.schema_load import load_mission, parse_mission
from marknav.missions.schema_marks import ColourName, ColourSpec, Hue, Marks
from marknav.missions.schema_mission import Mission
from marknav.missions.schema_problems import known_key

__all__ = [
    "CREATE_MAX_SPEED_MM_S",
    "MAX_CAMERA_PIXELS",
    "MAX_CAMERA_SIDE_PX",
    "PAPER_POWER_A",
    "PAPER_POWER_B",
    "ROBOT_TINT_LIMIT",
    "SIM_BYTES_PER_PIXEL",
    "WHEEL_BASE_MM",
    "Camera",
    "CameraIntrinsics",
    "ColourName",
    "ColourSpec",
    "Control",
    "DetectSettings",
    "Hue",
    "Marks",
    "Mission",
    "Navigation",
    "PinholeRange",
    "PowerRange",
    "RangeModel",
    "Robot",
    "Safety",
    "Search",
    "Sim",
    "VerifyPass",
    "known_key",
    "load_mission",
    "mission_json_schema",
    "parse_mission",
]
