"""Coloured circular marks in one BGR frame (paper §3: HSV colour space, circles and ellipses).

The paper (§3.2) classifies marks in HSV because hue and saturation move little when the light
changes, finds circles with the Hough transform (§3.3) and checks each object against the ellipse
fitted to its contour. This module keeps that idea and orders it for speed: every pixel of the
frame goes through a few OpenCV calls at a quarter resolution (:mod:`.gate`), the half-resolution
search runs only around what could be a mark; Python work is per blob, O(1) calls for a whole
mark, and only blobs that may be partial marks reach the slower arc path.

The stages, one module each: :mod:`.gate` (where a mark can be), :mod:`.colour` (white balance,
masks, hue tables, coverage),
:mod:`.whole` (the fast path for whole marks), :mod:`.arcs` (partial marks from arcs),
:mod:`.suppress` (one mark per object); :mod:`.detector` strings them together, :mod:`.geometry`
holds the ellipse fits they share and :mod:`.model` the public types.

Output: :class:`Mark` objects sorted by radius, largest (nearest) first. ``radius`` is the
semi-major axis (eqs. 2-4 of the paper relate it to range).
"""

from __future__ import annotations

from marknav.vision.detect.detector import Detector, detect_marks
from marknav.vision.detect.model import DetectorConfig, Mark

__all__ = ["Detector", "DetectorConfig", "Mark", "detect_marks"]
