"""marknav's behaviours as node types of a mission's ``tree:`` section.

:func:`register` adds them to a :class:`marknav.missions.registry.NodeRegistry`, each with a
pydantic model of its ``params``; :func:`marknav.behaviours.catalogue.register`, the target of
marknav's ``marknav.nodes`` entry point, calls it.
Settings left out of ``params`` come from the mission at setup, as in the default tree.

=======================  =====================================================================
type                     what it builds
=======================  =====================================================================
Perception               camera → marks → blackboard (``camera_timeout_s``)
SafetyGuard              FAILURE on fault / e-stop
NotBumped                ``NotBumped?`` condition
BackOff                  reverse after a bump (``distance_mm``, ``speed_mm_s``, ...)
BumpRecovery             Selector(memory=False) of NotBumped and BackOff (BackOff's params)
SelectTarget             ``{colour, waypoint, side?}``
TargetSeen               ``Seen?`` (``lost_after_s``)
TargetLocked             ``Bypassing?`` (``{colour, waypoint}`` or any waypoint)
WaypointPassed           ``Passed?`` (``{colour, waypoint}``)
SearchWhenLost           turn until the target is seen (``turn_speed_deg_s``, ``timeout_s``)
ReturnToSighting         drive back to where the target was seen, turn (``distance_mm``, ...)
AdvanceAlongCourse       drive on along the course, turn (``distance_mm``, ``speed_mm_s``)
Search                   Selector(memory) of Spin, Return, Advance (navigation.search)
VerifyPass               look back at a doubtful pass and decide its side
ApproachWhileCentring    approach keeping the mark centred (``speed_mm_s``, ``steer_gain``, ...)
BezierBypass             plan and track the bypass (``clearance_mm``, ``lookahead_mm``, ...)
Waypoint                 the whole waypoint subtree (``{colour, side?, index?}``)
Route                    one Waypoint per entry of the mission's ``route``
=======================  =====================================================================
"""

from __future__ import annotations

from typing import Literal

from py_trees.behaviour import Behaviour
from pydantic import BaseModel, ConfigDict, Field

from marknav.behaviours.approach import THRESHOLD_SPEED_FRACTION, ApproachWhileCentring
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.perception import DEFAULT_CAMERA_TIMEOUT_S, Perception
from marknav.behaviours.route import bump_recovery, route, search_strategy, waypoint
from marknav.behaviours.safety import BackOff, NotBumped, SafetyGuard
from marknav.behaviours.search import SearchWhenLost
from marknav.behaviours.search_steps import AdvanceAlongCourse, ReturnToSighting
from marknav.behaviours.target import (
    SelectTarget,
    TargetLocked,
    TargetSeen,
    WaypointPassed,
    waypoint_id_for,
)
from marknav.behaviours.verify import VerifyPass
from marknav.core.errors import InputError
from marknav.missions.registry import BuildContext, NodeRegistry, NoParams
from marknav.missions.schema import Mission


def mission_of(context: BuildContext) -> Mission | None:
    """The build context's mission as the schema's :class:`Mission` (``None`` without one)."""
    mission = context.mission
    if mission is not None and not isinstance(mission, Mission):
        raise TypeError(f"BuildContext.mission is a {type(mission).__name__}, not a Mission")
    return mission

__all__ = ["register"]

_FORBID = ConfigDict(extra="forbid")


class PerceptionParams(BaseModel):
    """Read the camera, find and place the marks, write them to the blackboard."""

    model_config = _FORBID
    camera_timeout_s: float = Field(DEFAULT_CAMERA_TIMEOUT_S, gt=0, allow_inf_nan=False,
                                    description="No frame this long: camera lost, abort.")


class BackOffParams(BaseModel):
    """Reverse away from what the bumper hit; abort after too many bumps."""

    model_config = _FORBID
    distance_mm: float = Field(150.0, gt=0, allow_inf_nan=False, description="How far to reverse.")
    speed_mm_s: float = Field(150.0, gt=0, le=500, allow_inf_nan=False,
                              description="Reversing speed.")
    max_duration_s: float = Field(1.5, gt=0, allow_inf_nan=False,
                                  description="Stop reversing after this long.")
    max_recoveries: int | None = Field(None, ge=0, description="Default: "
                                       "safety.max_bump_recoveries.")


class WaypointRef(BaseModel):
    """A route waypoint: its colour and index in the route (0-based)."""

    model_config = _FORBID
    colour: str = Field(min_length=1, description="Route colour of the waypoint.")
    waypoint: int = Field(ge=0, description="Index of the waypoint in the route (0-based).")


class SelectTargetParams(WaypointRef):
    """Make the waypoint's mark the target (nearest visible mark of the colour)."""

    side: Literal["left", "right"] | None = Field(None, description="Default: the colour's side.")


class LockedParams(BaseModel):
    """SUCCESS while the bypass of the waypoint (default: any waypoint) is under way."""

    model_config = _FORBID
    colour: str | None = Field(None, min_length=1, description="Waypoint colour (with waypoint).")
    waypoint: int | None = Field(None, ge=0, description="Waypoint index (with colour).")


class SeenParams(BaseModel):
    """SUCCESS while the target was seen within lost_after_s."""

    model_config = _FORBID
    lost_after_s: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="Default: navigation.lost_after_s.")


class SearchParams(BaseModel):
    """Turn on the spot toward where the target should be until it is seen."""

    model_config = _FORBID
    turn_speed_deg_s: float | None = Field(None, gt=0, allow_inf_nan=False,
                                           description="Default: navigation.search.")
    timeout_s: float | None = Field(None, gt=0, allow_inf_nan=False,
                                    description="Default: navigation.search.")


class SearchStepParams(BaseModel):
    """Drive a leg of a search (back to the last sighting, or on along the course), then turn."""

    model_config = _FORBID
    distance_mm: float | None = Field(None, ge=0, allow_inf_nan=False,
                                      description="Default: navigation.search.")
    speed_mm_s: float | None = Field(None, gt=0, le=500, allow_inf_nan=False,
                                     description="Default: navigation.search.drive_speed_mm_s.")


class PassedParams(WaypointRef):
    """SUCCESS once the waypoint was passed."""

    wait_for_check: bool = Field(False, description="A doubtful pass counts only once a "
                                 "VerifyPass after the bypass has checked it.")


class ApproachParams(BaseModel):
    """Drive toward the target keeping it centred in the image, up to the bypass distance."""

    model_config = _FORBID
    speed_mm_s: float | None = Field(None, gt=0, le=500, allow_inf_nan=False,
                                     description="Default: navigation.approach_speed_mm_s.")
    bypass_distance_mm: float | None = Field(None, gt=0, allow_inf_nan=False,
                                             description="Default: navigation.")
    lost_after_s: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="Default: navigation.")
    steer_gain: float = Field(2.0, gt=0, allow_inf_nan=False,
                              description="Turn rate per radian off-centre, 1/s.")
    max_turn_rate_deg_s: float = Field(60.0, gt=0, allow_inf_nan=False,
                                       description="Cap on the turn rate.")
    slow_band_mm: float = Field(500.0, ge=0, allow_inf_nan=False,
                                description="Slow down over this distance before the threshold.")
    min_speed_fraction: float = Field(THRESHOLD_SPEED_FRACTION, gt=0, le=1,
                                      description="Speed at the threshold / speed_mm_s.")


class BypassParams(BaseModel):
    """Plan the Bézier bypass of the target on its side and track it."""

    model_config = _FORBID
    clearance_mm: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="Default: navigation.clearance_mm.")
    speed_mm_s: float | None = Field(None, gt=0, le=500, allow_inf_nan=False,
                                     description="Default: 0.8 × navigation.approach_speed_mm_s.")
    lookahead_mm: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="Default: navigation.lookahead_mm.")
    replan_ratio: float = Field(0.9, gt=0, le=1, description="Re-plan on a sighting this much "
                                "closer than the one planned from.")
    replan_min_shift_mm: float = Field(10.0, ge=0, allow_inf_nan=False,
                                       description="... that moves the mark by more than this.")


class WaypointParams(BaseModel):
    """One waypoint: pass the mark of a colour (select, search, approach, bypass)."""

    model_config = _FORBID
    colour: str = Field(min_length=1, description="Route colour of the waypoint.")
    side: Literal["left", "right"] | None = Field(None, description="Default: the colour's side.")
    index: int | None = Field(None, ge=0, description="Index in the route (0-based), for "
                              "messages and the report.")


def _check_colour(context: BuildContext, colour: str, type_name: str) -> None:
    mission = mission_of(context)
    if mission is not None and colour not in mission.marks.colours:
        known = ", ".join(mission.marks.colours)
        raise InputError(f"{type_name}: colour {colour!r} is not in marks.colours ({known})")


def _perception(name: str, params: PerceptionParams, _: BuildContext) -> Behaviour:
    return Perception(name, camera_timeout_s=params.camera_timeout_s)


def _safety_guard(name: str, _params: NoParams, _: BuildContext) -> Behaviour:
    return SafetyGuard(name)


def _not_bumped(name: str, _params: NoParams, _: BuildContext) -> Behaviour:
    return NotBumped(name)


def _backoff(name: str, params: BackOffParams) -> BackOff:
    return BackOff(name, distance_mm=params.distance_mm, speed_mm_s=params.speed_mm_s,
                   max_duration_s=params.max_duration_s, max_recoveries=params.max_recoveries)


def _backoff_node(name: str, params: BackOffParams, _: BuildContext) -> Behaviour:
    return _backoff(name, params)


def _bump_recovery(name: str, params: BackOffParams, _: BuildContext) -> Behaviour:
    return bump_recovery(name, backoff=_backoff("BackOff", params))


def _select_target(name: str, params: SelectTargetParams, context: BuildContext) -> Behaviour:
    _check_colour(context, params.colour, "SelectTarget")
    return SelectTarget(name, colour=params.colour, side=params.side, waypoint=params.waypoint)


def _target_seen(name: str, params: SeenParams, _: BuildContext) -> Behaviour:
    return TargetSeen(name, lost_after_s=params.lost_after_s)


def _target_locked(name: str, params: LockedParams, context: BuildContext) -> Behaviour:
    if (params.colour is None) != (params.waypoint is None):
        raise InputError("TargetLocked: give both colour and waypoint, or neither")
    wid = None
    if params.colour is not None and params.waypoint is not None:
        _check_colour(context, params.colour, "TargetLocked")
        wid = waypoint_id_for(params.waypoint, params.colour)
    return TargetLocked(name, waypoint_id=wid)


def _waypoint_passed(name: str, params: PassedParams, context: BuildContext) -> Behaviour:
    _check_colour(context, params.colour, "WaypointPassed")
    return WaypointPassed(name, waypoint_id=waypoint_id_for(params.waypoint, params.colour),
                          wait_for_check=params.wait_for_check)


def _search(name: str, params: SearchParams, _: BuildContext) -> Behaviour:
    return SearchWhenLost(name, turn_speed_deg_s=params.turn_speed_deg_s,
                          timeout_s=params.timeout_s)


def _return_step(name: str, params: SearchStepParams, _: BuildContext) -> Behaviour:
    return ReturnToSighting(name, distance_mm=params.distance_mm, speed_mm_s=params.speed_mm_s)


def _advance_step(name: str, params: SearchStepParams, _: BuildContext) -> Behaviour:
    return AdvanceAlongCourse(name, distance_mm=params.distance_mm, speed_mm_s=params.speed_mm_s)


def _search_strategy(name: str, _params: NoParams, _: BuildContext) -> Behaviour:
    return search_strategy(name)


def _verify(name: str, _params: NoParams, _: BuildContext) -> Behaviour:
    return VerifyPass(name)


def _approach(name: str, params: ApproachParams, _: BuildContext) -> Behaviour:
    return ApproachWhileCentring(
        name, speed_mm_s=params.speed_mm_s, bypass_distance_mm=params.bypass_distance_mm,
        lost_after_s=params.lost_after_s, steer_gain=params.steer_gain,
        max_turn_rate_deg_s=params.max_turn_rate_deg_s, slow_band_mm=params.slow_band_mm,
        min_speed_fraction=params.min_speed_fraction)


def _bypass(name: str, params: BypassParams, _: BuildContext) -> Behaviour:
    return BezierBypass(name, clearance_mm=params.clearance_mm, speed_mm_s=params.speed_mm_s,
                        lookahead_mm=params.lookahead_mm, replan_ratio=params.replan_ratio,
                        replan_min_shift_mm=params.replan_min_shift_mm)


def _waypoint(name: str, params: WaypointParams, context: BuildContext) -> Behaviour:
    _check_colour(context, params.colour, "Waypoint")
    side = params.side
    mission = mission_of(context)
    if side is None and mission is not None:
        side = mission.side_of(params.colour)
    node = waypoint(params.colour, side=side, index=params.index)
    if name != "Waypoint":  # an explicit name from the file
        node.name = name
    return node


def _route(name: str, _params: NoParams, context: BuildContext) -> Behaviour:
    mission = mission_of(context)
    if mission is None:
        raise InputError("Route: needs the mission (its route) to build")
    return route(mission, name=name)


def register(registry: NodeRegistry) -> None:
    """Add marknav's behaviours (see the module docstring) to ``registry``."""
    registry.register("Perception", _perception, PerceptionParams)
    registry.register("SafetyGuard", _safety_guard, NoParams,
                      description="FAILURE (abort) on a fault or e-stop, else SUCCESS.")
    registry.register("NotBumped", _not_bumped, NoParams,
                      description="SUCCESS unless bumped or a bump recovery is under way.")
    registry.register("BackOff", _backoff_node, BackOffParams)
    registry.register("BumpRecovery", _bump_recovery, BackOffParams,
                      description="NotBumped? or BackOff (Selector without memory).")
    registry.register("SelectTarget", _select_target, SelectTargetParams)
    registry.register("TargetSeen", _target_seen, SeenParams)
    registry.register("TargetLocked", _target_locked, LockedParams)
    registry.register("WaypointPassed", _waypoint_passed, PassedParams)
    registry.register("SearchWhenLost", _search, SearchParams)
    registry.register("ReturnToSighting", _return_step, SearchStepParams,
                      description="Face where the target was last seen (or is predicted), "
                      "drive to the range it was seen from, turn once more.")
    registry.register("AdvanceAlongCourse", _advance_step, SearchStepParams,
                      description="Drive on along the course, then turn once more.")
    registry.register("Search", _search_strategy, NoParams,
                      description="Selector(memory=True) of Spin, Return and Advance, with "
                      "navigation.search's settings; the last step's message tells the search.")
    registry.register("VerifyPass", _verify, NoParams,
                      description="After a bypass: look back at a doubtful pass and decide its "
                      "side (navigation.verify_pass).")
    registry.register("ApproachWhileCentring", _approach, ApproachParams)
    registry.register("BezierBypass", _bypass, BypassParams)
    registry.register("Waypoint", _waypoint, WaypointParams)
    registry.register("Route", _route, NoParams,
                      description="One Waypoint per entry of the mission's route, in order.")
