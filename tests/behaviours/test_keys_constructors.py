"""SeenMark, KnownMark and Target have hand-written one-step constructors (issue 16: they are
built every frame): these must take exactly the dataclass's fields, with its defaults, so a field
added to the class cannot be silently left out."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from marknav.behaviours import keys


@pytest.mark.parametrize("cls", [keys.SeenMark, keys.KnownMark, keys.Target])
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
