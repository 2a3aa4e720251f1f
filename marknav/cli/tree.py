"""``marknav tree``: print a mission's behaviour tree without running it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from marknav.cli.validate import SET_HELP, set_item
from marknav.core.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "tree",
        help="print a mission's behaviour tree without running it",
        description="Build MISSION's tree (its tree: section, or the default route tree) and "
                    "print it, every node, in the notation of the live view and 'marknav "
                    "replay' (the legend line says what the symbols mean); --dot also writes "
                    "it in Graphviz dot format with the same labels.",
    )
    p.add_argument("mission", metavar="MISSION",
                   help="mission YAML file, or the name of a built-in example (slalom)")
    p.add_argument("--dot", metavar="FILE", type=Path,
                   help="also write the tree as Graphviz dot (render with: dot -Tpng FILE)")
    p.add_argument("--tree", default="auto", choices=("auto", "ascii", "unicode"),
                   help="symbols: unicode where the output can show them (default auto), or "
                        "ascii")
    p.add_argument("--unicode", action="store_const", const="unicode", dest="tree",
                   help="same as --tree unicode")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", dest="overrides",
                   type=set_item, help=SET_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.behaviours.tree import build_mission_tree
    from marknav.missions.examples import mission_path
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.loop.checks import checked_mission
    from marknav.runs.records.tree_state import TreeState, dot_tree, legend
    from marknav.runs.views.display import resolve_style

    if args.dot is not None:
        from marknav.core.outputs import check_output_file

        check_output_file(args.dot, option="--dot")  # before the work, not after
    # The same checks as 'marknav validate' (and 'run'): a tree is only drawn for a mission
    # that would run.
    mission = checked_mission(mission_path(args.mission), parse_overrides(args.overrides))
    root = build_mission_tree(mission)
    style = resolve_style(args.tree, sys.stdout)
    route = mission.route_summary()
    print(f"# {mission.name}: {route if style == 'unicode' else route.replace('→', '->')}")
    print(f"# legend: {legend(style)}")
    print(TreeState.of_tree(root).text(style=style, full=True))
    if args.dot is not None:
        try:
            args.dot.write_text(dot_tree(root), encoding="utf-8")
        except OSError as exc:
            raise InputError(f"cannot write: {exc}", file=str(args.dot)) from None
        print(f"# wrote {args.dot} (Graphviz dot; render with: dot -Tpng {args.dot} -o tree.png)")
    return 0
