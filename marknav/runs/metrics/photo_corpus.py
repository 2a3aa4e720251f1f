"""The labelled photo corpus (``tests/data/real``): loading its labels and scoring recall on it."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from marknav.sim.synthetic.scene import Image
from marknav.vision.detect import Detector, Mark
from marknav.vision.palette import ColourRange, Palette

__all__ = ["Label", "LabelledPhoto", "default_corpus", "hit", "load_corpus", "real_recall"]


@dataclass(frozen=True)
class Label:
    colour: str
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class LabelledPhoto:
    name: str
    image: Image
    natural: bool
    marks: tuple[Label, ...]
    ignore: tuple[Label, ...]


def default_corpus() -> Path | None:
    """The source tree's ``tests/data`` when it exists (an editable install), else None."""
    here = Path(__file__).resolve().parents[3] / "tests" / "data"
    return here if (here / "labels.json").is_file() else None


def _palette(entries: Sequence[dict[str, Any]]) -> Palette:
    return tuple(ColourRange(e["name"], int(e["hue_lo"]), int(e["hue_hi"])) for e in entries)


def load_corpus(folder: str | Path) -> tuple[list[LabelledPhoto], Palette, Palette]:
    """The labelled photographs of ``folder``, the palette their labels use and the
    red/green/blue palette false marks are counted with."""
    root = Path(folder)
    doc = json.loads((root / "labels.json").read_text(encoding="utf-8"))
    photos: list[LabelledPhoto] = []
    for name, entry in sorted(doc["images"].items()):
        image = cv2.imread(str(root / name), cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError(f"{root / 'labels.json'}: images.{name}: cannot read {root / name}")

        def labels(key: str, entry: dict[str, Any] = entry) -> tuple[Label, ...]:
            return tuple(Label(m["colour"], float(m["x"]), float(m["y"]), float(m["radius"]))
                         for m in entry.get(key, []))

        photos.append(LabelledPhoto(name, np.asarray(image, np.uint8), bool(entry["natural"]),
                                    labels("marks"), labels("ignore")))
    return photos, _palette(doc["palette"]), _palette(doc["negative_palette"])


def hit(label: Label, mark: Mark, *, colour: bool = True) -> bool:
    return (not colour or mark.colour == label.colour) and \
        math.hypot(mark.x - label.x, mark.y - label.y) <= 0.2 * label.radius and \
        abs(mark.radius - label.radius) <= 0.15 * label.radius


def real_recall(photos: Sequence[LabelledPhoto], palette: Palette) -> dict[str, Any]:
    """Labelled marks found (colour, centre within 0.2 r, radius within 15 %)."""
    detector = Detector(palette)
    found = total = 0
    missed: list[str] = []
    for photo in photos:
        marks = detector.detect(photo.image)
        for label in photo.marks:
            total += 1
            if any(hit(label, m) for m in marks):
                found += 1
            else:
                missed.append(f"{photo.name}:{label.colour}@{label.x:.0f},{label.y:.0f}")
    return {"labelled": total, "found": found,
            "recall": round(found / total, 4) if total else 1.0, "missed": missed}
