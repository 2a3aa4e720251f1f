"""Ellipses and their fits: the shapes every stage measures marks with.

Least-squares circles (algebraic, optionally refined geometrically), direct ellipse fits,
ellipses from image moments, sub-pixel edges along an ellipse's normals, and the small mask
helpers (a filled ellipse, a pasted window) the stages share. Pixel centres at integers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect.kernels import circle_fit, ellipse_rms, true_runs

FloatArray = npt.NDArray[np.float64]
U8Array = npt.NDArray[np.uint8]
#: What OpenCV returns (images, masks, contours): its stubs type the element loosely.
Mat = npt.NDArray[Any]
Contour = Mat

#: Samples along an edge normal for the sub-pixel crossing (px from the contour point).
_RAY_T = np.array([-1.5, -0.75, 0.0, 0.75, 1.5, 2.25], np.float64)


@dataclass(slots=True)
class _Ellipse:
    """Centre, semi-axes ``a`` along ``theta`` (radians, image axes) and ``b`` across it."""

    cx: float
    cy: float
    a: float
    b: float
    theta: float

    @property
    def major(self) -> float:
        return max(self.a, self.b)

    @property
    def minor(self) -> float:
        return min(self.a, self.b)

    def rho(self, pts: FloatArray) -> FloatArray:
        """Normalised radius of each point: 1 on the ellipse, < 1 inside."""
        dx = pts[:, 0] - self.cx
        dy = pts[:, 1] - self.cy
        c, s = math.cos(self.theta), math.sin(self.theta)
        u = (dx * c + dy * s) / self.a
        v = (-dx * s + dy * c) / self.b
        out: FloatArray = np.sqrt(u * u + v * v)
        return out

    def residuals(self, pts: FloatArray) -> FloatArray:
        """Signed distance (px, + outside) of each point from the ellipse, along its ray from the
        centre (exact for circles, close for the mildly eccentric ellipses of marks)."""
        if self.a == self.b:
            out_c: FloatArray = np.hypot(pts[:, 0] - self.cx, pts[:, 1] - self.cy) - self.a
            return out_c
        c, s = math.cos(self.theta), math.sin(self.theta)
        d = pts - (self.cx, self.cy)
        # Normalised coordinates (u/a, v/b) of every point through one 2×2 product.
        q = d @ np.array([[c / self.a, -s / self.b], [s / self.a, c / self.b]])
        rho = np.sqrt(np.einsum("ij,ij->i", q, q))
        dist = np.sqrt(np.einsum("ij,ij->i", d, d))
        centre = rho == 0.0
        if centre.any():  # the centre itself: no ray (as far inside as the minor axis)
            out: FloatArray = np.where(centre, -self.minor,
                                       dist * (1.0 - 1.0 / np.where(centre, 1.0, rho)))
            return out
        res: FloatArray = dist * (1.0 - 1.0 / rho)
        return res

    def perimeter(self) -> float:
        a, b = self.a, self.b
        return math.pi * (3 * (a + b) - math.sqrt(max((3 * a + b) * (a + 3 * b), 0.0)))

    def scaled(self, da: float) -> _Ellipse:
        """The ellipse with both semi-axes grown by ``da`` px (shrunk when negative, >= 0.5)."""
        return _Ellipse(self.cx, self.cy, max(0.5, self.a + da), max(0.5, self.b + da),
                        self.theta)


def _from_rotated_rect(rect: tuple[Sequence[float], Sequence[float], float]) -> _Ellipse:
    (cx, cy), (w, h), angle = rect
    return _Ellipse(float(cx), float(cy), float(w) / 2.0, float(h) / 2.0, math.radians(angle))


def _fit_ellipse(pts: FloatArray) -> _Ellipse | None:
    if len(pts) < 6:
        return None
    try:
        e = _from_rotated_rect(cv2.fitEllipseDirect(pts.astype(np.float32)))
    except cv2.error:
        return None
    if not (e.a > 0 and e.b > 0 and math.isfinite(e.cx) and math.isfinite(e.cy)):
        return None
    return e


def _rms(values: FloatArray) -> float:
    return math.sqrt(float((values * values).sum()) / len(values)) if len(values) else math.inf


def _runs(keep: npt.NDArray[np.bool_]) -> list[npt.NDArray[np.intp]]:
    """Index arrays of the maximal runs of True in a cyclic boolean array."""
    if len(keep) == 0:
        return []
    order, bounds = true_runs(keep)
    return [order[b:e] for b, e in bounds.tolist()]


def _fit_arc(pts: FloatArray) -> _Ellipse | None:
    """Model of one or more arcs: a circle, or an ellipse when that fits clearly better and the
    points go round enough of it (200°) to pin it down."""
    pts = np.ascontiguousarray(pts, np.float64)
    ok, cx, cy, r, span = circle_fit(pts, len(pts) >= 12)
    if not ok:
        return None
    circle = _Ellipse(cx, cy, r, r, 0.0)
    if len(pts) < 12 or span < math.radians(200):
        return circle
    ell = _fit_ellipse(pts)
    if ell is None or ell.minor / ell.major < 0.3 or ell.major > 1.5 * circle.major:
        return circle
    if ellipse_rms(pts, ell.cx, ell.cy, ell.a, ell.b, ell.theta) < \
            0.7 * ellipse_rms(pts, cx, cy, r, r, 0.0):
        return ell
    return circle


def _moments_ellipse(mom: dict[str, float]) -> _Ellipse | None:
    """The ellipse with a region's area, centroid and second-moment shape (``cv2.moments`` of a
    binary image or of a contour polygon).

    For a uniform ellipse the covariance eigenvalues are a²/4 and b²/4; the axes are then scaled
    so that πab equals the area (for a binary image: the count of pixel centres inside the edge,
    an unbiased area).
    """
    m00 = mom["m00"]
    if m00 < 6:
        return None
    cx, cy = mom["m10"] / m00, mom["m01"] / m00
    mu20, mu02, mu11 = mom["mu20"] / m00, mom["mu02"] / m00, mom["mu11"] / m00
    half = 0.5 * (mu20 + mu02)
    diff = math.hypot(0.5 * (mu20 - mu02), mu11)
    l1, l2 = half + diff, half - diff
    if l2 <= 0:
        return None
    ratio = math.sqrt(l2 / l1)
    theta = 0.5 * math.atan2(2.0 * mu11, mu20 - mu02)
    a = math.sqrt(m00 / (math.pi * ratio))
    return _Ellipse(cx, cy, a, a * ratio, theta)


def _subpixel_edges(alpha: npt.NDArray[np.float32], fit: _Ellipse,
                    pts: FloatArray) -> FloatArray:
    """Contour points moved along the fit's normals to where α crosses 0.5 (bilinear samples,
    linear interpolation between the two samples that bracket it); points whose profile does not
    go from mark (α > 0.5) to background are dropped."""
    dx, dy = pts[:, 0] - fit.cx, pts[:, 1] - fit.cy
    c, s = math.cos(fit.theta), math.sin(fit.theta)
    u = dx * c + dy * s
    v = -dx * s + dy * c
    gu, gv = u / (fit.a * fit.a), v / (fit.b * fit.b)  # gradient of the ellipse equation
    norm = np.hypot(gu, gv)
    norm[norm == 0] = 1.0
    nx = (gu * c - gv * s) / norm
    ny = (gu * s + gv * c) / norm
    xs = (pts[:, 0:1] + nx[:, None] * _RAY_T[None, :]).astype(np.float32)
    ys = (pts[:, 1:2] + ny[:, None] * _RAY_T[None, :]).astype(np.float32)
    prof = cv2.remap(alpha, xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    above = prof >= 0.5
    # The first sample below 0.5 after the inner end must follow one above it.
    crossing = above[:, :-1] & ~above[:, 1:]
    has = crossing.any(axis=1) & above[:, 0] & ~above[:, -1]
    if not has.any():
        return np.zeros((0, 2), np.float64)
    j = np.argmax(crossing, axis=1)
    rows = np.arange(len(pts))
    p0, p1 = prof[rows, j].astype(np.float64), prof[rows, j + 1].astype(np.float64)
    denom = p0 - p1
    denom[denom <= 1e-6] = 1e-6
    t = _RAY_T[j] + (p0 - 0.5) / denom * (_RAY_T[j + 1] - _RAY_T[j])
    out: FloatArray = np.empty((int(has.sum()), 2), np.float64)
    out[:, 0] = (pts[:, 0] + nx * t)[has]
    out[:, 1] = (pts[:, 1] + ny * t)[has]
    return out


def _draw(shape: tuple[int, int], e: _Ellipse) -> Mat:
    """A filled ellipse (255) on a zero mask, with 1/16 px precision."""
    out = np.zeros(shape, np.uint8)
    shift = 4
    one = 1 << shift
    cv2.ellipse(out, (round(e.cx * one), round(e.cy * one)), (round(e.a * one), round(e.b * one)),
                math.degrees(e.theta), 0, 360, 255, cv2.FILLED, cv2.LINE_8, shift)
    return out


def _paste(mask: tuple[Mat, int, int], x0: int, y0: int, shape: tuple[int, int]) -> Mat:
    """The part of ``mask`` (placed at its origin in the image) inside the window of ``shape``
    at (x0, y0); zero elsewhere."""
    src, sx0, sy0 = mask
    out = np.zeros(shape, np.uint8)
    ax0, ay0 = max(x0, sx0), max(y0, sy0)
    ax1 = min(x0 + shape[1], sx0 + src.shape[1])
    ay1 = min(y0 + shape[0], sy0 + src.shape[0])
    if ax1 > ax0 and ay1 > ay0:
        out[ay0 - y0:ay1 - y0, ax0 - x0:ax1 - x0] = src[ay0 - sy0:ay1 - sy0, ax0 - sx0:ax1 - sx0]
    return out


def _longest_edge(polygon: Contour) -> float:
    """Length of the longest side of a closed polygon (e.g. a simplified convex hull)."""
    pts = polygon.reshape(-1, 2).tolist()
    px, py = pts[-1]
    longest = 0
    for x, y in pts:
        longest = max(longest, (x - px) * (x - px) + (y - py) * (y - py))
        px, py = x, y
    return math.sqrt(longest)


def _flat_stretch(e: _Ellipse) -> float:
    """Longest edge expected on the convex hull of the digitised outline of ``e``, simplified
    to 0.75 px: its flattest part (curvature radius major²/minor) stays that close to a chord
    ≈ 2.5·√radius long."""
    return 3.0 * math.sqrt(e.major * e.major / e.minor) + 2.0
