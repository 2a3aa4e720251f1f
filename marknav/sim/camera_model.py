"""The simulator's camera, defined once.

The simulated camera (:class:`marknav.sim.builtin_camera.CameraConfig`'s defaults), the mission
schema's
camera defaults, ``marknav calibrate --sim`` and the example missions all refer to these values,
and ``tests/sim/test_camera_model.py`` checks that they agree: the range law here is what
``marknav calibrate --sim`` measures (within 0.5 % over 300–2000 mm), and the example missions for
the simulator carry it.

:func:`sim_range_law` is the law a simulator mission without ``camera.range`` uses: this law for
the default camera, scaled for another focal length (the image radius of a mark grows with f).
This module imports nothing heavy: the schema uses it.
"""

from __future__ import annotations

__all__ = ["SIM_FOCAL_PX", "SIM_HEIGHT", "SIM_RANGE_A", "SIM_RANGE_B",
           "SIM_RANGE_MARK_RADIUS_MM", "SIM_WIDTH", "sim_range_law"]

#: Image size and focal length (px) of the simulator's camera (horizontal field of view 57°).
SIM_WIDTH = 640
SIM_HEIGHT = 480
SIM_FOCAL_PX = 590.0
#: d = a · r^b fitted by ``marknav calibrate --sim`` (the paper's Table 1 procedure on the
#: simulator, mark radius 100 mm): the simulator camera's own eq. 19.
SIM_RANGE_A = 59752.0
SIM_RANGE_B = -1.00242
#: The mark radius the law was measured with (the law scales with it: d ∝ R at a given r).
SIM_RANGE_MARK_RADIUS_MM = 100.0


def sim_range_law(focal_px: float = SIM_FOCAL_PX,
                  mark_radius_mm: float = SIM_RANGE_MARK_RADIUS_MM) -> tuple[float, float]:
    """``(a, b)`` of the simulator camera's law for a camera of ``focal_px`` and marks of
    ``mark_radius_mm``: at the same distance the radius is ``k = (focal_px / SIM_FOCAL_PX)·(R /
    100)`` times larger, so d = a·(r / k)^b."""
    if focal_px <= 0 or mark_radius_mm <= 0:
        raise ValueError("focal length and mark radius must be positive")
    k = (focal_px / SIM_FOCAL_PX) * (mark_radius_mm / SIM_RANGE_MARK_RADIUS_MM)
    return SIM_RANGE_A * k ** (-SIM_RANGE_B), SIM_RANGE_B
