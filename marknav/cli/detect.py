"""``marknav detect``: find the coloured marks in images, print them, optionally draw them."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

from marknav.core.errors import InputError

if TYPE_CHECKING:
    from marknav.missions.mission_detector import CameraDetector
    from marknav.missions.schema import Mission
    from marknav.vision.detect import Mark


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "detect",
        help="find coloured circular marks in images",
        description="Detect marks (colour, centre, radius, axes, angle, shape, score) in each "
                    "IMAGE. With --mission, with the very detector `marknav run` builds from "
                    "the mission (its palette and camera.detect settings: horizon prior, "
                    "farthest range, white balance, faint-blob floor), and each mark's distance "
                    "by the mission's range law and its offset to the left of the camera axis; "
                    "without, the plain detector with the built-in red, orange, yellow, green, "
                    "blue palette.",
    )
    p.add_argument("images", metavar="IMAGE", nargs="+", help="image files")
    p.add_argument("--mission", metavar="MISSION",
                   help="detect as the robot does on this mission (palette, camera.detect), "
                        "and give distances by its range law")
    p.add_argument("--json", action="store_true",
                   help="print [{image, marks: [{colour, x, y, radius, axes, angle, shape, "
                        "score}]}]")
    p.add_argument("--annotate", metavar="DIR", type=Path,
                   help="write each image with its marks drawn and labelled into DIR")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import cv2

    from marknav.missions.mission_detector import mission_detector
    from marknav.vision.annotate import annotate
    from marknav.vision.detect import Detector
    from marknav.vision.imagefile import check_image_file
    from marknav.vision.palette import DEFAULT_PALETTE, Palette
    from marknav.vision.sources import read_image

    palette: Palette = DEFAULT_PALETTE
    mission = None
    detector: Detector | CameraDetector = Detector(palette)
    if args.mission:
        from marknav.missions.schema import load_mission

        mission = load_mission(args.mission)
        detector = mission_detector(mission)
        palette = detector.palette
    for name in args.images:  # all readable, or exit 2 before any output
        check_image_file(name)
    # Decoded one at a time: never every image's pixels at once.
    images = ((name, read_image(name)) for name in args.images)
    if args.annotate is not None:
        try:
            args.annotate.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot create the folder: {exc}", file=str(args.annotate)) from None
    results = []
    for name, image in images:
        marks = detector.detect(image)
        where = [mark_position(m, image.shape[1], mission) for m in marks] if mission else []
        rows = [m.to_dict() for m in marks]
        for row, pos in zip(rows, where, strict=False):
            row.update(pos)
        results.append({"image": name, "marks": rows})
        if not args.json:
            print(f"{name}: {len(marks)} mark{'s' if len(marks) != 1 else ''}")
            if mission is not None:
                note = size_note(mission, image.shape[1], image.shape[0])
                if note:
                    print(f"  note: {note}")
            for i, m in enumerate(marks):
                distance = (f" distance={where[i]['distance_mm']:6.0f} mm "
                            f"left={where[i]['left_mm']:6.0f} mm" if where else "")
                print(f"  {m.colour:<8} x={m.x:7.1f} y={m.y:7.1f} r={m.radius:6.1f} "
                      f"axes=({m.axes[0]:.1f}, {m.axes[1]:.1f}) angle={m.angle_deg:5.1f} "
                      f"{m.shape:<7} score={m.score:.2f}{distance}")
        if args.annotate is not None:
            out = args.annotate / (Path(name).stem + ".annotated.png")
            if not cv2.imwrite(str(out), annotate(image, marks, palette)):
                raise InputError("cannot write the annotated image", file=str(out))
            if not args.json:
                print(f"  drawn: {out}")
    if args.json:
        print(json.dumps(results, indent=2))
    return 0


def mark_position(mark: Mark, image_width: int, mission: Mission) -> dict[str, float]:
    """The mark's distance (mm, the mission's range law) and offset to the left of the camera's
    axis (mm), as perception estimates them (a disc at camera height: paper eqs. 19/2 from the
    vertical semi-axis, and the bearing of its horizontal ends)."""
    from marknav.missions.camera import mission_intrinsics, mission_range_model
    from marknav.vision.estimate import estimate_disc

    cam = mission.camera
    intr = mission_intrinsics(mission)
    same = image_width == cam.width
    cx = intr.cx if intr is not None and same else 0.5 * (image_width - 1)
    focal = intr.fx if intr is not None and same else cam.focal_px * image_width / cam.width
    est = estimate_disc(x_px=mark.x, axes=mark.axes, angle_deg=mark.angle_deg, cx=cx,
                        model=mission_range_model(mission)[0],
                        mark_radius_mm=mission.marks.radius_mm, focal_px=focal)
    return {"distance_mm": round(est.distance_mm, 1), "left_mm": round(est.left_mm, 1)}


def size_note(mission: Mission, width: int, height: int) -> str | None:
    """A warning when the image is not the size the mission's range law is for."""
    cam = mission.camera
    if (width, height) == (cam.width, cam.height):
        return None
    return (f"the image is {width}×{height}, the mission's camera {cam.width}×{cam.height}: "
            "its range law is for that size, so these distances are off by the scale")
