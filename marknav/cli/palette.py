"""``marknav palette``: teach the marks' colours from photos (or live frames) of the marks."""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from marknav.core.errors import InputError, MissionFailed

if TYPE_CHECKING:
    from marknav.vision.palette import Palette
    from marknav.vision.palette_teach import RoundMark
    from marknav.vision.sources import Image


#: Two colours whose ranges meet with a margin under this (hue units, OpenCV's 0..179) get a
#: warning: after white balance, daylight against a warm lamp still moves a printed colour's
#: hue by a few units, so a 3-unit margin (a red next to an orange) is carried across by a
#: change of light; 5 units leave room for that shift and the hue noise of a small mark.
WARN_MARGIN_HUE = 5.0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "palette",
        help="teach the marks' hue ranges from photos of your own marks",
        description=(
            "Find the saturated round marks in IMAGEs (or in frames of --camera), measure each "
            "colour's hues under the light of those pictures (after the detector's white "
            "balance), group them into the colours named by --colours, and print the hue "
            "ranges, the margins between colours (hue units, OpenCV's 0..179) and the "
            "marks.colours block to paste into a mission. Warns where two colours are too "
            "close to be told apart. --check MISSION reports how the mission's palette "
            "separates the marks found (exit 1 when a mark falls in another colour's range "
            "or in none)."
        ),
    )
    p.add_argument("images", metavar="IMAGE", nargs="*",
                   help="photographs of the marks (every mark you will use, in your light)")
    p.add_argument("--camera", metavar="SRC",
                   help="take frames from a camera index, video file, image folder or http:// "
                        "MJPEG stream instead of IMAGE files")
    p.add_argument("--frames", type=int, default=5, metavar="N",
                   help="frames to take from --camera (default 5)")
    p.add_argument("--interval", type=float, default=0.5, metavar="SECONDS",
                   help="time between --camera frames, to move the marks or the light "
                        "(default 0.5)")
    p.add_argument("--colours", metavar="NAME[=HUE][:SIDE],...",
                   help="the colours of your marks, e.g. red:left,green:right,blue:left; a "
                        "name marknav does not know needs its hue (teal=85); SIDE is copied "
                        "into the block")
    p.add_argument("--check", metavar="MISSION",
                   help="report how MISSION's marks.colours separates the marks found")
    p.add_argument("--max-margin", type=int, default=12, metavar="HUE",
                   help="hue units a range may reach past the hues its marks showed, where no "
                        "other colour and no other saturated surface of the pictures is "
                        "(default 12)")
    p.add_argument("--annotate", metavar="DIR", type=Path,
                   help="write into DIR each picture with the marks found outlined in the "
                        "colour each was given, and hues.png: every colour's hue histogram "
                        "with its range and the margins (needs matplotlib: the plot extra)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)


#: Most frames taken from a camera: each is kept until the palette is fitted (a 1280×720 frame
#: is 2.8 MB: 200 are 550 MB), and a few dozen views of the marks teach their colours.
MAX_CAMERA_FRAMES = 200
#: Longest wait between camera frames (s): time to move the marks or the light between two.
MAX_INTERVAL_S = 600.0


@dataclass
class _Frame:
    """A camera frame (kept: it cannot be taken again) or an image file, decoded each time it
    is looked at: never every file's pixels at once (16 images whose headers claim 7000×7000
    were 4.9 GB)."""

    name: str
    kept: Image | None = None

    @property
    def image(self) -> Image:
        if self.kept is not None:
            return self.kept
        from marknav.vision.imagefile import read_image

        return read_image(self.name)


def _frames(args: argparse.Namespace) -> list[_Frame]:
    from marknav.vision.imagefile import check_image_file

    if args.camera is None:
        if not args.images:
            raise InputError("give IMAGE files or --camera SRC")
        for name in args.images:  # all readable, or exit 2 before any work
            check_image_file(name)
        return [_Frame(name) for name in args.images]
    if args.images:
        raise InputError("give IMAGE files or --camera, not both", field="--camera")
    if not 1 <= args.frames <= MAX_CAMERA_FRAMES:
        raise InputError(f"must be from 1 to {MAX_CAMERA_FRAMES}, got {args.frames}",
                         field="--frames")
    if not 0 <= args.interval <= MAX_INTERVAL_S:  # also refuses nan
        raise InputError(f"must be from 0 to {MAX_INTERVAL_S:g} seconds, got {args.interval:g}",
                         field="--interval")
    from marknav.vision.sources import open_source

    source = open_source(args.camera)
    out: list[_Frame] = []
    try:
        for i in range(args.frames):
            if i and args.interval > 0:
                time.sleep(args.interval)
            frame = source.read()
            if frame is None:
                break
            out.append(_Frame(f"{args.camera}#{frame.index}", frame.image))
    finally:
        source.close()
    if not out:
        raise InputError("the camera gave no frame", file=args.camera)
    return out


def _detector_agreement(frames: Sequence[_Frame], marks_per_frame: Sequence[Sequence[RoundMark]],
                        labels: Sequence[Sequence[str]], palette: Palette) -> dict[str, Any]:
    """The robot's detector with ``palette`` on each frame, against the marks found there and
    the colour each was given: found with that colour, with another, or missed."""
    from marknav.vision.detect import Detector

    detector = Detector(palette)
    per: list[dict[str, Any]] = []
    for fr, marks, names in zip(frames, marks_per_frame, labels, strict=True):
        detected = detector.detect(fr.image)
        right = wrong = missed = 0
        wrong_as: list[str] = []
        for m, name in zip(marks, names, strict=True):
            near = [d for d in detected if math.hypot(d.x - m.x, d.y - m.y) < 0.5 * m.radius]
            if not near:
                missed += 1
            elif any(d.colour == name for d in near):
                right += 1
            else:
                wrong += 1
                wrong_as.append(f"{name} as {near[0].colour}")
        per.append({"image": fr.name, "marks": len(marks), "right": right, "wrong": wrong,
                    "missed": missed, "wrong_as": wrong_as, "detections": len(detected)})
    total = {k: sum(p[k] for p in per) for k in ("marks", "right", "wrong", "missed")}
    return {"images": per, **total}


def run(args: argparse.Namespace) -> int:
    from marknav.core.outputs import printable
    from marknav.vision.palette_teach import check_palette, find_round_marks, parse_colours

    if args.colours is None and args.check is None:
        raise InputError("say which colours to teach (--colours red,green,blue) or which "
                         "mission to check (--check MISSION)")
    if args.max_margin < 0 or args.max_margin > 45:
        raise InputError(f"must be 0..45 hue units, got {args.max_margin}", field="--max-margin")
    requests = None
    if args.colours is not None:
        try:
            requests = parse_colours(args.colours)
        except ValueError as exc:
            raise InputError(str(exc), field="--colours") from None
    mission = None
    if args.check is not None:
        from marknav.missions.schema import load_mission

        mission = load_mission(args.check)
    frames = _frames(args)
    found = [find_round_marks(fr.image, source=fr.name) for fr in frames]
    marks = [m for ms in found for m in ms]
    result: dict[str, Any] = {"images": [{"image": fr.name, "marks": [m.to_dict() for m in ms]}
                                         for fr, ms in zip(frames, found, strict=True)]}
    out: list[str] = []
    for fr, ms in zip(frames, found, strict=True):
        out.append(f"{fr.name}: {len(ms)} round saturated mark{'s' if len(ms) != 1 else ''}")
    exit_code = 0
    #: what --annotate draws: each mark's colour, the palette, its margins, whose it is
    pictures: tuple[Any, ...] | None = None
    if requests is not None:
        pictures = _teach(args, requests, frames, found, result, out)
    if mission is not None:
        palette = mission.palette()
        checks, given = check_palette(marks, palette)
        labels = _split(given, found)
        agreement = _detector_agreement(frames, found, labels, palette)
        if pictures is None:
            pictures = (labels, palette, [], f"{args.check}'s")
        bad = sum(c.in_other + c.in_none for c in checks)
        result["check"] = {"mission": args.check, "colours": [vars(c) | {
            "other_names": list(c.other_names)} for c in checks], "detector": agreement,
            "separated": bad == 0}
        out += _check_text(args.check, checks, agreement)
        if bad:
            exit_code = 1
    if args.annotate is not None and pictures is not None:
        written = write_pictures(args.annotate, frames, found, *pictures)
        out.append("pictures: " + "  ".join(printable(str(p)) for p in written))
        result["pictures"] = [str(p) for p in written]
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print("\n".join(out))
    if exit_code:
        raise MissionFailed(f"{args.check}: its palette does not separate the marks found "
                            f"({sum(c.in_other for c in checks)} in another colour's range, "
                            f"{sum(c.in_none for c in checks)} in none)")
    return 0


def _teach(args: argparse.Namespace, requests: Any, frames: Sequence[_Frame],
           found: Sequence[Sequence[Any]], result: dict[str, Any],
           out: list[str]) -> tuple[Any, ...]:
    """``--colours``: propose the palette; its figures into ``result`` and its lines into
    ``out``; what ``--annotate`` draws of it."""
    import numpy as np

    from marknav.vision.palette_pictures import margins_of
    from marknav.vision.palette_teach import propose_palette, scene_hues, yaml_block

    marks = [m for ms in found for m in ms]
    try:
        clutter = np.mean([scene_hues(fr.image, ms)
                           for fr, ms in zip(frames, found, strict=True)], axis=0)
        proposal = propose_palette(marks, requests, max_margin=args.max_margin,
                                   clutter=clutter)
    except ValueError as exc:
        raise InputError(f"{exc} (photograph every colour; marks must be round, saturated "
                         "and at least 5 px in radius)", field="--colours") from None
    labels = _split(list(proposal.labels), found)
    for entry, names in zip(result["images"], labels, strict=True):
        for row, name in zip(entry["marks"], names, strict=True):
            row["colour"] = name
    agreement = _detector_agreement(frames, found, labels, proposal.palette())
    result.update(
        colours=[_colour_dict(c) for c in proposal.colours],
        gaps=[_gap_dict(g) for g in proposal.gaps],
        warnings=[*proposal.warnings, *narrow_margins(proposal)], detector=agreement,
        yaml=yaml_block(proposal))
    out += _marks_text(frames, found, labels)
    out += _proposal_text(proposal, agreement)
    out.append("# paste into your mission (replacing marks.colours):")
    out.append(yaml_block(proposal))
    return (labels, proposal.palette(), margins_of(proposal.gaps), "taught")


def write_pictures(folder: Path, frames: Sequence[_Frame], found: Sequence[Sequence[Any]],
                   labels: Sequence[Sequence[str]], palette: Any,
                   margins: Sequence[tuple[str, str, float, float]], whose: str) -> list[Path]:
    """``--annotate``: each frame with its marks outlined, and the hue histogram; the files."""
    import cv2

    from marknav.core.outputs import safe_file_name
    from marknav.vision.palette_pictures import hue_histogram, outline_marks

    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the folder: {exc.strerror or exc}",
                         file=str(folder)) from None
    written = []
    for k, (fr, ms, names) in enumerate(zip(frames, found, labels, strict=True)):
        stem = safe_file_name(Path(fr.name).stem, default="frame")
        out = folder / f"{k:02d}-{stem}.palette.png"
        if not cv2.imwrite(str(out), outline_marks(fr.image, ms, names, palette)):
            raise InputError("cannot write the picture", file=str(out))
        written.append(out)
    hist = folder / "hues.png"
    hue_histogram([m for ms in found for m in ms], [n for ns in labels for n in ns], palette,
                  hist, title=f"hue of the marks' pixels and the {whose} ranges", margins=margins)
    written.append(hist)
    return written


def _split(labels: list[str], found: Sequence[Sequence[Any]]) -> list[list[str]]:
    out, i = [], 0
    for ms in found:
        out.append(labels[i:i + len(ms)])
        i += len(ms)
    return out


def _hue(h: float) -> str:
    """A hue for the eye: one decimal, 179.97 shown as 0.0."""
    return f"{round(h, 1) % 180:.1f}"


def _colour_dict(c: Any) -> dict[str, Any]:
    return {"name": c.name, "hue": [c.hue_lo, c.hue_hi], "marks": c.marks,
            "mean_hue": round(c.mean_hue, 2), "mark_hues": [round(h, 2) for h in c.mark_hues],
            "pixel_hues": [round(h, 1) for h in c.pixel_hues], "sat_min": c.sat_min,
            "val_min": c.val_min, "side": c.side, "margin_stopped_at": list(c.stopped_at)}


def _gap_dict(g: Any) -> dict[str, Any]:
    return {"below": g.below, "above": g.above, "boundary": g.boundary,
            "margin_below": g.margin_below, "margin_above": g.margin_above,
            "pixel_overlap": g.pixel_overlap}


def _marks_text(frames: Sequence[_Frame], found: Sequence[Sequence[RoundMark]],
                labels: Sequence[Sequence[str]]) -> list[str]:
    out = []
    for fr, ms, names in zip(frames, found, labels, strict=True):
        out.append(f"{fr.name}:")
        for m, name in zip(ms, names, strict=True):
            lo, hi = round(m.hue + m.hue_lo) % 180, round(m.hue + m.hue_hi) % 180
            out.append(f"  {name:<8} x={m.x:7.1f} y={m.y:7.1f} r={m.radius:6.1f}  hue "
                       f"{_hue(m.hue):>5} (pixels {lo:.0f}..{hi:.0f})  S {m.saturation:3.0f} "
                       f"V {m.value:3.0f}  round {m.roundness:.2f}")
    return out


def narrow_margins(proposal: Any) -> list[str]:
    """Warnings for colours whose ranges meet with a margin under :data:`WARN_MARGIN_HUE`
    that the proposal itself did not warn about."""
    out = []
    for g in proposal.gaps:
        pair = f"{g.below} and {g.above}"
        if g.boundary is None or g.margin >= WARN_MARGIN_HUE or any(
                w.startswith(pair) for w in proposal.warnings):
            continue
        out.append(f"{pair} meet with a margin of only {g.margin:.1f} hue units (split at "
                   f"{g.boundary}|{(g.boundary + 1) % 180}): a change of light will carry one "
                   "into the other (choose marks of more different colours, or teach them "
                   "under the light the robot will see)")
    return out


def _proposal_text(proposal: Any, agreement: dict[str, Any]) -> list[str]:
    out = ["colours (hue in OpenCV units 0..179; a range may wrap, 170..10):"]
    for c in proposal.colours:
        stop = (f"  (margin stopped by other surfaces at hue "
                f"{', '.join(str(h) for h in c.stopped_at)})" if c.stopped_at else "")
        out.append(f"  {c.name:<8} {c.marks:3d} mark{'s' if c.marks != 1 else ' '}  mean hue "
                   f"{_hue(c.mean_hue)}  marks {_hue(c.mark_hues[0])}..{_hue(c.mark_hues[1])}  "
                   f"pixels {round(c.pixel_hues[0]) % 180}..{round(c.pixel_hues[1]) % 180}  "
                   f"-> range {c.hue_lo}..{c.hue_hi}  sat_min {c.sat_min}  val_min "
                   f"{c.val_min}{stop}")
    if proposal.gaps:
        out.append("between colours (margins: hue units from the nearest mark's mean hue to its "
                   "range's edge):")
    by_name = {c.name: c for c in proposal.colours}
    for g in proposal.gaps:
        free = f"{(by_name[g.below].hue_hi + 1) % 180}..{(by_name[g.above].hue_lo - 1) % 180}"
        where = (f"split at {g.boundary}|{(g.boundary + 1) % 180}" if g.boundary is not None
                 else f"hues {free} left to neither")
        share = f", pixels share {g.pixel_overlap:.0f} units" if g.pixel_overlap > 0 else ""
        out.append(f"  {g.below + ' | ' + g.above:<18} {where:<28} margins "
                   f"{g.margin_below:5.1f} / {g.margin_above:5.1f}{share}")
    for w in [*proposal.warnings, *narrow_margins(proposal)]:
        out.append(f"warning: {w}")
    out.append(f"the detector with this palette: {agreement['right']} of {agreement['marks']} "
               f"marks found with their colour, {agreement['wrong']} with another, "
               f"{agreement['missed']} missed")
    for p in agreement["images"]:
        if p["wrong"] or p["missed"]:
            out.append(f"  {p['image']}: {p['right']}/{p['marks']}"
                       + (f" (wrong: {', '.join(p['wrong_as'])})" if p["wrong_as"] else ""))
    return out


def _check_text(mission: str, checks: Sequence[Any], agreement: dict[str, Any]) -> list[str]:
    out = [f"{mission}: how its palette separates the marks found "
           "(margin: hue units from a mark's mean hue to its range's nearer edge):"]
    for c in checks:
        other = f" ({', '.join(c.other_names)})" if c.other_names else ""
        margin = f"{c.min_margin:.1f}" if c.min_margin is not None else "-"
        out.append(f"  {c.name:<8} marks {c.marks:3d}  in its range {c.inside:3d}  in another "
                   f"colour's {c.in_other:3d}{other}  in none {c.in_none:3d}  "
                   f"smallest margin {margin}")
    out.append(f"  the detector with this palette: {agreement['right']} of {agreement['marks']} "
               f"marks found with that colour, {agreement['wrong']} with another, "
               f"{agreement['missed']} missed")
    return out
