"""A mission's behaviour tree: its own ``tree:`` section built from its registry, or the default
route tree (:func:`marknav.behaviours.route.build_route_tree`)."""

from __future__ import annotations

import py_trees

from marknav.behaviours.route import build_route_tree
from marknav.missions.registry import BuildContext, build_tree
from marknav.missions.schema import Mission


def build_mission_tree(mission: Mission) -> py_trees.behaviour.Behaviour:
    """The mission's own ``tree:`` if it has one, else the default route tree."""
    if mission.tree is not None:
        return build_tree(mission.tree, mission.registry, BuildContext(mission=mission))
    return build_route_tree(mission)
