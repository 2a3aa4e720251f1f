"""``marknav tree``: print a mission's behaviour tree without running it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from marknav.cli.validate import SET_HELP, set_item
from marknav.core.errors import InputError

if TYPE_CHECKING:
    from py_trees.behaviour import Behaviour


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "tree",
        help="print a mission's behaviour tree without running it",
        description="Build MISSION's tree (its tree: section, or the default route tree) and "
                    "print it, every node, in the notation of the live view and 'marknav "
                    "replay' (the legend line says what the symbols mean); --dot also writes "
                    "it in Graphviz dot format with the same labels; --xml as "
                    "BehaviorTree.CPP 4 XML (Groot2 opens it), --xsd the XML schema of its "
                    "node types as BehaviorTree.CPP writes schemas.",
    )
    p.add_argument("mission", metavar="MISSION",
                   help="mission YAML file, or the name of a built-in example (slalom)")
    p.add_argument("--dot", metavar="FILE", type=Path,
                   help="also write the tree as Graphviz dot (render with: dot -Tpng FILE)")
    p.add_argument("--xml", metavar="FILE", type=Path,
                   help="also write the tree as BehaviorTree.CPP 4 XML with Groot2's node uids "
                        "(_uid: pre-order from 1), its node types in <TreeNodesModel>; - : "
                        "the XML alone on standard output")
    p.add_argument("--plain", action="store_true",
                   help="with --xml: leave out the uids (_uid, _fullpath), which "
                        "BehaviorTree.CPP's schema does not admit")
    p.add_argument("--xsd", metavar="FILE", type=Path,
                   help="also write the XML schema of the tree's node types (BehaviorTree.CPP's "
                        "built-ins used and marknav's), to validate --xml --plain files")
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
    from marknav.core.outputs import check_output_file
    from marknav.missions.examples import mission_path
    from marknav.missions.overrides import parse_overrides
    from marknav.runs.loop.checks import checked_mission
    from marknav.runs.records.tree_state import TreeState, dot_tree, legend
    from marknav.runs.views.display import resolve_style

    to_stdout = args.xml is not None and str(args.xml) == "-"
    for option, path in (("--dot", args.dot), ("--xml", None if to_stdout else args.xml),
                         ("--xsd", args.xsd)):
        if path is not None:
            check_output_file(path, option=option)  # before the work, not after
    if args.plain and args.xml is None:
        raise InputError("applies to --xml only", field="--plain")
    # The same checks as 'marknav validate' (and 'run'): a tree is only drawn for a mission
    # that would run.
    mission = checked_mission(mission_path(args.mission), parse_overrides(args.overrides))
    root = build_mission_tree(mission)
    if to_stdout:
        from marknav.runs.records.btcpp import tree_xml

        sys.stdout.write(tree_xml(root, _tree_id(mission.name), metadata=not args.plain))
        _write_xsd(args, root)
        return 0
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
    if args.xml is not None:
        from marknav.runs.records.btcpp import tree_xml

        _write(args.xml, tree_xml(root, _tree_id(mission.name), metadata=not args.plain))
        print(f"# wrote {args.xml} (BehaviorTree.CPP 4 XML: Groot2 opens it)")
    if _write_xsd(args, root):
        print(f"# wrote {args.xsd} (XML schema of the tree's node types)")
    return 0


def _tree_id(name: str) -> str:
    """A BehaviorTree ID from a mission name (letters, digits, _ and -)."""
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in name) or "MainTree"


def _write(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot write: {exc}", file=str(path)) from None


def _write_xsd(args: argparse.Namespace, root: Behaviour) -> bool:
    if args.xsd is None:
        return False
    from marknav.runs.records.btcpp import BUILTINS, nodes_of, tree_xsd, used_models

    _write(args.xsd, tree_xsd([*BUILTINS.values(), *used_models(nodes_of(root))]))
    return True
