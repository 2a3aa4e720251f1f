"""Learning the camera's pose from the marks it sees: where the horizon prior's band belongs.

The detector's horizon prior (paper §3.1: marks stand at camera height) accepts mark centres
near the principal point's row. A camera pitched by p, rolled by r, with the marks' centres Δh
above it, sees a mark d ahead at image column u on the row

    v = c_y + f·tan(p − atan(Δh/d)) + (u − c_x)·tan r  ≈  h − k/d + s·(u − c_x)

with h = c_y + f·tan p (the horizon row: a far mark's), k = f·Δh and s = tan r. Each sighting
(u, v, d) is one linear equation in (h, k, s); :class:`HorizonLearner` fits them by least
squares, starting from the sightings within :data:`OUTLIER_SIGMAS` robust σ of the median row
and then dropping those that far off each fit (a false detection is not a mark at the marks'
height). While the sightings' 1/d spread less than
``min_inverse_spread_per_m`` (a robot turning on the spot sees its marks at one range), the
rise is not separable from the pitch: k is held at 0 and h absorbs it. Pure numbers: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OUTLIER_SIGMAS", "HorizonFit", "HorizonLearner"]

#: Sightings this many robust σ (1.4826 × median absolute residual) off the fit are dropped.
OUTLIER_SIGMAS = 3.0


@dataclass(frozen=True)
class HorizonFit:
    """A fitted camera pose: ``horizon_row`` h (px), ``k_px_mm`` (f·Δh), ``roll_slope`` s,
    ``rms_px`` of the kept sightings, how many were kept, and whether the rise was fitted."""

    horizon_row: float
    k_px_mm: float
    roll_slope: float
    rms_px: float
    samples: int
    rise_fitted: bool

    def pitch_deg(self, *, cy: float, focal_px: float) -> float:
        """The camera's tilt above the horizontal (positive: looking up), degrees."""
        return math.degrees(math.atan2(self.horizon_row - cy, focal_px))

    def rise_mm(self, *, focal_px: float) -> float:
        """How far the marks' centres stand above the camera, mm."""
        return self.k_px_mm / focal_px

    def roll_deg(self) -> float:
        return math.degrees(math.atan(self.roll_slope))


class HorizonLearner:
    """Collects sightings ``(u, v, forward_mm)`` and fits the camera's pose (module docstring).

    ``min_samples``: sightings before a fit is offered (a few frames of two or three marks);
    ``min_inverse_spread_per_m``: the 1/d range (1/m) that separates the marks' rise from the
    pitch (marks seen from 3 m down to 1 m span 0.67 /m); ``max_samples``: the newest kept.
    """

    def __init__(self, *, focal_px: float, cx: float, cy: float, min_samples: int = 20,
                 min_inverse_spread_per_m: float = 0.5, max_samples: int = 400) -> None:
        if not focal_px > 0:
            raise ValueError(f"focal_px must be positive, got {focal_px!r}")
        self.focal_px, self.cx, self.cy = float(focal_px), float(cx), float(cy)
        self.min_samples = int(min_samples)
        self.min_inverse_spread_per_m = float(min_inverse_spread_per_m)
        self.max_samples = int(max_samples)
        self._rows: list[tuple[float, float, float]] = []  # (u − cx, v, 1/d in 1/mm)

    @property
    def samples(self) -> int:
        return len(self._rows)

    def add(self, u: float, v: float, forward_mm: float) -> None:
        """One mark's centre (px) and its estimated distance ahead (mm; ignored unless > 0)."""
        if not (forward_mm > 0 and math.isfinite(u) and math.isfinite(v)):
            return
        self._rows.append((u - self.cx, v, 1.0 / forward_mm))
        if len(self._rows) > self.max_samples:
            del self._rows[0]

    def fit(self) -> HorizonFit | None:
        """The pose the sightings so far say, or ``None`` while there are too few."""
        if len(self._rows) < self.min_samples:
            return None
        a = np.asarray(self._rows, dtype=float)
        du, v, inv = a[:, 0], a[:, 1], a[:, 2]
        rise = bool((inv.max() - inv.min()) * 1000.0 >= self.min_inverse_spread_per_m)
        # Start from the median row (robust to clutter), then refit on the sightings near it.
        spread = 1.4826 * float(np.median(np.abs(v - np.median(v)))) + 0.5
        keep = np.abs(v - np.median(v)) <= OUTLIER_SIGMAS * spread
        coef = np.zeros(3)
        for _ in range(3):
            cols = [np.ones(keep.sum()), du[keep]] + ([-inv[keep]] if rise else [])
            sol, *_ = np.linalg.lstsq(np.stack(cols, axis=1), v[keep], rcond=None)
            coef = np.array([sol[0], sol[2] if rise else 0.0, sol[1]])  # h, k, s
            resid = v - (coef[0] - coef[1] * inv + coef[2] * du)
            sigma = 1.4826 * float(np.median(np.abs(resid[keep]))) + 0.5
            keep = np.abs(resid) <= OUTLIER_SIGMAS * sigma
            if keep.sum() < max(3, self.min_samples // 2):
                return None
        resid = v[keep] - (coef[0] - coef[1] * inv[keep] + coef[2] * du[keep])
        return HorizonFit(horizon_row=float(coef[0]), k_px_mm=float(coef[1]),
                          roll_slope=float(coef[2]),
                          rms_px=float(np.sqrt(np.mean(resid ** 2))), samples=int(keep.sum()),
                          rise_fitted=rise)
