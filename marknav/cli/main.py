"""The ``marknav`` command line.

Each sub-command lives in its own module of this package and provides ``register(subparsers)``
and the function it runs; :data:`COMMANDS` lists the modules in the order ``--help`` shows them.
This package is the only code that prints; the libraries below it log.

Exit codes (every command): 0 success; 1 the mission or evaluation failed or was aborted;
2 bad input (usage, invalid file, unreadable image or port); 130 interrupted.
"""

from __future__ import annotations

import argparse
import difflib
import logging
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from marknav import __version__
from marknav.cli import (
    bench,
    calibrate,
    calibrate_camera,
    calibrate_odometry,
    completion,
    detect,
    evaluate,
    examples,
    palette,
    random_mission,
    replay,
    run,
    schema,
    serve_camera,
    serve_robot,
    serve_tree,
    sim_robot,
    tree,
    tune,
    validate,
)
from marknav.core.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, InputError, MarknavError

log = logging.getLogger(__name__)

#: The first line a newcomer needs, at the top of ``marknav --help``.
START_HERE = ("Start here: 'marknav run slalom' drives the built-in slalom course in the "
              "simulator, no hardware needed; 'marknav examples DIR' copies the example "
              "missions out to edit; 'marknav COMMAND --help' tells more.")
#: Where the documentation is (the package has no published site: it is built from the source).
DOCS = ("Documentation: the MkDocs site in the source's docs/ folder (pip install "
        "'marknav[docs]'; mkdocs serve), first tutorial 'Your first run in the simulator'; "
        "exit codes: 0 success, 1 the mission failed, 2 bad input, 130 interrupted.")

#: The arguments that name a mission, as (command or ``None`` for every command, argument
#: name): each is a file or a built-in example's name (``slalom``), resolved to a file here
#: before the command runs.
MISSION_ARGUMENTS: tuple[tuple[str | None, str], ...] = ((None, "mission"), ("palette", "check"))

#: The modules that each register one sub-command, in the order ``--help`` shows them.
COMMANDS: tuple[ModuleType, ...] = (
    run, validate, tree, evaluate, replay, examples, tune, random_mission, bench, detect,
    palette, calibrate, calibrate_camera, calibrate_odometry, sim_robot, schema, serve_camera,
    serve_robot, serve_tree, completion,
)



def _global_options(parser: argparse.ArgumentParser, *, after_command: bool) -> None:
    """``--version`` and ``-v`` on the top-level parser and on every sub-command, so they work
    before or after the command (``marknav run M -v``). After the command, ``-v`` counts into
    ``verbose_after`` (added to the top-level count)."""
    parser.add_argument("--version", action="version", version=f"marknav {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="count",
        dest="verbose_after" if after_command else "verbose",
        default=argparse.SUPPRESS if after_command else 0,
        help="more log output: -v marknav's own messages (INFO), -vv debug messages and "
             "the libraries' (py_trees, transitions) too"
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="marknav",
        description=("Drive an iRobot Create past coloured circular marks with one camera. "
                     f"{START_HERE}"),
        epilog=DOCS,
    )
    _global_options(parser, after_command=False)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in COMMANDS:
        module.register(sub)
    for command in sub.choices.values():
        _global_options(command, after_command=True)
    parser.set_defaults(root_parser=parser)  # 'marknav completion' describes it
    return parser


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers by name (aliases included)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def option_strings(parser: argparse.ArgumentParser) -> list[str]:
    return [s for action in parser._actions for s in action.option_strings]


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """`` (did you mean X?)`` when ``word`` is close to one of ``choices``, else ``""``."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


def check_command(parser: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """An unknown command is named with the closest known ones (argparse lists all 16).

    The top-level options take no values, so the first word not starting with ``-`` is the
    command."""
    commands = subcommands(parser)
    for word in argv:
        if word == "--":
            return
        if word.startswith("-"):
            continue
        if word not in commands:
            parser.error(f"unknown command {word!r}{did_you_mean(word, list(commands))}; "
                         f"commands: {', '.join(commands)} ('marknav --help' says what each "
                         "does)")
        return


def unrecognized(extras: Sequence[str], parser: argparse.ArgumentParser) -> str:
    """The error for arguments ``parser`` did not take, with the closest option for each
    option-like one."""
    known = option_strings(parser)
    parts = []
    for word in extras:
        if word.startswith("-") and len(word) > 1:
            name = word.split("=", 1)[0]
            parts.append(f"unknown option {word!r}{did_you_mean(name, known)}")
        else:
            parts.append(f"unexpected argument {word!r}")
    return "; ".join(parts)


def parse(parser: argparse.ArgumentParser, argv: Sequence[str]) -> argparse.Namespace:
    """Parse ``argv``; a usage error exits 2 with the usage of the command it concerns."""
    check_command(parser, argv)
    args, extras = parser.parse_known_args(argv)
    if extras:
        target = subcommands(parser).get(getattr(args, "command", None) or "", parser)
        target.error(unrecognized(extras, target))
    return args


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is when a record arrives (rich's proxy under the live
    view, a caller's capture), never to a stream that has since been closed."""

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)


#: OpenCV's own log level as the user set it (``OPENCV_LOG_LEVEL``), if they did.
_USER_OPENCV_LOG_LEVEL = os.environ.get("OPENCV_LOG_LEVEL")


def quiet_libraries(verbosity: int) -> None:
    """Library messages never reach the screen raw.

    - OpenCV writes ``[ WARN:0@1.959] global cap_v4l.cpp…`` lines to stderr itself (a camera
      that does not open, before marknav's own message says so): its level is ERROR, WARNING
      with -vv (unless the user set ``OPENCV_LOG_LEVEL``). It is read when OpenCV logs first,
      so it is set here, before any command imports ``cv2``; an imported ``cv2`` is set too.
    - Python warnings (numba's, NumPy's, ...) go to logging (logger ``py.warnings``), shown
      as log lines with -v and hidden otherwise.
    """
    if _USER_OPENCV_LOG_LEVEL is None:
        os.environ["OPENCV_LOG_LEVEL"] = "WARNING" if verbosity >= 2 else "ERROR"
        cv2 = sys.modules.get("cv2")
        if cv2 is not None and hasattr(cv2, "setLogLevel"):
            cv2.setLogLevel(3 if verbosity >= 2 else 2)  # 3 warning, 2 error
    logging.captureWarnings(True)
    logging.getLogger("py.warnings").setLevel(logging.WARNING if verbosity >= 1
                                              else logging.ERROR)


def configure_logging(verbosity: int) -> None:
    """Log to stderr: marknav's loggers at WARNING, INFO (-v) or DEBUG (-vv); other libraries'
    (transitions logs every state callback at INFO) stay at WARNING unless -vv; see
    :func:`quiet_libraries` for OpenCV's own log and Python warnings."""
    quiet_libraries(verbosity)
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


def resolve_missions(args: argparse.Namespace) -> None:
    """Every mission argument (:data:`MISSION_ARGUMENTS`) given as a built-in example's name
    becomes that example's file; InputError for a name or path that is neither."""
    from marknav.missions.examples import mission_path

    for only, name in MISSION_ARGUMENTS:
        value = getattr(args, name, None)
        if (only is None or only == args.command) and isinstance(value, str):
            setattr(args, name, mission_path(value))


def main(argv: Sequence[str] | None = None, *, exiting: bool = False) -> int:
    """Run one command; ``exiting``: the process ends after it (the console entry point)."""
    from marknav.core import signals

    signals.install()  # first: a signal while importing the commands is already handled
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before a command started (importing, parsing)
        print("marknav: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BaseException as exc:
        if signals.signalled() is None or isinstance(exc, SystemExit):
            raise
        # A library that caught the signal's KeyboardInterrupt mid-way and raised its own
        # error instead (an extension module's import): the signal is what happened.
        log.debug("%s after %s", type(exc).__name__, signals.signalled(), exc_info=exc)
        print("marknav: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        signals.uninstall(exiting=exiting)


def _main(argv: Sequence[str] | None) -> int:
    from marknav.cli.requirements import check_requirements
    from marknav.core.outputs import printable

    parser = build_parser()
    args = parse(parser, list(sys.argv[1:] if argv is None else argv))
    configure_logging(args.verbose + getattr(args, "verbose_after", 0))
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        check_requirements(args)  # before anything runs: no wasted run, no empty run folder
        resolve_missions(args)
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
