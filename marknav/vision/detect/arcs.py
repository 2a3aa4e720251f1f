"""Stage 3, the slow path: marks cut by the image edge, partly hidden, touching another mark.

Polygons, shapes far from their fitted ellipse's area and shapes with no plausible arc at half
resolution are dropped first (:meth:`_ArcMarks._has_arc`). In a full-resolution window the
``α >= 0.5`` mask of the colour (pixels of the other palette colours excluded) is traced; its
parts are tried as whole marks, else contour points on the image border and in concave stretches
are dropped and the remaining arcs fitted with circles (or an ellipse when they go round enough
of it), arcs of one circle merged — what the Hough transform gives the paper (a partial circle
still yields its centre and radius), without an accumulator. The edge points are moved to the
``α = 0.5`` crossing along the normals (one vectorised bilinear sampling) and refitted; a
candidate must be supported by enough of its outline, filled by its colour (marks of other
colours in front do not count against it) and not continue past its outline.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect.base import _Frame
from marknav.vision.detect.colour import _NO_COLOUR
from marknav.vision.detect.geometry import (
    Contour,
    FloatArray,
    Mat,
    _draw,
    _Ellipse,
    _fit_arc,
    _paste,
    _rms,
    _runs,
    _subpixel_edges,
)
from marknav.vision.detect.model import Mark
from marknav.vision.detect.whole import _WholeMarks

log = logging.getLogger("marknav.vision.detect")

def _mean_abs(values: FloatArray) -> float:
    """Mean absolute value (as ``np.mean(np.abs(values))``, without its dispatch)."""
    return float(np.abs(values).sum()) / len(values)


#: The flattest outline a partial mark is allowed before a straight stretch of it counts as an
#: occluder's edge: that of an ellipse of this axis ratio about the larger of the blob's
#: equivalent radius and half its extent (0.45-0.7 find the same 41 of 48 elongated partial
#: marks of the composited frames; 0.45 misses a mark crossed by a bar, 0.5-0.8 give the same
#: corpus figures).
_STRAIGHT_AXIS_RATIO = 0.7

#: A window's label for pixels of a palette colour's other hue cluster (:attr:`_Frame.hue_keep`):
#: neither background nor any palette colour's.
_OTHER = _NO_COLOUR - 1

_COS_36 = np.cos(np.arange(36) * (2.0 * math.pi / 36))
_SIN_36 = np.sin(np.arange(36) * (2.0 * math.pi / 36))


@dataclass
class _Window:
    """A full-resolution window of the frame with its per-pixel palette labels."""

    x0: int
    y0: int
    bgr: Mat
    labels: Mat  # palette index per pixel, _NO_COLOUR for none, _OTHER: another object
    blob: Mat  # the blob's pixels, dilated (255)


class _ArcMarks(_WholeMarks):
    """The arc path: partial marks from the arcs of their outline."""

    def _has_arc(self, frame: _Frame, contour: Contour, r_est: float) -> bool:
        """Whether a search-resolution contour holds an arc that could be a mark's: a circle
        through some of its convex stretches (off the image border) that its points follow
        within about a pixel over at least ~``min_arc`` of the circle, and beyond which its
        colour does not go on (as it does past the rounded end of a bar; a touching mark of
        another colour does not count). Cheap, so that clutter does not reach the
        full-resolution arc path."""
        cfg = self.config
        scale = frame.sx
        pts = contour.reshape(-1, 2).astype(np.float64)
        sh, sw = frame.mask.shape
        on_border = (pts[:, 0] <= 0) | (pts[:, 1] <= 0) | (pts[:, 0] >= sw - 1) | \
            (pts[:, 1] >= sh - 1)
        for fit, group in self._arc_candidates(pts, on_border, r_est, scale):
            if fit.major * scale < 0.9 * cfg.min_partial_radius:
                continue
            tol = max(0.75, 0.05 * fit.major)
            near = group[np.abs(fit.residuals(group)) <= 2.0 * tol]
            if len(near) < 6:
                continue
            ang = np.arctan2(near[:, 1] - fit.cy, near[:, 0] - fit.cx)
            seen = np.zeros(37, bool)
            seen[((ang + math.pi) * (36 / (2 * math.pi))).astype(np.intp)] = True
            if int(np.count_nonzero(seen)) < 0.8 * cfg.min_arc * 36:
                continue
            # The palette label 1.5 px outside the circle against the one 1.5 px inside it.
            cos, sin = _COS_36, _SIN_36
            xo = np.rint(fit.cx + (fit.major + 1.5) * cos).astype(np.intp)
            yo = np.rint(fit.cy + (fit.major + 1.5) * sin).astype(np.intp)
            r_in = max(0.5, fit.minor - 1.5)
            xi = np.minimum(np.maximum(np.rint(fit.cx + r_in * cos).astype(np.intp), 0), sw - 1)
            yi = np.minimum(np.maximum(np.rint(fit.cy + r_in * sin).astype(np.intp), 0), sh - 1)
            inside = (xo >= 0) & (xo < sw) & (yo >= 0) & (yo < sh)
            if not inside.any():
                continue
            xo, yo, xi, yi = xo[inside], yo[inside], xi[inside], yi[inside]
            hue_out = frame.hsv[yo, xo, 0]
            label_out = self._hue_lut[hue_out]
            label_in = self._hue_lut[frame.hsv[yi, xi, 0]]
            same = (frame.mask[yo, xo] > 0) & (label_out == label_in)
            if frame.hue_keep is not None:
                same &= frame.hue_keep[hue_out] > 0
            beyond = np.count_nonzero(same)
            if beyond <= 0.25 * len(xo):
                return True
        return False

    def _window(self, frame: _Frame, region: Mat, box: tuple[int, int, int, int],
                pad: int) -> _Window:
        """The blob's bounding box at full resolution (plus ``pad`` px) with palette labels;
        pixels outside the blob (dilated) are unlabelled, so neighbours stay out."""
        bx, by, bw, bh = box
        s_x, s_y = frame.sx, frame.sy
        x0 = max(0, int(bx * s_x) - pad)
        y0 = max(0, int(by * s_y) - pad)
        x1 = min(frame.width, math.ceil((bx + bw) * s_x) + pad)
        y1 = min(frame.height, math.ceil((by + bh) * s_y) + pad)
        bgr = frame.image[y0:y1, x0:x1]
        balanced = bgr if frame.balance is None else cv2.transform(bgr, frame.balance)
        hsv = cv2.cvtColor(balanced, cv2.COLOR_BGR2HSV)
        coloured = cv2.inRange(hsv, (0, self._sat_min, frame.v_floor), (255, 255, 255))
        # The blob's own pixels: its search-resolution region, enlarged and dilated.
        blob = np.zeros((y1 - y0, x1 - x0), np.uint8)
        full_box = (int(bx * s_x) - x0, int(by * s_y) - y0)
        up = cv2.resize(region, (round(bw * s_x), round(bh * s_y)),
                        interpolation=cv2.INTER_NEAREST)
        fx0, fy0 = full_box
        hh = min(up.shape[0], blob.shape[0] - fy0)
        ww = min(up.shape[1], blob.shape[1] - fx0)
        blob[fy0:fy0 + hh, fx0:fx0 + ww] = up[:hh, :ww]
        k = 2 * pad + 1
        cv2.dilate(blob, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)), dst=blob)
        cv2.bitwise_and(coloured, blob, dst=coloured)
        hue = np.ascontiguousarray(hsv[:, :, 0])
        labels = cv2.LUT(hue, self._hue_lut)
        if frame.hue_keep is not None:
            # Another hue cluster's pixels: another object (:attr:`_Frame.hue_keep`).
            labels[cv2.LUT(hue, frame.hue_keep) == 0] = _OTHER
        labels[coloured == 0] = _NO_COLOUR
        return _Window(x0, y0, bgr, labels, blob)

    def _window_marks(self, frame: _Frame, region: Mat,
                      box: tuple[int, int, int, int], colours: list[int],
                      purity: dict[int, float], *, try_whole: bool,
                      merged: bool = False, win: _Window | None = None) -> list[Mark]:
        """Marks of the given colours in the blob's full-resolution window (arc path). With
        ``try_whole``, each part of a colour's mask is first tried as a whole mark. ``merged``
        (one colour given): every palette-coloured pixel counts as that colour (not another
        hue cluster's, :attr:`_Frame.hue_keep`). ``win``: the
        blob's :meth:`_window` (``pad`` 4) when the caller already made it."""
        cfg = self.config
        if win is None:
            win = self._window(frame, region, box, pad=4)
        labels = win.labels
        background = cv2.inRange(labels, _NO_COLOUR, _NO_COLOUR)
        if cv2.countNonZero(background) < 8:
            return []
        back_bgr = cv2.mean(win.bgr, mask=background)
        min_area = 0.4 * math.pi * cfg.min_radius ** 2
        marks: list[Mark] = []
        for k in colours:
            own = cv2.bitwise_not(cv2.bitwise_or(background, cv2.inRange(labels, _OTHER, _OTHER))) \
                if merged else cv2.inRange(labels, k, k)
            core = cv2.erode(own, self._kernel3)
            if cv2.countNonZero(core) < min_area:
                continue
            transform = self._alpha_transform(cv2.mean(win.bgr, mask=core), back_bgr)
            if transform is None:
                continue
            alpha = cv2.transform(win.bgr, transform)
            # Pixels of the other palette colours (and of other hue clusters) are not this
            # mark; blob pixels of this colour below the mid-level (a highlight) are.
            others = cv2.bitwise_xor(cv2.bitwise_not(background), own)
            alpha[others > 0] = 0
            binary = cv2.threshold(alpha, 127, 255, cv2.THRESH_BINARY)[1]
            cv2.bitwise_and(binary, win.blob, dst=binary)
            cv2.bitwise_or(binary, core, dst=binary)
            binary = cv2.morphologyEx(binary, cv2.MORPH_OPEN, self._kernel3)
            parts, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            alpha_f = alpha.astype(np.float32) * (1.0 / 255.0)
            for part in parts:
                area = cv2.contourArea(part)
                if len(part) < 8 or area < min_area:
                    continue
                found = self._part_marks(frame, win, part, area, binary, alpha_f, k,
                                         purity.get(k, 1.0), others, try_whole)
                if merged:
                    found = [self._own_colour(m, win) for m in found]
                marks.extend(found)
        return marks

    def _own_colour(self, mark: Mark, win: _Window) -> Mark:
        """``mark`` named after the palette colour most of its own pixels have."""
        disc = _draw(win.labels.shape, _Ellipse(mark.x - win.x0, mark.y - win.y0, mark.axes[0],
                                                mark.axes[1], math.radians(mark.angle_deg)))
        hist = cv2.calcHist([win.labels], [0], disc, [len(self.palette)],
                            [0, len(self.palette)]).ravel()
        k = int(np.argmax(hist))
        if hist[k] <= 0 or self.palette[k].name == mark.colour:
            return mark
        return Mark(self.palette[k].name, mark.x, mark.y, mark.radius, mark.axes, mark.angle_deg,
                    mark.shape, mark.score * float(hist[k] / hist.sum()))

    def _part_marks(self, frame: _Frame, win: _Window, part: Contour, area: float,
                    binary: Mat, alpha: npt.NDArray[np.float32], colour: int,
                    purity: float, others: Mat, try_whole: bool) -> list[Mark]:
        """Marks in one connected part of a colour's α mask (window coordinates); ``others``
        marks the window's pixels of other palette colours."""
        cfg = self.config
        pts = part.reshape(-1, 2)
        gx = pts[:, 0] + win.x0
        gy = pts[:, 1] + win.y0
        on_border = (gx <= 0) | (gy <= 0) | (gx >= frame.width - 1) | (gy >= frame.height - 1)
        hull = cv2.convexHull(part)
        hull_area = cv2.contourArea(hull)
        if try_whole and not on_border.any() and hull_area > 0 and \
                area / hull_area >= cfg.min_solidity:
            coarse = self._whole_fit(part, tolerance_px=1.5)
            if coarse is not None:
                e = _Ellipse(coarse.cx + win.x0, coarse.cy + win.y0, coarse.a + 0.5,
                             coarse.b + 0.5, coarse.theta)
                exclude = (others, win.x0, win.y0) if cv2.countNonZero(others) else None
                mark = self._measure_whole(frame, e, colour, purity, exclude)
                if mark is not None:
                    return [mark]
        marks: list[Mark] = []
        r_est = math.sqrt(max(hull_area, 1.0) / math.pi)
        for cand in self._arc_candidates(pts.astype(np.float64), on_border, r_est):
            mark = self._refine_arc(frame, win, cand, binary, alpha, colour, purity, others)
            if mark is not None:
                marks.append(mark)
        return marks

    def _arc_candidates(self, pts: FloatArray, on_border: npt.NDArray[np.bool_],
                        r_est: float, scale: float = 1.0) -> Iterator[tuple[_Ellipse, FloatArray]]:
        """Coarse circles/ellipses, each with its contour points, from the convex arcs of a
        contour: points on the image border and in concave stretches (contour spans whose
        hull edge is long, or much shorter than the span) are dropped; the remaining runs are
        fitted and the runs of one circle merged. Yielded one by one, so that a caller that
        needs only the first good one (:meth:`_has_arc`) does not pay for the others."""
        n = len(pts)
        keep = ~on_border
        # A digital circle's flattest stretch (at its extremes) is ≈ 2√r long: longer hull
        # edges bridge something that is not the mark's outline.
        long_edge = max(6.0, 3.0 * math.sqrt(max(r_est, 1.0)) + 2.0)
        hull = np.sort(cv2.convexHull(pts.astype(np.int32).reshape(-1, 1, 2),
                                      returnPoints=False).ravel())
        if len(hull) >= 2:
            nxt = np.concatenate((hull[1:], hull[:1]))
            step = pts[nxt] - pts[hull]
            lengths = np.sqrt(np.einsum("ij,ij->i", step, step))
            spans = (nxt - hull) % n
            bad = (lengths > long_edge) | (spans > 1.4 * lengths + 3)
            cuts = list(zip(hull[bad].tolist(), nxt[bad].tolist(), strict=True))
            # The radius its outline may curve with: a mark cut by the image edge or hidden
            # in part covers less area than its radius says, not less extent.
            extent = 0.5 * float((pts.max(axis=0) - pts.min(axis=0)).max())
            cuts += _straight_stretches(pts, hull.astype(np.intp),
                                        max(r_est, extent) / _STRAIGHT_AXIS_RATIO)
            for i, j in cuts:
                if j > i:
                    keep[i + 1:j] = False
                else:
                    keep[i + 1:] = False
                    keep[:j] = False
        min_radius = self.config.min_partial_radius / scale
        min_run = max(6, int(0.1 * math.pi * min_radius))
        runs = sorted((r for r in _runs(keep) if len(r) >= min_run), key=len, reverse=True)
        if len(runs) >= 2:
            # All the convex stretches together: one mark cut or hidden in several places
            # (a tilted mark's arcs have different curvatures and do not merge as circles).
            every = pts[np.concatenate(runs)]
            whole = _fit_arc(every)
            if whole is not None and whole.major >= 0.8 * min_radius and \
                    _mean_abs(whole.residuals(every)) <= max(0.75, 0.02 * whole.major):
                yield whole, every
        while runs:
            group = pts[runs.pop(0)]
            fit = _fit_arc(group)
            if fit is None:
                continue
            rest: list[npt.NDArray[np.intp]] = []
            for other in runs:
                other_pts = pts[other]
                tol = max(1.5, 0.06 * fit.major)
                if _mean_abs(fit.residuals(other_pts)) > tol:
                    rest.append(other)
                    continue
                merged = np.concatenate([group, other_pts])
                refit = _fit_arc(merged)
                limit = max(1.0, 0.04 * fit.major)
                if refit is None or _mean_abs(refit.residuals(merged)) > limit:
                    rest.append(other)
                    continue
                group, fit = merged, refit
            runs = rest
            # Trim outliers (a chord of an occluder, a joint with a neighbour) and refit.
            for _ in range(2):
                res = np.abs(fit.residuals(group))
                inl = res <= max(1.0, 2.5 * 1.25 * float(res.sum()) / len(res))
                if inl.all() or inl.sum() < 6:
                    break
                group = group[inl]
                refit = _fit_arc(group)
                if refit is None:
                    break
                fit = refit
            if fit.major >= 0.8 * min_radius:
                yield fit, group

    def _refine_arc(self, frame: _Frame, win: _Window, cand: tuple[_Ellipse, FloatArray],
                    binary: Mat, alpha: npt.NDArray[np.float32], colour: int,
                    purity: float, others: Mat) -> Mark | None:
        """Move the candidate's contour points to the α = 0.5 crossing along its normals,
        refit, and check support, fill and continuation (window coordinates inside)."""
        cfg = self.config
        fit, pts = cand
        if fit.major > 3.0 * max(binary.shape) or fit.minor < 0.8 * cfg.min_partial_radius:
            return None
        edge = _subpixel_edges(alpha, fit, pts)
        if len(edge) < 6:
            return None
        refit = _fit_arc(edge)
        if refit is None:
            return None
        res = refit.residuals(edge)
        tol = max(0.4, 0.03 * refit.major)
        inliers = np.abs(res) <= 2.5 * tol
        if int(inliers.sum()) < 6:
            return None
        if not inliers.all():
            again = _fit_arc(edge[inliers])
            if again is not None:
                refit = again
                res = refit.residuals(edge)
                inliers = np.abs(res) <= 2.5 * tol
        rms = _rms(res[inliers])
        if rms > tol:
            log.debug("arc at (%.1f, %.1f) r=%.1f: rms %.2f > %.2f", refit.cx + win.x0,
                      refit.cy + win.y0, refit.major, rms, tol)
            return None
        g = _Ellipse(refit.cx + win.x0, refit.cy + win.y0, refit.a, refit.b, refit.theta)
        support, arc, continued = self._outline_stats(frame, win, refit, edge[inliers], alpha)
        # Small arcs are cheap to come by in clutter: they need 0.1 more support.
        min_support = cfg.min_support + (0.1 if g.major < 2.5 * cfg.min_partial_radius else 0.0)
        if support < min_support or arc < cfg.min_arc or continued > cfg.max_continued:
            log.debug("arc at (%.1f, %.1f) r=%.1f: support %.2f arc %.2f continued %.2f",
                      g.cx, g.cy, g.major, support, arc, continued)
            return None
        fill = self._fill(frame, win, g, binary, others)
        if fill < cfg.min_fill:
            log.debug("arc at (%.1f, %.1f) r=%.1f: fill %.2f", g.cx, g.cy, g.major, fill)
            return None
        if g.major < cfg.min_partial_radius:
            return None
        quality = max(0.0, 1.0 - 0.5 * rms / tol)
        return self._mark(g, colour, purity * arc * quality)

    def _outline_stats(self, frame: _Frame, win: _Window, e: _Ellipse, edge: FloatArray,
                       alpha: npt.NDArray[np.float32]) -> tuple[float, float, float]:
        """(support, arc, continued): the shares of the outline inside the image that the edge
        points cover, of the whole outline they cover, and of the outline inside the window
        where the colour goes on outside it."""
        m = int(min(180, max(24, e.perimeter() / 3.0)))
        phi = np.arange(m) * (2.0 * math.pi / m)
        c, s = math.cos(e.theta), math.sin(e.theta)
        cp, sp = np.cos(phi), np.sin(phi)
        ox = e.a * cp * c - e.b * sp * s
        oy = e.a * cp * s + e.b * sp * c
        gx, gy = ox + e.cx + win.x0, oy + e.cy + win.y0
        inside = (gx >= -0.5) & (gx <= frame.width - 0.5) & (gy >= -0.5) & \
                 (gy <= frame.height - 0.5)
        visible = int(inside.sum())
        if visible == 0:
            return 0.0, 0.0, 1.0
        dx, dy = edge[:, 0] - e.cx, edge[:, 1] - e.cy
        u = (dx * c + dy * s) / e.a
        v = (-dx * s + dy * c) / e.b
        bins = (np.floor(np.arctan2(v, u) % (2.0 * math.pi) * (m / (2.0 * math.pi)))
                .astype(np.intp) % m)
        seen = np.zeros(m, bool)
        seen[bins] = True
        seen_visible = int((seen & inside).sum())
        # Colour beyond the outline: α sampled 2.5 px outside it, along the outward normal.
        gu, gv = cp / e.a, sp / e.b
        norm = np.hypot(gu, gv)
        nx, ny = (gu * c - gv * s) / norm, (gu * s + gv * c) / norm
        px = (e.cx + ox + 2.5 * nx).astype(np.float32)
        py = (e.cy + oy + 2.5 * ny).astype(np.float32)
        h, w = alpha.shape
        in_win = inside & (px >= 0) & (px <= w - 1) & (py >= 0) & (py <= h - 1)
        outside = cv2.remap(alpha, px.reshape(1, -1), py.reshape(1, -1), cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0.0).ravel()
        n_win = int(in_win.sum())
        continued = float(np.count_nonzero((outside >= 0.5) & in_win & ~seen)) / max(n_win, 1)
        return seen_visible / visible, float(seen.sum()) / m, continued

    def _fill(self, frame: _Frame, win: _Window, e: _Ellipse, binary: Mat,
              others: Mat) -> float:
        """Share of the ellipse's area inside the image that the colour's mask covers, not
        counting pixels of other palette colours (a mark in front hides part of it)."""
        x0 = max(0, math.floor(e.cx - e.major) - 1)
        y0 = max(0, math.floor(e.cy - e.major) - 1)
        x1 = min(frame.width, math.ceil(e.cx + e.major) + 2)
        y1 = min(frame.height, math.ceil(e.cy + e.major) + 2)
        if x1 <= x0 or y1 <= y0:
            return 0.0
        disc = _draw((y1 - y0, x1 - x0), _Ellipse(e.cx - x0, e.cy - y0, e.a, e.b, e.theta))
        hidden = _paste((others, win.x0, win.y0), x0, y0, disc.shape)
        cv2.subtract(disc, hidden, dst=disc)
        inside = cv2.countNonZero(disc)
        if inside == 0:
            return 0.0
        covered = cv2.bitwise_and(disc, _paste((binary, win.x0, win.y0), x0, y0, disc.shape))
        return cv2.countNonZero(covered) / inside


def _straight_stretches(pts: FloatArray, hull: npt.NDArray[np.intp],
                        r_max: float) -> list[tuple[int, int]]:
    """Contour index pairs (i, j) of straight stretches of a convex hull (sorted indices
    ``hull`` into ``pts``) longer than the flattest part of a curve of radius ``r_max`` (all in
    the contour's own pixels): an occluder's edge across a mark (a pole, a board's corner),
    which digitisation splits into several short hull edges that each pass the long-edge test.
    The hull is simplified to 0.75 px and measured as the whole path's straight-cut test
    measures a whole mark's (:func:`~marknav.vision.detect.geometry._flat_stretch`)."""
    if len(hull) < 4:
        return []
    corners = pts[hull]
    simple = cv2.approxPolyDP(corners.astype(np.float32).reshape(-1, 1, 2), 0.75,
                              True).reshape(-1, 2).astype(np.float64)
    if len(simple) < 3:
        return []
    limit = 3.0 * math.sqrt(max(r_max, 1.0)) + 2.0
    closed = np.concatenate((simple, simple[:1]))
    step = closed[1:] - closed[:-1]
    length = np.sqrt(np.einsum("ij,ij->i", step, step))
    if float(length.max()) <= limit:
        return []
    # The simplified hull's corners are some of the hull's points (integer coordinates): their
    # contour indices through one sorted lookup.
    keys = corners[:, 0] * 65536.0 + corners[:, 1]
    order = np.argsort(keys)
    wanted = simple[:, 0] * 65536.0 + simple[:, 1]
    at = np.minimum(np.searchsorted(keys[order], wanted), len(keys) - 1)
    if not np.array_equal(keys[order][at], wanted):
        return []
    verts = hull[order[at]]
    nxt = np.concatenate((verts[1:], verts[:1]))
    # The contour must run along the stretch (about a point per pixel): a hull edge over a
    # concave join (touching marks) is the long-edge test's, and the tangent it continues
    # along the marks' outlines is no occluder's edge.
    straight = (length > limit) & ((nxt - verts) % len(pts) <= 1.2 * length + 2)
    return list(zip(verts[straight].tolist(), nxt[straight].tolist(), strict=True))
