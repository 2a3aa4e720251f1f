"""``marknav replay RUN`` (the run in the terminal, from its log alone) and ``marknav view RUN``
(the run in the Rerun viewer)."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

from marknav.core.errors import InputError
from marknav.core.inputfile import check_regular_file


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "replay",
        help="replay a recorded run in the terminal: tree and status at any time, and its plot",
        description=(
            "Rebuild a run from its log (RUN: a run folder or its *.events.jsonl) alone: the "
            "tree view and status panel as they were at any tick. Interactive on a terminal: "
            "Enter steps one tick, 'c' jumps to the next status change, 'j T' to time T, 'b' "
            "steps back, 'q' quits. --at, --changes and --plot work without a terminal."
        ),
    )
    p.add_argument("run", metavar="RUN", help="run folder or run log (*.events.jsonl)")
    p.add_argument("--at", type=float, metavar="SECONDS",
                   help="print the view at this run time and exit")
    p.add_argument("--changes", action="store_true",
                   help="print every status change (time, tick, node, old -> new) and exit")
    p.add_argument("--plot", metavar="FILE.png", type=Path,
                   help="draw the top-down picture of the run from the log")
    p.add_argument("--btlog", metavar="FILE.btlog", type=Path,
                   help="write the run's tree history as Groot2's replay file "
                        "(BehaviorTree.CPP 4's .btlog: every status change at its run time)")
    p.add_argument("--tree", default="auto", choices=("auto", "ascii", "unicode"),
                   help="tree symbols (default auto)")
    p.set_defaults(func=replay)

    v = sub.add_parser(
        "view",
        help="open a recorded run in the Rerun viewer (extra: viewer)",
        description=(
            "Open RUN in the Rerun viewer: a recording (FILE.mcap from 'marknav run --record', "
            "which Rerun reads itself), a folder holding one (the run's folder, a rosbag2 "
            "folder), or else a run folder / run log, which is streamed to the viewer (camera "
            "images only where the run saved frames with --frames). marknav sets "
            "RERUN_ANALYTICS=0 for the viewer it starts (Rerun otherwise sends anonymous usage "
            "data)."
        ),
    )
    v.add_argument("run", metavar="RUN", help="FILE.mcap, run folder or run log")
    v.set_defaults(func=view)


def _screen(state: object, panel: dict[str, object], style: str) -> str:
    from marknav.runs.records.tree_state import TreeState, legend
    from marknav.runs.views.display import status_text

    assert isinstance(state, TreeState)
    return "\n".join([legend(style), state.text(style=style),
                      *("  " + line for line in status_text(panel, style))])


def replay(args: argparse.Namespace) -> int:
    from marknav.runs.records.runlog import Replay, read_log
    from marknav.runs.views.display import resolve_style

    if args.btlog is not None:
        from marknav.core.outputs import check_output_file

        if args.btlog.suffix != ".btlog":
            raise InputError("Groot2 opens replay files named *.btlog", field="--btlog")
        check_output_file(args.btlog, option="--btlog")
    records = read_log(args.run)
    run = Replay(records)
    style = resolve_style(args.tree, sys.stdout)
    did = False
    if args.btlog is not None:
        _write_btlog(args.run, records, args.btlog)
        did = True
    if args.plot is not None:
        from marknav.sim.plot import plot_log

        plot_log(records, args.plot)
        print(f"plot: {args.plot}")
        did = True
    if args.changes:
        _print_changes(run)
        did = True
    if args.at is not None:
        k = run.index_at(args.at)
        print(_screen(run.state_at(k), run.ticks[k].get("panel", {}), style))
        did = True
    if did:
        return 0
    if not sys.stdin.isatty():
        raise InputError("interactive replay needs a terminal; use --at SECONDS, --changes or "
                         "--plot FILE", field="RUN")
    _interactive(run, style)
    return 0


def _write_btlog(run: str, records: list[dict[str, object]], path: Path) -> None:
    from marknav.runs.records import btlog
    from marknav.runs.records.runlog import resolve_log

    log = btlog.from_run_log(records, log_mtime_s=resolve_log(run).stat().st_mtime)
    try:
        btlog.write(path, log)
    except OSError as exc:
        raise InputError(f"cannot write: {exc}", file=str(path)) from None
    print(f"btlog: {path} ({len(log.transitions)} status changes; open it in Groot2's Log "
          "Replay)")


def _print_changes(run: object) -> None:
    from marknav.runs.records.runlog import Replay
    from marknav.runs.records.tree_state import TreeState

    assert isinstance(run, Replay)
    prev = TreeState.from_structure(run.info["tree"])
    for rec, state in run.states():
        for key, (st, _msg) in rec.get("nodes", {}).items():
            i = int(key)
            if prev.status[i] != st:
                print(f"t={rec['t']:.2f} s  tick {rec['n']}  {state.names[i]}: "
                      f"{prev.status[i]} -> {st}")
                prev.status[i] = st


def _interactive(run: object, style: str) -> None:
    from rich.console import Console

    from marknav.runs.records.runlog import Replay
    from marknav.runs.views.display import render, tree_rows

    assert isinstance(run, Replay)
    console = Console()
    k = 0
    last = len(run) - 1
    while True:
        console.clear()
        size = console.size  # one row more than the live view's: the prompt
        console.print(render(run.state_at(k), run.ticks[k].get("panel", {}), style=style,
                             max_rows=tree_rows(size.height - 1, size.width, style),
                             title=f"replay: tick {k}/{last}", width=size.width))
        try:
            cmd = console.input("[dim]Enter next tick · c next change · b back · "
                                "j T jump to time · e end · q quit[/] ").strip()
        except EOFError:
            return
        if cmd == "q":
            return
        if cmd == "":
            k = min(k + 1, last)
        elif cmd == "b":
            k = max(k - 1, 0)
        elif cmd == "c":
            k = run.next_change(k)
        elif cmd == "e":
            k = last
        elif cmd.startswith("j"):
            try:
                k = run.index_at(float(cmd[1:].strip()))
            except ValueError:
                continue


def view(args: argparse.Namespace) -> int:
    from marknav.runs.views.viewer import require_display, require_rerun

    require_rerun("view")  # also sets RERUN_ANALYTICS=0 unless the user chose otherwise
    recording = _recording_of(Path(args.run))
    if recording is not None:
        require_display("view")
        return _open_viewer(recording)
    from marknav.runs.records.runlog import read_log, resolve_log
    from marknav.runs.views.viewer import log_to_recording

    log_path = resolve_log(Path(args.run))
    records = read_log(log_path)
    require_display("view")
    sink = log_to_recording(log_path, records, spawn=True)
    sink.close()
    return 0


def _recording_of(path: Path) -> Path | None:
    """The MCAP recording RUN names: the file itself, or the one in the folder (None: none)."""
    import stat

    from marknav.core.inputfile import stat_path

    if path.suffix == ".mcap":
        check_regular_file(path, what="a recording (.mcap)")
        return path
    st = stat_path(path, field="RUN")
    if st is not None and stat.S_ISDIR(st.st_mode):
        found = sorted(path.glob("*.mcap"))
        return found[0] if found else None
    return None


def _open_viewer(path: Path) -> int:
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    if not Path(exe).exists():
        raise InputError("the Rerun viewer ('rerun') is not installed: pip install "
                         "'marknav[viewer]'", field="view")
    env = {**os.environ, "RERUN_ANALYTICS": os.environ.get("RERUN_ANALYTICS", "0")}
    return subprocess.call([exe, str(path)], env=env)
