"""``marknav tree``: print a mission's behaviour tree without running it."""

from __future__ import annotations

import argparse
from pathlib import Path

from marknav.errors import InputError


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
    p.add_argument("--unicode", action="store_true", help="draw with unicode symbols")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import py_trees

    from marknav.missions.run import build_mission_tree
    from marknav.missions.schema import load_mission

    if args.dot is not None:
        from marknav.outputs import check_output_file

        check_output_file(args.dot, option="--dot")  # before the work, not after
    mission = load_mission(args.mission)
    root = build_mission_tree(mission)
    draw = py_trees.display.unicode_tree if args.unicode else py_trees.display.ascii_tree
    print(f"# {mission.name}: {mission.route_summary()}")
    print(draw(root), end="")
    if args.dot is not None:
        text = py_trees.display.dot_tree(root).to_string()
        try:
            args.dot.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise InputError(f"cannot write: {exc}", file=str(args.dot)) from None
        print(f"# dot: {args.dot}")
    return 0
