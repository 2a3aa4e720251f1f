"""``marknav tree``: print a mission's behaviour tree without running it."""

from __future__ import annotations

import argparse
from pathlib import Path

from marknav.cli.validate import SET_HELP
from marknav.core.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "tree",
        help="print a mission's behaviour tree without running it",
        description="Build MISSION's tree (its tree: section, or the default route tree) and "
                    "print it; --dot also writes it in Graphviz dot format.",
    )
    p.add_argument("mission", metavar="MISSION", help="mission YAML file")
    p.add_argument("--dot", metavar="FILE", type=Path,
                   help="also write the tree as Graphviz dot (render with: dot -Tpng FILE)")
    p.add_argument("--unicode", action="store_true",
                   help="draw with box-drawing lines and a symbol per node kind")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", dest="overrides",
                   help=SET_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import py_trees

    from marknav.behaviours.tree import build_mission_tree
    from marknav.missions.overrides import parse_overrides
    from marknav.missions.tree_display import UNICODE_LEGEND, dot_tree, unicode_tree
    from marknav.runs.checks import checked_mission

    if args.dot is not None:
        from marknav.core.outputs import check_output_file

        check_output_file(args.dot, option="--dot")  # before the work, not after
    # The same checks as 'marknav validate' (and 'run'): a tree is only drawn for a mission
    # that would run.
    mission = checked_mission(args.mission, parse_overrides(args.overrides))
    root = build_mission_tree(mission)
    print(f"# {mission.name}: {mission.route_summary()}")
    if args.unicode:
        print(f"# {UNICODE_LEGEND}")
        print(unicode_tree(root), end="")
    else:
        print(py_trees.display.ascii_tree(root), end="")
    if args.dot is not None:
        try:
            args.dot.write_text(dot_tree(root), encoding="utf-8")
        except OSError as exc:
            raise InputError(f"cannot write: {exc}", file=str(args.dot)) from None
        print(f"# wrote {args.dot} (Graphviz dot; render with: dot -Tpng {args.dot} -o tree.png)")
    return 0
