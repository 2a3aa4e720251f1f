"""The smallest mission the closed-loop tests run: one waypoint, a 320×240 camera (quick to
render) and the pinhole range law that matches it; a run takes about a second."""

from __future__ import annotations

from typing import Any

from marknav.testing import BASE_MISSION

TINY: dict[str, Any] = {
    **BASE_MISSION,
    "name": "tiny",
    "route": ["red"],
    "camera": {"width": 320, "height": 240, "focal_px": 295,
               "range": {"model": "pinhole", "focal_px": 295}},
}
