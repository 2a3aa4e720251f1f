"""``marknav examples [DIR]``: copy the built-in example missions and worlds out to edit."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_DIR = "marknav-examples"


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "examples",
        help="copy the example missions and their worlds into a folder to edit",
        description=(
            "Copy the example missions shipped with marknav (and their simulator worlds, in "
            "worlds/) into DIR (default ./marknav-examples), without overwriting anything. "
            "Any command taking a MISSION also runs an example by name: 'marknav run slalom'."
        ),
    )
    p.add_argument("dir", metavar="DIR", nargs="?", default=DEFAULT_DIR, type=Path,
                   help=f"folder to copy them into (default ./{DEFAULT_DIR})")
    p.add_argument("--list", action="store_true", help="only list the examples' names")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.core.outputs import printable
    from marknav.missions.examples import copy_examples, example_names

    if args.list:
        for name in example_names():
            print(name)
        return 0
    written = copy_examples(args.dir)
    missions = [p for p in written if p.parent == args.dir]
    print(f"copied {len(missions)} missions and {len(written) - len(missions)} worlds into "
          f"{printable(str(args.dir))}; run one with: marknav run "
          f"{printable(str(args.dir / 'slalom.yaml'))}")
    return 0
