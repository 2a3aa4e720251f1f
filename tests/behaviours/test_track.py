"""The target's track, state by state: which state a target is in, the transitions, what a
frame's sighting of it is in each state, and the gate derived from the range estimate's errors."""

from __future__ import annotations

import math

import pytest

from marknav.behaviours import keys
from marknav.behaviours.target import associate, remember, with_sighting
from marknav.behaviours.track import DEFAULT_GATE, RangeGate, TrackState, lock, state_of
from marknav.planning.kinematics import Pose

AHEAD = Pose(0.0, 0.0, math.pi / 2)  # at the origin facing +y


def seen(x: float, y: float, colour: str = "red") -> keys.SeenMark:
    """A 100 mm mark at world (x, y) seen from :data:`AHEAD` (f = 590 px)."""
    return keys.SeenMark(colour=colour, forward_mm=y, left_mm=-x, world_x=x, world_y=y,
                         x_px=0.0, radius_px=590.0 * 100.0 / y, image_width=640, t=0.0)


def target(**kw: object) -> keys.Target:
    base: dict[str, object] = {"waypoint": 0, "waypoint_id": "waypoint-0-red", "colour": "red",
                               "side": "left"}
    base.update(kw)
    return keys.Target(**base)  # type: ignore[arg-type]


def test_the_state_is_read_off_the_target() -> None:
    assert state_of(target()) is TrackState.UNSEEN
    assert state_of(target(locked=True)) is TrackState.UNSEEN  # never seen: nothing to lock
    assert state_of(target(world_x=0.0, world_y=1.0)) is TrackState.FOLLOWING
    assert state_of(target(world_x=0.0, world_y=1.0, remembered=True)) is TrackState.REMEMBERED
    assert state_of(target(world_x=0.0, world_y=1.0, locked=True, remembered=True)) is \
        TrackState.LOCKED


def test_transitions_sighting_lock_and_their_guards() -> None:
    unseen = target()
    following = with_sighting(unseen, seen(0.0, 2000.0))
    assert state_of(following) is TrackState.FOLLOWING
    remembered = target(world_x=0.0, world_y=2000.0, remembered=True)
    assert state_of(with_sighting(remembered, seen(0.0, 1900.0))) is TrackState.FOLLOWING
    locked = lock(remembered)
    assert state_of(locked) is TrackState.LOCKED and not locked.remembered
    assert state_of(lock(following)) is TrackState.LOCKED
    assert state_of(with_sighting(locked, seen(0.0, 1900.0))) is TrackState.LOCKED
    with pytest.raises(ValueError, match="never seen"):
        lock(unseen)


def test_unseen_takes_the_nearest_unpassed_mark_of_its_colour() -> None:
    near, far, blue = seen(0.0, 1500.0), seen(300.0, 3000.0), seen(0.0, 900.0, "blue")
    assert associate([far, blue, near], target()) is near
    passed = [keys.PassedWaypoint(waypoint=0, waypoint_id="w", colour="red", side="left",
                                  t=0.0, mark_x=0.0, mark_y=1500.0)]
    assert associate([far, near], target(), passed) is far


def test_following_gives_way_to_its_own_memory_when_that_is_clearly_nearer() -> None:
    # The target's mark, 1 m ahead-right, left the view; a red 4 m ahead is in view.
    own = seen(600.0, 800.0)
    known = remember((), [own] * 3)
    t = with_sighting(target(), own)
    farther = seen(0.0, 4000.0)
    assert associate([farther], t, (), AHEAD, known) is None
    assert associate([farther], t) is farther  # without the memory: the nearest in view


def test_remembered_waits_until_turned_toward_its_position_then_gates_widely() -> None:
    t = target(world_x=0.0, world_y=2370.0, remembered=True)
    near = seen(0.0, 1900.0)  # 470 mm short of the remembered place
    assert associate([near], t, (), AHEAD) is near  # within 2.5 gates (407 mm)
    turned_away = Pose(0.0, 0.0, math.pi / 2 + math.radians(20.0))
    assert associate([near], t, (), turned_away) is None
    assert associate([seen(0.0, 900.0)], t, (), AHEAD) is None  # 1.47 m off: another mark


def test_locked_keeps_its_mark_and_never_swaps_it_for_a_nearer_one() -> None:
    t = lock(target(world_x=300.0, world_y=900.0))
    own, nearer = seen(320.0, 880.0), seen(-200.0, 600.0)
    assert associate([nearer, own], t) is own
    assert associate([nearer], t) is None
    assert associate([seen(0.0, 1900.0)], lock(target(world_x=0.0, world_y=2370.0))) is None


def test_the_gate_is_the_laws_error_plus_the_radius_error_above_a_floor() -> None:
    gate = RangeGate(law_error=0.2, law_exponent=-1.0, radius_error_px=0.5, floor_mm=250.0)
    assert gate.gate_mm(500.0) == 250.0  # the floor near the mark
    assert gate.gate_mm(3000.0) == pytest.approx(600.0)  # the law's error alone
    assert gate.gate_mm(3000.0, radius_px=20.0) == pytest.approx(3000.0 * (0.2 + 0.025))
    # the paper's eq. 19 (b = -0.9434) weighs the radius error a little less than a pinhole
    paper = RangeGate(law_exponent=-0.9434)
    assert paper.gate_mm(3000.0, 20.0) < DEFAULT_GATE.gate_mm(3000.0, 20.0)
    for bad in ({"law_error": -0.1}, {"law_exponent": 1.0}, {"radius_error_px": -1.0},
                {"floor_mm": -5.0}):
        with pytest.raises(ValueError):
            RangeGate(**bad)  # type: ignore[arg-type]
