"""Which intrinsics and which range law a mission's perception uses.

- **Intrinsics**: the mission's ``camera.intrinsics``; else those the camera knows of itself (the
  simulator's camera knows its lens exactly, as if it had been calibrated); else none.
- **Range law**: the mission's ``camera.range`` when written; else the pinhole law of the
  intrinsics' focal length (eq. 18) when the mission has intrinsics; else the camera's own law
  when it knows one (the simulator's: :mod:`marknav.sim.camera_model`); else the schema's default
  (the paper's eq. 19).

A camera "knows itself" by having an ``intrinsics`` property and a ``range_law(R)`` method
(:class:`SelfDescribingCamera`); real cameras do not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

from marknav.vision.estimate import Pinhole, PowerLaw, RangeModel
from marknav.vision.undistort import Intrinsics

if TYPE_CHECKING:
    from marknav.missions.schema_mission import Mission

__all__ = ["SelfDescribingCamera", "as_power_law", "mission_intrinsics", "mission_range_model",
           "range_model_of"]


@runtime_checkable
class SelfDescribingCamera(Protocol):
    """A frame source that knows its own lens and range law (the simulator's camera)."""

    @property
    def intrinsics(self) -> Intrinsics | None: ...

    def range_law(self, mark_radius_mm: float) -> PowerLaw: ...


def mission_intrinsics(mission: Mission, camera: object = None) -> Intrinsics | None:
    """The intrinsics perception undistorts with (see the module doc)."""
    spec = mission.camera.intrinsics
    if spec is not None:
        return Intrinsics(fx=spec.fx, fy=spec.fy, cx=spec.cx, cy=spec.cy, dist=tuple(spec.dist))
    if isinstance(camera, SelfDescribingCamera):
        return camera.intrinsics
    return None


def range_model_of(mission: Mission) -> RangeModel:
    """The mission's ``camera.range`` as an estimation model (eq. 19 power law or eq. 2 pinhole)."""
    spec = mission.camera.range
    if spec.model == "power":
        return PowerLaw(a=spec.a, b=spec.b)
    return Pinhole(focal_px=spec.focal_px, radius_mm=mission.marks.radius_mm)


def mission_range_model(mission: Mission, camera: object = None) -> tuple[RangeModel, str]:
    """The range law to start from and where it came from (for the log and the report)."""
    cam = mission.camera
    if "range" in cam.model_fields_set:
        return range_model_of(mission), "mission camera.range"
    if cam.intrinsics is not None:
        focal = 0.5 * (cam.intrinsics.fx + cam.intrinsics.fy)
        return (Pinhole(focal_px=focal, radius_mm=mission.marks.radius_mm),
                "pinhole law of camera.intrinsics")
    if isinstance(camera, SelfDescribingCamera):
        return (camera.range_law(mission.marks.radius_mm),
                "the simulated camera's own law")
    return range_model_of(mission), "default camera.range (the paper's eq. 19)"


def as_power_law(model: RangeModel) -> PowerLaw | None:
    """A power law equal to ``model`` (a pinhole law is d = f·R·r^-1), if it is one of the two."""
    if isinstance(model, PowerLaw):
        return model
    if isinstance(model, Pinhole):
        return PowerLaw(a=model.focal_px * model.radius_mm, b=-1.0)
    return None
