"""A custom ``tree:`` checked against the mission's palette and route, before anything is built.

What :func:`check_tree` finds, each at the field to change:

- a node's ``params.colour`` that is not in ``marks.colours`` (any node type whose params have a
  ``colour`` field, plugins' included);
- a route index out of range: a ``Waypoint``'s ``index``, or any node's ``params.waypoint``;
- a colour that is not the route's colour at that index (a purple Waypoint at index 0 of a route
  starting with yellow);
- route waypoints that no node of the tree drives: every route position needs a ``Waypoint`` (or
  a ``SelectTarget``, which the low-level nodes start a waypoint with), unless a ``Route`` node
  drives them all. ``tree: {type: Success}`` would otherwise "succeed" with every waypoint
  pending.

**Derived indices**: a ``Waypoint`` without ``index`` gets the index after the previous Waypoint's
in the tree's depth-first order (the first gets 0), so a tree that lists one Waypoint per route
entry in order needs no indices. The derived index is written into the node's params, so the
report and the tree display number the waypoints.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from typing import Any

from pydantic_core import InitErrorDetails, PydanticCustomError

from marknav.missions.registry import Loc, NodeRegistry, TreeNode

#: Node types that drive one route waypoint, with the params field holding its index.
DRIVES_WAYPOINT: dict[str, str] = {"Waypoint": "index", "SelectTarget": "waypoint"}
#: Node types that drive every waypoint of the route.
DRIVES_ROUTE: frozenset[str] = frozenset({"Route"})


def _problem(kind: str, message: str, loc: Loc, value: Any) -> InitErrorDetails:
    return InitErrorDetails(type=PydanticCustomError(kind, message), loc=loc, input=value)


def _walk(node: TreeNode, loc: Loc = ()) -> list[tuple[TreeNode, Loc]]:
    out = [(node, loc)]
    for i, child in enumerate(node.children or []):
        out.extend(_walk(child, (*loc, "children", i)))
    if node.child is not None:
        out.extend(_walk(node.child, (*loc, "child")))
    return out


def _colour_hint(colour: str, known: Sequence[str]) -> str:
    close = difflib.get_close_matches(colour, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def check_tree(
    tree: TreeNode,
    colours: Mapping[str, Any],
    route: Sequence[str],
    registry: NodeRegistry,
) -> list[InitErrorDetails]:
    """Problems of ``tree`` against the palette (``colours``, by name) and ``route``, located
    relative to the tree. Derives missing Waypoint indices in place (see the module docstring)."""
    problems: list[InitErrorDetails] = []
    known = list(colours)
    covered: set[int] = set()
    drives_all = False
    next_index = 0
    out_of_range = False
    n = len(route)
    for node, loc in _walk(tree):
        if node.type not in registry:
            continue  # reported by the node's own validation
        fields = registry.get(node.type).params_model.model_fields
        params = node.params
        colour = params.get("colour") if "colour" in fields else None
        colour_ok = isinstance(colour, str) and colour in colours
        if isinstance(colour, str) and not colour_ok:
            problems.append(_problem(
                "tree_colour",
                f"colour {colour!r} is not in marks.colours ({', '.join(known)})"
                + _colour_hint(colour, known),
                (*loc, "params", "colour"), colour,
            ))
        if node.type in DRIVES_ROUTE:
            drives_all = True
        index_key = DRIVES_WAYPOINT.get(node.type, "waypoint" if "waypoint" in fields else None)
        if index_key is None or index_key not in fields:
            continue
        index = params.get(index_key)
        derived = False
        if index is None and node.type == "Waypoint":
            index, derived = next_index, True
            params[index_key] = index
        if not isinstance(index, int) or isinstance(index, bool):
            continue  # optional and left out (TargetLocked), or a type error reported elsewhere
        if node.type == "Waypoint":
            next_index = index + 1
        if index >= n:
            out_of_range = True  # the likely reason for an undriven waypoint: say it once
            what = (f"this Waypoint has no index, so it takes the one after the previous "
                    f"Waypoint's: {index}" if derived else f"index {index}")
            problems.append(_problem(
                "route_index",
                f"{what}, but the route has {n} waypoint{'s' if n != 1 else ''} "
                f"(indices 0..{n - 1})",
                (*loc, "params", index_key) if not derived else (*loc, "type"), index,
            ))
            continue
        if node.type in DRIVES_WAYPOINT:
            covered.add(index)
        if colour_ok and route[index] != colour:
            source = (f"index {index} follows from the Waypoints before it" if derived
                      else f"{index_key}: {index}")
            problems.append(_problem(
                "route_colour_order",
                f"{node.type} colour {colour!r}, but route[{index}] is {route[index]!r} "
                f"({source})",
                (*loc, "params", "colour"), colour,
            ))
    can_drive = any(t in registry for t in (*DRIVES_WAYPOINT, *DRIVES_ROUTE))
    if not drives_all and not out_of_range and can_drive:
        # (a registry without marknav's behaviours, as a library user may build, has no way
        # to drive a waypoint: nothing to ask for)
        missing = [i for i in range(n) if i not in covered]
        if len(missing) == n:
            problems.append(_problem(
                "route_not_driven",
                f"the tree drives none of the route's {n} waypoint{'s' if n != 1 else ''} (no "
                "Waypoint, SelectTarget or Route node): the run could only end with every "
                "waypoint pending; add one Waypoint per route entry (indices follow their "
                "order) or a Route node",
                (), None,
            ))
        elif missing:
            listed = ", ".join(f"route[{i}] ({route[i]})" for i in missing)
            problems.append(_problem(
                "route_not_driven",
                f"no node of the tree drives {listed}: add a Waypoint for "
                f"{'each' if len(missing) > 1 else 'it'} (with index:, or in route order), or "
                "shorten the route",
                (), None,
            ))
    return problems
