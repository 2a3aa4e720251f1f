"""``marknav calibrate``: fit the range law (eq. 19) to a measured table and print it."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from marknav.core.errors import InputError

if TYPE_CHECKING:
    from marknav.vision.calibrate import PowerFit


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "calibrate",
        help="fit the distance-from-radius law to a measured table",
        description=(
            "Fit d = a·r^b (paper eq. 19) to a CSV table with the header radius_px,distance_mm "
            "(the image radius of a mark straight ahead, and its measured distance). Prints the "
            "line to paste under camera: in a mission, the fit quality and the worst rows."
        ),
    )
    p.add_argument("table", metavar="TABLE.csv", nargs="?",
                   help="CSV with header radius_px,distance_mm")
    p.add_argument("--sim", action="store_true",
                   help="measure the table in the simulator instead (the paper's Table 1 "
                        "procedure: a mark straight ahead, 2000 to 300 mm in 100 mm steps)")
    p.add_argument("--json", action="store_true", help="print the fit as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="draw the data and the fitted law")
    p.set_defaults(func=run)


def print_fit(fit: PowerFit, *, as_json: bool, source: str) -> None:
    if as_json:
        print(json.dumps(fit.to_dict(), indent=2))
        return
    print(f"# range law fitted to {source} ({len(fit.rows)} rows)")
    print("# paste under camera: in your mission")
    print(fit.yaml_snippet())
    print(f"# R² (log space) = {fit.r2:.6f}; largest relative error = {fit.max_rel_error:.2%}")
    print("# worst rows:")
    for row in fit.worst_rows(3):
        where = f"line {row.line}: " if row.line is not None else ""
        print(f"#   {where}r = {row.radius_px:g} px, measured {row.distance_mm:g} mm, "
              f"fitted {row.fitted_mm:.0f} mm ({row.rel_error:+.2%})")


def run(args: argparse.Namespace) -> int:
    from marknav.core.outputs import printable
    from marknav.vision.calibrate import fit_power_law, fit_table, plot_fit

    if args.sim == (args.table is not None):
        raise InputError("give either a TABLE.csv or --sim")
    if args.plot:
        from pathlib import Path

        from marknav.core.outputs import check_output_file

        check_output_file(Path(args.plot), option="--plot")
    if args.sim:
        from marknav.runs.views.progress import Progress
        from marknav.sim.calibration import sim_calibration_table

        with Progress("calibrate: the simulator's range table", sys.stderr,
                      unit="distances measured") as progress:
            rows = sim_calibration_table(
                on_row=lambda done, total: progress.update(done, total=total))
        fit = fit_power_law([r for r, _ in rows], [d for _, d in rows])
        source = "the simulator"
    else:
        fit = fit_table(args.table)
        source = args.table
    if args.plot:
        plot_fit(fit, args.plot, title=f"Range calibration: {source}")
    print_fit(fit, as_json=args.json, source=source)
    if args.plot:  # after the JSON, on stderr: stdout stays one JSON document
        print(f"# plot: {printable(str(args.plot))}", file=sys.stderr if args.json else sys.stdout)
    return 0
