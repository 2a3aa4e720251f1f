"""``marknav calibrate-camera``: camera matrix and lens distortion from chessboard photographs."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "calibrate-camera",
        help="fit the camera matrix and lens distortion to chessboard photographs",
        description=(
            "OpenCV's chessboard calibration: every image must show the whole board. Prints the "
            "camera matrix K, the distortion coefficients (k1, k2, p1, p2, k3), the RMS "
            "reprojection error and a camera.intrinsics block to paste into a mission (its "
            "focal length then gives the pinhole range prior, and detections are undistorted)."
        ),
    )
    p.add_argument("images", metavar="IMAGE", nargs="+", help="photographs of the chessboard")
    p.add_argument("--board", metavar="COLSxROWS", required=True,
                   help="inner corners per row and column, e.g. 9x6")
    p.add_argument("--square-mm", metavar="S", type=float, required=True,
                   help="side of one square, mm")
    p.add_argument("--json", action="store_true",
                   help="print fx, fy, cx, cy, dist, rms, images_used as JSON")
    p.add_argument("--plot", metavar="FILE.png",
                   help="draw the corners found and the lens's distortion field")
    p.add_argument("--opencv-yml", metavar="FILE.yml",
                   help="also write the result in OpenCV's FileStorage format (camera_matrix, "
                        "distortion_coefficients, image_width, image_height, "
                        "avg_reprojection_error), as OpenCV's calibration sample writes it")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.core.outputs import check_output_file, printable
    from marknav.vision.chessboard import (
        calibrate_images,
        parse_board,
        plot_calibration,
        write_opencv_yml,
    )

    board = parse_board(args.board)
    for option, path in (("--plot", args.plot), ("--opencv-yml", args.opencv_yml)):
        if path:
            check_output_file(Path(path), option=option)
    cal = calibrate_images(list(args.images), board, args.square_mm)
    if args.plot:
        plot_calibration(cal, args.plot)
    if args.opencv_yml:
        write_opencv_yml(cal, args.opencv_yml)
    plotted = f"# plot: {printable(str(args.plot))}" if args.plot else None
    if args.json:
        print(json.dumps(cal.to_dict(), indent=2))
        if plotted:  # stdout stays one JSON document
            print(plotted, file=sys.stderr)
        return 0
    i = cal.intrinsics
    w, h = cal.image_size
    print(f"# camera calibrated from {len(cal.images_used)} images of a {board[0]}x{board[1]} "
          f"board ({args.square_mm:g} mm squares), {w}x{h}")
    print("# K =")
    for row in i.matrix:
        print("#   [" + "  ".join(f"{v:10.4f}" for v in row) + "]")
    print("# dist (k1, k2, p1, p2, k3) = " + ", ".join(f"{c:.6g}" for c in i.dist))
    print(f"# RMS reprojection error = {cal.rms_px:.4f} px")
    worst = sorted(zip(cal.per_view_px, cal.images_used, strict=False), reverse=True)[:3]
    print("# worst views: " + ", ".join(f"{p} {e:.3f} px" for e, p in worst))
    if args.opencv_yml:
        print(f"# OpenCV FileStorage written: {args.opencv_yml}")
    if plotted:
        print(plotted)
    print("# paste under camera: in your mission")
    print(cal.yaml_snippet())
    return 0
