"""Session 4 notes: the hue a mark of each colour reads over held-out randomised rooms.

Usage (from the project root)::

    [TL=0.05] python docs/notes/2026-12-02/hue-readings.py FIRST END orange,yellow [OVERRIDES]

A mark of radius 80 mm at 1.2 and 2.5 m straight ahead, in the room (conditions and background,
no poles, no distractors) of random missions FIRST..END-1. Prints, per colour, the min, p1, p50,
p99 and max of its balanced mean hue (inside its eroded outline) and the readings whose
detection at the mark is not its colour. ``TL``: the bare detector's ``tint_limit``.
``OVERRIDES``: palette ranges to try, e.g. ``"yellow:26:42;green:44:80"``.
"""

from __future__ import annotations

import math
import os
import sys

import cv2
import numpy as np

from marknav.planning.kinematics import Pose
from marknav.runs.random_mission import PALETTE, random_mission
from marknav.sim.camera import CameraConfig, Renderer
from marknav.sim.world import MarkSpec, World
from marknav.vision.detect import Detector, DetectorConfig
from marknav.vision.palette import ColourRange


def main() -> None:
    first, end, colours = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3].split(",")
    if len(sys.argv) > 4:
        for item in sys.argv[4].split(";"):
            name, lo, hi = item.split(":")
            PALETTE[name] = ((int(lo), int(hi)), PALETTE[name][1])
    palette = tuple(ColourRange(n, lo, hi, sat_min=s) for n, ((lo, hi), s) in PALETTE.items())
    limit = os.environ.get("TL")
    detector = Detector(palette, DetectorConfig(tint_limit=float(limit) if limit else None))
    cam = CameraConfig()
    pose = Pose(0.0, 0.0, math.pi / 2)
    readings: dict[str, list[tuple[int, float, float, list[str]]]] = {c: [] for c in colours}
    for seed in range(first, end):
        room = random_mission(seed).world
        conditions = room.conditions.model_copy(update={"occluders": 0, "distractors": 0})
        for colour in colours:
            for d in (1200.0, 2500.0):
                world = World(marks=(MarkSpec(colour=colour, x_mm=0.0,
                                              y_mm=d + cam.forward_offset_mm, radius_mm=80.0),),
                              conditions=conditions, background=room.background)
                renderer = Renderer(world, palette, cam)
                image = renderer.render(pose, np.random.default_rng(seed))
                gains, _ = detector.white_balance(image)
                mark = renderer.project(pose)[0]
                mask = np.zeros(image.shape[:2], np.uint8)
                cv2.fillPoly(mask, [np.round(mark.polygon).astype(np.int32)], 255)
                mask = cv2.erode(mask, np.ones((3, 3), np.uint8))
                balanced = cv2.transform(image, np.diag(np.array(gains, np.float32)))
                hue = cv2.cvtColor(balanced, cv2.COLOR_BGR2HSV)[..., 0][mask > 0]
                angle = hue.astype(float) * math.pi / 90.0
                mean = (math.degrees(math.atan2(np.sin(angle).mean(),
                                                np.cos(angle).mean())) / 2.0) % 180.0
                found = [m.colour for m in detector.detect(image) if abs(m.x - mark.u) < 10]
                readings[colour].append((seed, d, round(mean, 2), found))
    for colour, rows in readings.items():
        hues = np.array([r[2] for r in rows])
        hues = np.where(hues > 150, hues - 180, hues)
        wrong = [r for r in rows if r[3] != [colour]]
        print(colour, "hue min/p1/p50/p99/max",
              np.round(np.percentile(hues, [0, 1, 50, 99, 100]), 1),
              "not read as itself:", len(wrong), wrong[:8])


if __name__ == "__main__":
    main()
