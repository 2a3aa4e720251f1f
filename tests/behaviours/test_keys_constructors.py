"""SeenMark, KnownMark, Target, FrameInfo, Observation and the fake robot's WheelCommand and
DriveRequest have hand-written one-step constructors (issue 16: they are built every frame):
these must take exactly the dataclass's fields, with its defaults, so a field added to the class
cannot be silently left out."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from marknav.behaviours import keys
from marknav.behaviours.perception import Observation
from marknav.testing.robot import DriveRequest, WheelCommand


@pytest.mark.parametrize("cls", [keys.SeenMark, keys.KnownMark, keys.Target, keys.FrameInfo,
                                 Observation, WheelCommand, DriveRequest])
def test_the_constructor_takes_exactly_the_fields(cls: type) -> None:
    params = list(inspect.signature(cls.__init__).parameters.values())[1:]  # without self
    fields = [f for f in dataclasses.fields(cls) if f.init]
    assert [p.name for p in params] == [f.name for f in fields]
    for p, f in zip(params, fields, strict=True):
        expected = inspect.Parameter.empty if f.default is dataclasses.MISSING else f.default
        assert p.default == expected, f.name


def test_instances_stay_frozen_comparable_and_replaceable() -> None:
    mark = keys.SeenMark("red", 300.0, 400.0, 1.0, 2.0, 320.0, 20.0, 640, 0.5)
    assert mark.range_mm == 500.0
    assert mark == keys.SeenMark(colour="red", forward_mm=300.0, left_mm=400.0, world_x=1.0,
                                 world_y=2.0, x_px=320.0, radius_px=20.0, image_width=640, t=0.5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        mark.t = 1.0  # type: ignore[misc]
    assert dataclasses.replace(mark, forward_mm=0.0, left_mm=7.0).range_mm == 7.0
    known = keys.KnownMark("red", 1.0, 2.0, 0.5, 500.0)
    assert (known.seen, known.missed) == (1, 0)
    assert dataclasses.replace(known, missed=2).missed == 2
    target = keys.Target(0, "waypoint-0-red", "red", "left")
    assert (target.sighting, target.world, target.locked, target.remembered) == (
        None, None, False, False)
    assert dataclasses.replace(target, locked=True).locked


def test_frame_records_stay_frozen_and_keep_their_defaults() -> None:
    info = keys.FrameInfo(3, 0.5, 640, 480, 2)
    assert info == keys.FrameInfo(index=3, t=0.5, width=640, height=480, marks=2,
                                  range_sigma=0.0)
    assert dataclasses.replace(info, range_sigma=0.1).range_sigma == 0.1
    obs = Observation(info, ())
    assert obs.pose is None and obs == Observation(frame=info, marks=(), pose=None)
    request = DriveRequest(1.0, "drive", 10.0, 20.0, True)
    command = WheelCommand(1.0, 10, 20)
    for record in (info, obs, request, command):
        with pytest.raises(dataclasses.FrozenInstanceError):
            record.t = 2.0  # type: ignore[misc, union-attr]
    assert request == DriveRequest(t=1.0, kind="drive", left=10.0, right=20.0, accepted=True)
    assert command == WheelCommand(t=1.0, left=10, right=20)
