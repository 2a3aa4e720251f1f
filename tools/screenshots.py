"""Make the documentation's screenshots from real runs.

    PYTHONPATH=. python tools/screenshots.py --out docs/figures

Runs the long course in the simulator (its run log, and camera frames at
:data:`FRAMES_HZ`), then:

- ``live-view-80x24.svg`` and ``live-view-120x40.svg``: the live view's screen as ``marknav
  run`` draws it on a terminal of that size, at the first tick of waypoint 7's bypass, rebuilt
  from the run log (``marknav replay`` draws the same screen); rich writes the SVG;
- ``detection.png``: the camera frame saved nearest that tick, with the marks the mission's
  detector found (``marknav detect FRAME --mission long-course --annotate DIR``).

- ``palette-smarties.png`` and ``palette-hues.png``: what ``marknav palette
  tests/data/smarties.png --colours red,orange,green,blue --annotate DIR`` draws.

Nothing is drawn by hand: every picture is what a command shows of that run.
"""

from __future__ import annotations

import argparse
import io
import shutil
import sys
import tempfile
from pathlib import Path

from rich.console import Console

from marknav.cli.main import main
from marknav.runs.records.runlog import Replay, read_log
from marknav.runs.views.display import render, tree_rows

#: The mission the screenshots show, and the waypoint (1-based) whose bypass they catch.
MISSION = "long-course"
WAYPOINT = 7
#: The photograph ``marknav palette --annotate`` is shown on, and the colours taught from it.
SMARTIES = Path(__file__).resolve().parents[1] / "tests" / "data" / "smarties.png"
PALETTE_COLOURS = "red,orange,green,blue"
#: Camera frames saved per second of run time: one within 0.125 s of any tick.
FRAMES_HZ = 4
#: Terminal sizes (columns, rows): the smallest common one and a roomy one.
SIZES = ((80, 24), (120, 40))


def run_once(folder: Path) -> Path:
    """The long course, run in ``folder``: its run log's path."""
    report = folder / "report.json"
    code = main(["run", MISSION, "--tree", "none", "--report", str(report),
                 "--frames", str(FRAMES_HZ)])
    if code != 0:
        raise SystemExit(f"the {MISSION} run failed (exit {code})")
    return report.with_name("report.events.jsonl")


def bypass_tick(replay: Replay, waypoint: int) -> int:
    """The first tick at which waypoint ``waypoint``'s bypass is running."""
    name = f"Waypoint {waypoint}:"
    for k, (rec, state) in enumerate(replay.states()):
        running = [state.names[i] for i, s in enumerate(state.status) if s == "RUNNING"]
        if rec["panel"].get("active") == "Bypass" and any(n.startswith(name) for n in running):
            return k
    raise SystemExit(f"no tick of waypoint {waypoint}'s bypass in the log")


def live_view_svg(replay: Replay, k: int, width: int, height: int) -> str:
    console = Console(file=io.StringIO(), width=width, height=height, record=True,
                      force_terminal=True, color_system="truecolor")
    style = "unicode"
    console.print(render(replay.state_at(k), replay.ticks[k]["panel"], style=style,
                         max_rows=tree_rows(height, width, style),
                         title=f"marknav run {MISSION} · real time (--fast: full speed)",
                         width=width))
    return console.export_svg(title=f"marknav run {MISSION} ({width}×{height})")


def detection(replay: Replay, log: Path, t: float, out: Path) -> str:
    """The camera frame saved nearest run time ``t``, annotated by ``marknav detect`` into
    ``out``; the frame's name."""
    saved = [r for r in replay.records_of("frame") if "image" in r]
    if not saved:
        raise SystemExit("the run saved no camera frames")
    best = min(saved, key=lambda r: abs(float(r["t"]) - t))
    annotated = log.parent / "annotated"
    annotated.mkdir(exist_ok=True)
    code = main(["detect", str(log.parent / best["image"]), "--mission", MISSION,
                 "--annotate", str(annotated)])
    if code != 0:
        raise SystemExit(f"marknav detect failed (exit {code})")
    (made,) = sorted(annotated.iterdir())
    shutil.copyfile(made, out)
    return f"{best['image']} (t={float(best['t']):.2f} s)"


def main_() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        log = run_once(Path(tmp))
        replay = Replay(read_log(log))
        k = bypass_tick(replay, WAYPOINT)
        for width, height in SIZES:
            path = args.out / f"live-view-{width}x{height}.svg"
            path.write_text(live_view_svg(replay, k, width, height), encoding="utf-8")
            print(f"{path}: t={replay.times[k]:.2f} s, tick {k}")
        out = args.out / "detection.png"
        print(f"{out}: {detection(replay, log, replay.times[k], out)}")
        pictures = Path(tmp) / "palette"
        code = main(["palette", str(SMARTIES), "--colours", PALETTE_COLOURS, "--annotate",
                     str(pictures)])
        if code != 0:
            raise SystemExit(f"marknav palette failed (exit {code})")
        for made, name in ((f"00-{SMARTIES.stem}.palette.png", "palette-smarties.png"),
                           ("hues.png", "palette-hues.png")):
            shutil.copyfile(pictures / made, args.out / name)
            print(args.out / name)
    return 0


if __name__ == "__main__":
    sys.exit(main_())
