"""The JSON Schema of simulator world files (``marknav schema --world``).

Generated from :class:`marknav.sim.world.schema.World` and its sections each time, so a field
added to the model is in the schema at once. Descriptions come from the model itself (a ``Field``'s
``description``, or a ``- ``key``: text`` line of a section's docstring, as ``Conditions`` has),
else from :data:`DESCRIPTIONS` below; the units are in the key names (``_mm``, ``_deg``).
"""

from __future__ import annotations

import re
from typing import Any

from marknav.sim.world import schema as worldmod

#: Descriptions of world keys whose model field carries none, by ``Section.key``.
DESCRIPTIONS: dict[str, str] = {
    "World": "A simulator world (a mission's sim.world, or marknav run --world FILE): marks, "
    "the robot's start, walls and boxes, image and wheel conditions, the background. Units: mm, "
    "degrees only in keys ending in _deg; x east, y north.",
    "World.marks": "The marks: discs standing on the floor, each of one colour of the mission's "
    "palette (a mission run in this world needs a mark of each route colour).",
    "World.robot": "The robot's start pose (default: the origin, facing +y).",
    "World.walls": "Walls, as line segments; the robot's bumper hits them.",
    "World.boxes": "Rectangular obstacles; the robot's bumper hits them.",
    "World.conditions": "Image and wheel conditions: light, colour cast, noise, blur, unequal "
    "wheels, slip, camera latency; camera frame rate, dropped frames, exposure (motion blur, "
    "drift), printed marks' colour; encoders, acceleration, command delay, battery sag.",
    "World.background": "The room behind the marks: a texture seed and distracting clutter.",
    "World.patches": "Friction patches: floor regions where a wheel loses part of its travel "
    "(a rug, a polished or dusty patch); odometry does not see it.",
    "World.events": "Timed faults read through the simulated Create's sensor packets: cliff, "
    "wheel drop, overcurrent, low battery, a held bump.",
    "FrictionPatch.x_mm": "Centre x, mm.",
    "FrictionPatch.y_mm": "Centre y, mm.",
    "FrictionPatch.radius_mm": "Radius of the patch, mm.",
    "FrictionPatch.slip": "Fraction of a wheel's travel lost on the patch (0..1).",
    "FaultEvent.t_s": "Run time at which the fault starts, s.",
    "FaultEvent.fault": "cliff, wheel_drop, overcurrent, low_battery or bump.",
    "FaultEvent.side": "Which sensor: left, right, both (cliff: also front_left, front_right; "
    "both = the two front sensors).",
    "FaultEvent.duration_s": "How long the fault lasts, s; null: to the end of the run.",
    "MarkSpec.colour": "Colour name, one of the mission's marks.colours.",
    "MarkSpec.x_mm": "Centre of the mark, x (east), mm.",
    "MarkSpec.y_mm": "Centre of the mark, y (north), mm.",
    "MarkSpec.yaw_deg": "Turn of the disc's face about the vertical, degrees counter-clockwise; "
    "0: its face looks along -y, toward a robot at the origin facing +y. Absolute (world frame).",
    "MarkSpec.radius_mm": "Radius of this mark, mm; default: the mission's marks.radius_mm.",
    "RobotStart.x_mm": "Start position x, mm.",
    "RobotStart.y_mm": "Start position y, mm.",
    "RobotStart.heading_deg": "Start heading, degrees counter-clockwise from +x (90: facing +y).",
    "Wall.x1_mm": "First end, x, mm.",
    "Wall.y1_mm": "First end, y, mm.",
    "Wall.x2_mm": "Second end, x, mm.",
    "Wall.y2_mm": "Second end, y, mm.",
    "Box.x_mm": "Centre x, mm.",
    "Box.y_mm": "Centre y, mm.",
    "Box.width_mm": "Size along x before turning, mm.",
    "Box.depth_mm": "Size along y before turning, mm.",
    "Box.yaw_deg": "Turn about the centre, degrees counter-clockwise.",
    "Background.seed": "Seed of the room's texture and clutter.",
    "Background.clutter": "Number of non-circular coloured shapes (posters, tape) on the far wall.",
}

_BULLET = re.compile(r"^\s*- ``(?P<key>\w+)``: (?P<text>.*)$")


def _plain(text: str) -> str:
    """reST docstring text as plain one-line prose."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text)
    return " ".join(text.replace("``", "").split())


def _from_docstring(doc: str | None) -> tuple[str, dict[str, str]]:
    """A section docstring's summary and its ``- ``key``: text`` bullets."""
    summary: list[str] = []
    bullets: dict[str, str] = {}
    current: str | None = None
    for line in (doc or "").splitlines():
        m = _BULLET.match(line)
        if m:
            current = m.group("key")
            bullets[current] = m.group("text")
        elif current is not None and line.strip():
            bullets[current] += " " + line.strip()
        elif current is None:
            summary.append(line)
        else:
            current = None
    return _plain("\n".join(summary)), {k: _plain(v) for k, v in bullets.items()}


def world_json_schema() -> dict[str, Any]:
    """JSON Schema (2020-12) of world files, with a description on every key."""
    schema = worldmod.World.model_json_schema()
    sections: dict[str, Any] = {"World": schema, **schema.get("$defs", {})}
    for name, section in sections.items():
        model = getattr(worldmod, name, None)
        summary, bullets = _from_docstring(getattr(model, "__doc__", None))
        summary = DESCRIPTIONS.get(name, summary)
        if summary:
            section["description"] = summary
        for key, prop in section.get("properties", {}).items():
            if "description" in prop:
                continue
            text = bullets.get(key) or DESCRIPTIONS.get(f"{name}.{key}")
            if text:
                prop["description"] = text
    schema["title"] = "marknav simulator world"
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
