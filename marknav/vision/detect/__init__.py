"""Coloured circular marks in one BGR frame (paper §3: HSV colour space, circles and ellipses).

The paper (§3.2) classifies marks in HSV because hue and saturation move little when the light
changes, and checks each object against the ellipse fitted to its contour (§3.3). The detector
keeps both ideas and is a pipeline of pure stages over one frozen value
(:class:`~marknav.vision.detect.scene.Scene`), each with its own small config
(:mod:`.pipeline`):

1. :mod:`.photometry` — the frame at half size with its exposure and the light's colour taken
   out (a software gain to a fixed bright end, grey world within bounds);
2. :mod:`.classify` — one mask per palette colour, the palette's HSV box;
3. :mod:`.segment` — blobs; a blob that is not a mark's shape is cut along the frame's colour
   edges (a mark against a surface of its own hue), and pieces are joined across thin occluders;
4. :mod:`.shape` — the blobs that are ellipses, measured at full resolution by the moments of
   their paint's coverage, vetoed when faint or textured;
5. :mod:`.suppression` — the horizon band and one mark per object.

Output: :class:`Mark` objects sorted by radius, largest (nearest) first. ``radius`` is the
semi-major axis (eqs. 2-4 of the paper relate it to range). :mod:`.least` is the least OpenCV
detector, the floor every cost is measured against.
"""

from __future__ import annotations

from marknav.vision.detect.model import Mark
from marknav.vision.detect.pipeline import Detector, DetectorConfig, detect_marks

__all__ = ["Detector", "DetectorConfig", "Mark", "detect_marks"]
