"""``marknav serve-tree``: a run's tree in a web browser, from its log or live."""

from __future__ import annotations

import argparse
import threading

from marknav.core.errors import InputError

#: The page's default port: free of Groot2's 1667/1668 and the camera server's 8080.
DEFAULT_PORT = 8733


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "serve-tree",
        help="show a run's tree in a web browser: from its run log, or live",
        description="Serve one page on 127.0.0.1 (nothing loaded from the network): the tree "
                    "drawn with each node's status, a timeline to scrub through the ticks, the "
                    "blackboard and the status panel. RUN: a run folder or run log; --live "
                    "[HOST:]PORT instead watches a Groot2 server ('marknav run --groot2', or a "
                    "BehaviorTree.CPP program's Groot2Publisher; extra: groot2). Ctrl-C stops.",
    )
    p.add_argument("run", metavar="RUN", nargs="?", help="run folder or run log (*.events.jsonl)")
    p.add_argument("--live", nargs="?", const="1667", metavar="[HOST:]PORT",
                   help="watch a Groot2 server instead of a run log (default 127.0.0.1:1667)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"the page's port on 127.0.0.1 (default {DEFAULT_PORT}; 0: any free)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.cli.groot2_option import MAX_PORT, groot2_address
    from marknav.runs.views.tree_page import LiveSource, LogSource, TreePageServer

    if (args.run is None) == (args.live is None):
        raise InputError("give a RUN or --live, not both or neither", field="RUN")
    if not 0 <= args.port <= MAX_PORT:
        raise InputError(f"not a port: {args.port}", field="--port")
    source: LogSource | LiveSource
    if args.live is not None:
        address = groot2_address(args.live)
        assert address is not None
        try:
            source = LiveSource(*address)
        except ConnectionError as exc:
            raise InputError(str(exc), field="--live") from None
    else:
        from marknav.runs.records.runlog import read_log

        try:
            source = LogSource(read_log(args.run))
        except ValueError as exc:
            raise InputError(str(exc), file=args.run) from None
    try:
        server = TreePageServer(source, port=args.port)
    except OSError as exc:
        source.close()
        raise InputError(f"cannot serve on 127.0.0.1:{args.port}: {exc.strerror or exc}",
                         field="--port") from None
    try:
        server.start()
        print(f"serving the tree at {server.url} (Ctrl-C stops)", flush=True)
        threading.Event().wait()
    finally:
        server.close()
    return 0
