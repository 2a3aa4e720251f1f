"""The ``marknav`` command line.

Each sub-command lives in its own module of this package and provides ``register(subparsers)``
and the function it runs; :data:`COMMANDS` lists the modules in the order ``--help`` shows them.
This package is the only code that prints; the libraries below it log.

Exit codes (every command): 0 success; 1 the mission or evaluation failed or was aborted;
2 bad input (usage, invalid file, unreadable image or port); 130 interrupted.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from types import ModuleType

from marknav import __version__
from marknav.cli import (
    bench,
    calibrate,
    calibrate_camera,
    calibrate_odometry,
    detect,
    evaluate,
    palette,
    random_mission,
    replay,
    run,
    schema,
    serve_camera,
    serve_robot,
    sim_robot,
    tree,
    tune,
    validate,
)
from marknav.core.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, InputError, MarknavError

log = logging.getLogger(__name__)

#: The modules that each register one sub-command, in the order ``--help`` shows them.
COMMANDS: tuple[ModuleType, ...] = (
    run, validate, tree, evaluate, replay, tune, random_mission, bench, detect, palette,
    calibrate, calibrate_camera, calibrate_odometry, sim_robot, schema, serve_camera,
    serve_robot,
)



def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="marknav",
        description="Drive an iRobot Create past coloured circular marks with one camera.",
    )
    parser.add_argument("--version", action="version", version=f"marknav {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="count", default=0,
        help="more log output: -v marknav's own messages (INFO), -vv debug messages and "
             "the libraries' (py_trees, transitions) too"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in COMMANDS:
        module.register(sub)
    return parser


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is when a record arrives (rich's proxy under the live
    view, a caller's capture), never to a stream that has since been closed."""

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)


def configure_logging(verbosity: int) -> None:
    """Log to stderr: marknav's loggers at WARNING, INFO (-v) or DEBUG (-vv); other libraries'
    (transitions logs every state callback at INFO) stay at WARNING unless -vv."""
    handler = _StderrHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    handler._marknav = True  # type: ignore[attr-defined]
    root = logging.getLogger()
    for old in [h for h in root.handlers if getattr(h, "_marknav", False)]:
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(logging.DEBUG if verbosity >= 2 else logging.WARNING)
    logging.getLogger("marknav").setLevel(
        (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbosity, 2)])


def main(argv: Sequence[str] | None = None, *, exiting: bool = False) -> int:
    """Run one command; ``exiting``: the process ends after it (the console entry point)."""
    from marknav.core import signals

    signals.install()  # first: a signal while importing the commands is already handled
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before a command started (importing, parsing)
        print("marknav: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        signals.uninstall(exiting=exiting)


def entry() -> None:
    """The ``marknav`` console script and ``python -m marknav``."""
    sys.exit(main(exiting=True))


def _main(argv: Sequence[str] | None) -> int:
    from marknav.core.outputs import printable

    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(args.verbose)
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        return int(args.func(args))
    except InputError as exc:  # control characters from the input are shown escaped
        text = "\n".join(printable(line) for line in str(exc).split("\n"))
        print(f"marknav {args.command}: error: {text}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MarknavError as exc:
        text = "\n".join(printable(line) for line in str(exc).split("\n"))
        print(f"marknav {args.command}: {text}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"marknav {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
