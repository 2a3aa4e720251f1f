"""``marknav detect``: find the coloured marks in images, print them, optionally draw them."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from marknav.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "detect",
        help="find coloured circular marks in images",
        description="Detect marks (colour, centre, radius, axes, angle, shape, score) in each "
                    "IMAGE with the mission's palette (or the built-in red, orange, yellow, "
                    "green, blue).",
    )
    p.add_argument("images", metavar="IMAGE", nargs="+", help="image files")
    p.add_argument("--mission", metavar="MISSION", help="take the palette from this mission")
    p.add_argument("--json", action="store_true",
                   help="print [{image, marks: [{colour, x, y, radius, axes, angle, shape, "
                        "score}]}]")
    p.add_argument("--annotate", metavar="DIR", type=Path,
                   help="write each image with its marks drawn and labelled into DIR")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import cv2

    from marknav.vision.annotate import annotate
    from marknav.vision.detect import Detector
    from marknav.vision.palette import DEFAULT_PALETTE, Palette
    from marknav.vision.sources import read_image

    palette: Palette = DEFAULT_PALETTE
    if args.mission:
        from marknav.missions.schema import load_mission

        palette = load_mission(args.mission).palette()
    images = [(name, read_image(name)) for name in args.images]  # all readable, or exit 2
    if args.annotate is not None:
        try:
            args.annotate.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot create the folder: {exc}", file=str(args.annotate)) from None
    detector = Detector(palette)
    results = []
    for name, image in images:
        marks = detector.detect(image)
        results.append({"image": name, "marks": [m.to_dict() for m in marks]})
        if not args.json:
            print(f"{name}: {len(marks)} mark{'s' if len(marks) != 1 else ''}")
            for m in marks:
                print(f"  {m.colour:<8} x={m.x:7.1f} y={m.y:7.1f} r={m.radius:6.1f} "
                      f"axes=({m.axes[0]:.1f}, {m.axes[1]:.1f}) angle={m.angle_deg:5.1f} "
                      f"{m.shape:<7} score={m.score:.2f}")
        if args.annotate is not None:
            out = args.annotate / (Path(name).stem + ".annotated.png")
            if not cv2.imwrite(str(out), annotate(image, marks, palette)):
                raise InputError("cannot write the annotated image", file=str(out))
            if not args.json:
                print(f"  drawn: {out}")
    if args.json:
        print(json.dumps(results, indent=2))
    return 0
