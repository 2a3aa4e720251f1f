"""A minimal valid mission for tests, with overrides (the ``mission_factory`` fixture)."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from marknav.missions.schema import Mission

__all__ = ["BASE_MISSION", "make_mission"]

#: The mission :func:`make_mission` starts from: three colours, the design brief's numbers, a
#: pinhole range model matching :class:`~marknav.testing.FakePerception`'s camera (f = 590 px).
BASE_MISSION: dict[str, Any] = {
    "name": "test",
    "route": ["red", "green", "red"],
    "marks": {
        "radius_mm": 100,
        "colours": {
            "red": {"hue": [170, 10], "side": "left"},
            "green": {"hue": [40, 85], "side": "right"},
            "blue": {"hue": [95, 130], "side": "left"},
        },
    },
    "robot": {"wheel_base_mm": 235, "max_speed_mm_s": 300},
    "camera": {"width": 640, "height": 480, "focal_px": 590,
               "range": {"model": "pinhole", "focal_px": 590}},
    "navigation": {
        "bypass_distance_mm": 800,
        "clearance_mm": 300,
        "approach_speed_mm_s": 250,
        "lost_after_s": 0.5,
        "lookahead_mm": 150,
        "search": {"turn_speed_deg_s": 40, "timeout_s": 15},
    },
    "safety": {"command_timeout_s": 0.3, "sensor_timeout_s": 0.2, "max_bump_recoveries": 2},
    "control": {"rate_hz": 20},
}


def _merge(base: dict[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        # A range model ({model: ...}) is replaced whole: its keys depend on the model.
        if isinstance(value, Mapping) and isinstance(out.get(key), dict) and "model" not in value:
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def make_mission(**overrides: Any) -> Mission:
    """:data:`BASE_MISSION` with ``overrides`` merged in, validated.

    Nested dicts merge key by key, except a dict with a ``model`` key (``camera.range``), which
    replaces the base's whole.

    ``make_mission(route=["blue"], navigation={"clearance_mm": 350})``. Invalid values raise
    pydantic's ``ValidationError``.
    """
    return Mission.model_validate(_merge(BASE_MISSION, overrides))
