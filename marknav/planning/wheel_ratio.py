"""Wheel-ratio calibration from mark sightings: fix odometry's heading drift while driving.

Two wheels whose effective diameters differ by a few per cent (worn tyres, a softer side, a
carpet's pile) turn odometry's heading a little more every millimetre driven, and encoders cannot
see it: with a 5 % mismatch on a Create 2 the heading is off by ~12° after one metre. Approaching
a mark, the camera closes the loop and hides the error; bypassing it, the robot tracks its curve
from odometry alone and the drift carries it toward the mark.

Marks do not move, so every sighting tells the odometry something. A sighting puts the mark at
``M = P ⊕ v`` in the odometry frame (pose ``P``, robot-frame estimate ``v``). If the right wheel's
true travel is ``(1 + ε)`` times what odometry assumed, the pose changes by ``ε · ∂P/∂s`` to first
order (``∂P/∂s``: the sensitivity of the pose to the right-wheel scale since an anchor, which the
odometry integrates alongside the pose), and the mark estimate by::

    g = ∂M/∂s = (∂x/∂s, ∂y/∂s) + ∂θ/∂s · J (M − P),   J = rotation by +90°

The right ``ε`` is the one that makes each mark's sightings agree: minimise
``Σ |M_i + ε g_i − M̄_k|²`` over ``ε`` and the marks' positions ``M̄_k``, a linear least-squares
problem with the closed form (per mark ``k``, centred on its means)::

    ε = − Σ (M_i − M̄_k)·(g_i − ḡ_k) / Σ |g_i − ḡ_k|²

The heading term of ``g`` is perpendicular to the line of sight, so range errors (the estimate's
largest, along the line of sight) hardly enter. :class:`WheelRatioCalibrator` collects sightings
since the last anchor and fits when the fit is precise enough. Successive fits are combined by a
scalar Kalman filter on the scale (prior: 1 ± 5 %; each fit's error inflated because residuals of
consecutive frames are correlated), so one unlucky window moves the scale little once it has
settled. It hands back the factor to apply to the right wheel; the caller re-anchors the
odometry, and a new window starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Sensitivity", "WheelRatioCalibrator", "WheelRatioFit", "WheelRatioStep",
           "fit_wheel_ratio", "mark_sensitivity"]

#: ∂(x, y, θ)/∂s: how the odometry pose moves per unit change of the right wheel's scale.
Sensitivity = tuple[float, float, float]


def mark_sensitivity(pose_xy: tuple[float, float], mark_xy: tuple[float, float],
                     sensitivity: Sensitivity) -> tuple[float, float]:
    """``∂M/∂s`` of a mark estimate ``mark_xy`` made from ``pose_xy`` (see the module doc)."""
    dx, dy, dtheta = sensitivity
    rx, ry = mark_xy[0] - pose_xy[0], mark_xy[1] - pose_xy[1]
    return (dx - dtheta * ry, dy + dtheta * rx)


@dataclass(frozen=True)
class WheelRatioFit:
    """A fitted relative correction ``epsilon`` of the right wheel's scale."""

    epsilon: float
    sigma: float  # its standard error, from the residuals
    samples: int
    marks: int
    rms_mm: float  # residual scatter of the sightings after the correction


@dataclass(frozen=True)
class WheelRatioStep:
    """A calibration step: multiply the right wheel's scale by ``factor``."""

    factor: float
    scale: float  # the filtered scale after the step (relative to the uncalibrated wheel)
    scale_sigma: float  # its standard deviation
    fit: WheelRatioFit


@dataclass
class _Cluster:
    colour: str
    ref: tuple[float, float]
    points: list[tuple[float, float]] = field(default_factory=list)
    grads: list[tuple[float, float]] = field(default_factory=list)


def fit_wheel_ratio(groups: list[tuple[list[tuple[float, float]], list[tuple[float, float]]]],
                    *, noise_floor_mm: float = 5.0) -> WheelRatioFit | None:
    """Fit ε from groups of sightings of one mark each: ``(points, gradients)``.

    ``None`` when there is nothing to fit (fewer than two sightings of any mark, or gradients
    that do not vary). ``sigma`` uses the residual scatter, at least ``noise_floor_mm``.
    """
    num = den = 0.0
    n = k = 0
    centred: list[tuple[list[tuple[float, float]], list[tuple[float, float]]]] = []
    for points, grads in groups:
        if len(points) < 2:
            continue
        mx = sum(p[0] for p in points) / len(points)
        my = sum(p[1] for p in points) / len(points)
        gx = sum(g[0] for g in grads) / len(grads)
        gy = sum(g[1] for g in grads) / len(grads)
        cp = [(p[0] - mx, p[1] - my) for p in points]
        cg = [(g[0] - gx, g[1] - gy) for g in grads]
        num += sum(p[0] * g[0] + p[1] * g[1] for p, g in zip(cp, cg, strict=True))
        den += sum(g[0] * g[0] + g[1] * g[1] for g in cg)
        centred.append((cp, cg))
        n += len(points)
        k += 1
    if k == 0 or den <= 0.0:
        return None
    eps = -num / den
    sq = sum((p[0] + eps * g[0]) ** 2 + (p[1] + eps * g[1]) ** 2
             for cp, cg in centred for p, g in zip(cp, cg, strict=True))
    dof = max(2 * n - 2 * k - 1, 1)
    rms = math.sqrt(sq / dof)
    sigma = max(rms, noise_floor_mm) / math.sqrt(den)
    return WheelRatioFit(epsilon=eps, sigma=sigma, samples=n, marks=k, rms_mm=rms)


class WheelRatioCalibrator:
    """Collects sightings since the last anchor and says when a correction is due.

    Args:
        max_range_mm: sightings farther than this are ignored (coarse estimates).
        cluster_mm: sightings of one colour within this distance are one mark.
        min_samples: sightings needed before a fit.
        max_sigma: a fit is used only when its standard error is at most this.
        max_epsilon: a fitted |ε| above this is taken for a misassociation and dropped.
        max_rms_mm: a fit whose sightings still scatter more than this is dropped (the model
            does not explain them: a misassociation, a bump, a moved mark).
        max_samples: a window that never becomes precise enough ends after this many.

    Every sighting of a window must carry a sensitivity from the same anchor: re-anchor the
    odometry whenever a window starts (``samples == 0``), as :class:`~marknav.behaviours.
    perception.Perception` does.
        prior_sigma: the scale's prior standard deviation around 1.
        fit_inflation: each fit's ``sigma`` is multiplied by this in the filter.
        drift_sigma: random walk of the scale per step (lets it follow slow changes).
    """

    def __init__(self, *, max_range_mm: float = 3000.0, cluster_mm: float = 400.0,
                 min_samples: int = 12, max_sigma: float = 0.004, max_epsilon: float = 0.12,
                 max_rms_mm: float = 25.0, max_samples: int = 400, prior_sigma: float = 0.05,
                 fit_inflation: float = 2.5, drift_sigma: float = 0.001) -> None:
        self.max_range_mm = max_range_mm
        self.cluster_mm = cluster_mm
        self.min_samples = min_samples
        self.max_sigma = max_sigma
        self.max_epsilon = max_epsilon
        self.max_rms_mm = max_rms_mm
        self.max_samples = max_samples
        self.fit_inflation = fit_inflation
        self.drift_sigma = drift_sigma
        self.scale = 1.0
        self.variance = prior_sigma * prior_sigma
        self._clusters: list[_Cluster] = []
        self._count = 0
        self.rejected = 0
        #: The last fit and the window it was made of (``_window`` counts every change).
        self._window = 0
        self._fitted: tuple[int, WheelRatioFit | None] | None = None

    @property
    def samples(self) -> int:
        return self._count

    def reset(self) -> None:
        """Start a new window (call after the odometry was re-anchored)."""
        self._clusters = []
        self._count = 0
        self._window += 1

    def add(self, colour: str, pose_xy: tuple[float, float], mark_xy: tuple[float, float],
            sensitivity: Sensitivity) -> None:
        """One sighting: the mark ``colour`` estimated at ``mark_xy`` from ``pose_xy``."""
        if math.hypot(mark_xy[0] - pose_xy[0], mark_xy[1] - pose_xy[1]) > self.max_range_mm:
            return
        grad = mark_sensitivity(pose_xy, mark_xy, sensitivity)
        cluster = None
        for c in self._clusters:
            if c.colour == colour and math.hypot(mark_xy[0] - c.ref[0],
                                                 mark_xy[1] - c.ref[1]) <= self.cluster_mm:
                cluster = c
                break
        if cluster is None:
            cluster = _Cluster(colour, mark_xy)
            self._clusters.append(cluster)
        cluster.points.append(mark_xy)
        cluster.grads.append(grad)
        self._count += 1
        self._window += 1

    def fit(self) -> WheelRatioFit | None:
        """The current window's fit, whether or not it is precise enough (made again only
        when a sighting was added since the last one: most control cycles add none)."""
        if self._fitted is None or self._fitted[0] != self._window:
            self._fitted = (self._window,
                            fit_wheel_ratio([(c.points, c.grads) for c in self._clusters]))
        return self._fitted[1]

    def correction(self) -> WheelRatioStep | None:
        """A step to apply now, else ``None``. A precise fit ends the window: an implausible one
        is dropped, a plausible one updates the filtered scale and returns the step (the caller
        applies ``factor`` and re-anchors the odometry)."""
        if self._count < self.min_samples:
            return None
        result = self.fit()
        if result is None or result.sigma > self.max_sigma:
            if self._count >= self.max_samples:
                self.reset()  # never precise enough: start again
            return None
        self.reset()
        if abs(result.epsilon) > self.max_epsilon or result.rms_mm > self.max_rms_mm:
            self.rejected += 1
            return None
        measured = self.scale * (1.0 + result.epsilon)
        noise = (self.fit_inflation * result.sigma * self.scale) ** 2
        prior = self.variance + self.drift_sigma ** 2
        gain = prior / (prior + noise)
        new_scale = self.scale + gain * (measured - self.scale)
        self.variance = (1.0 - gain) * prior
        factor = new_scale / self.scale
        self.scale = new_scale
        return WheelRatioStep(factor=factor, scale=new_scale,
                              scale_sigma=math.sqrt(self.variance), fit=result)
