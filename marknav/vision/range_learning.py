"""Learning the range law while driving: odometry measures what the law only guesses.

A mark stands still. Seen from odometry pose ``P_i = (x, y, θ)`` with image radius ``r_i`` and
lateral offset ``l_i`` (eq. 21, which does not depend on the range law), it is placed at::

    M_i = (x, y) + Rot(θ) · (d(r_i), l_i),     d(r) = d₀ · (r / r_ref)^b

If the law is right, every sighting of one mark lands on the same point; if its scale is off,
the sightings of a mark approached from 2 m to 1 m smear along the line of sight by the error
times the metre driven, and if its exponent is off they smear more at one end than at the other.
So the law's scale ``d₀`` (and, with enough spread of radii, its exponent ``b``) is what makes
the sightings agree — the idea of :mod:`marknav.planning.wheel_ratio`, applied to the range.

:class:`RangeLawLearner` keeps the sightings, grouped by mark, and refits all of them once
some mark has been seen ``min_samples`` times across ``min_log_spread`` of ln r (or
``min_scale_samples`` times across ``min_scale_spread``: then only the scale is fitted, the
exponent held — small marks reach ``min_radius_px`` only near the bypass distance, and an
approach to them spans no more). The fit is
Gauss–Newton on ``θ = (ln d₀, b)`` with the mission's law (or the pinhole law of the
intrinsics) as prior (σ ``prior_sigma_scale`` and ``prior_sigma_exponent``), each mark's
position profiled out (its weighted mean), the residuals taken along each line of sight (where
a wrong law moves a mark; a heading error of the odometry moves it mostly across). Sightings
are weighted by the range noise (σ grows
with d²) and their information is divided by ``inflation`` (consecutive frames share their
errors). Guards:

- sightings outside ``min_range_mm``..``max_range_mm``, more than ``max_bearing_rad`` off the
  axis, smaller than ``min_radius_px``, or of marks cut by the image edge (the caller decides),
  are not added, nor any while
  the robot turns more than ``max_turn_rad`` between frames (a frame's latency then shows as a
  sideways error); after :meth:`interrupt` (a bump) new sightings are never tied
  to earlier ones, since odometry across a bump is not trusted. The radius and bearing guards
  are about the detector, not the law: a small or off-axis mark's radius is biased (in the
  simulator, through a webcam lens, a mark of ~20-27 px 20° off the axis read a median 1-2 px
  large after undistortion — mostly the radial axis undistortion over-stretched, since read
  along the lens's stretch: :func:`marknav.vision.undistort.tangential_radius`), and a bias
  of the radius that grows with range is exactly what a steeper law explains — on the long
  course such sightings pulled a correct law 16 % short at 1 m;
- the worst sightings (normalised residual above ``outlier_sigma`` × the median) are dropped
  once and the rest refitted;
- a fit whose residual stays above ``max_chi`` (the model does not explain it: two marks of one
  colour mixed up, a moved mark, a slipping wheel) or whose step would change the range at the
  latest radii by more than ``max_step`` is rejected (counted in ``rejected``).

Pure and typed: no I/O, no logging; each accepted step is returned as a :class:`RangeLawStep`
for the caller to log and report.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from marknav.vision.estimate import PowerLaw

__all__ = ["MIN_RADIUS_FRACTION", "RangeLawLearner", "RangeLawStep", "Sighting", "WindowFit",
           "fit_window"]

FloatArray = npt.NDArray[np.float64]

#: Sightings of marks whose radius is below this fraction of the image width are not learnt
#: from (29 px at 640 px, 7 px at 160 px: a 100 mm mark at ~2 m through a 57° lens, the far end
#: of the paper's Table 1). Beyond it the detector's radius (a pixel or two of blur, of the
#: half-resolution search, of the lens's stretch) is several per cent of it, and the fit read
#: that bias as a steeper law.
MIN_RADIUS_FRACTION = 0.045


@dataclass(frozen=True)
class Sighting:
    """One mark in one frame: odometry pose (mm, rad), image radius (px), lateral offset (mm,
    left positive, law-free: eq. 21) and which mark (a cluster id given by the learner)."""

    x: float
    y: float
    theta: float
    radius_px: float
    left_mm: float
    mark: int


@dataclass(frozen=True)
class WindowFit:
    """A fit's posterior: ``ln_d0`` and ``b`` with their covariance, the normalised residual
    ``chi`` (1 = as noisy as the model says), and what was used."""

    ln_d0: float
    b: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    chi: float
    samples: int
    marks: int
    dropped: int


@dataclass(frozen=True)
class RangeLawStep:
    """An accepted update: the law before and after, at ``r_ref``."""

    before: PowerLaw
    after: PowerLaw
    sigma_scale: float  # posterior σ of ln d₀ (≈ relative σ of the range at r_ref)
    sigma_exponent: float
    fit: WindowFit

    @property
    def change(self) -> float:
        """Relative change of the range of a mark the old law put at 1 m."""
        return self.after.distance_mm(self.before.radius_px(1000.0)) / 1000.0 - 1.0


def _noise_mm(d: FloatArray) -> FloatArray:
    """Expected scatter of a sighting along the line of sight at range d (mm): an eighth of a
    pixel of radius at f·R ≈ 6e4 px·mm, plus a floor for the pose."""
    return 4.0 + 0.12 * d * d / 6.0e4


def _residuals(theta: FloatArray, s: FloatArray, marks: npt.NDArray[np.intp], n_marks: int,
               r_ref: float, weights: FloatArray | None = None) -> FloatArray:
    """Weighted residuals (N) of the sightings from their marks' weighted means, along each
    sighting's line of sight: a wrong law moves a mark along it, a heading error of the odometry
    (unequal wheels, still being calibrated) mostly across it."""
    x, y, th, r, left = s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4]
    d = np.exp(theta[0]) * (r / r_ref) ** theta[1]
    c, sn = np.cos(th), np.sin(th)
    vx, vy = c * d - sn * left, sn * d + c * left
    mx, my = x + vx, y + vy
    w = 1.0 / _noise_mm(d) ** 2 if weights is None else weights
    tw = np.bincount(marks, w, n_marks)
    cx = np.bincount(marks, w * mx, n_marks) / tw
    cy = np.bincount(marks, w * my, n_marks) / tw
    norm = np.hypot(vx, vy)
    return np.sqrt(w) * ((mx - cx[marks]) * vx + (my - cy[marks]) * vy) / norm


def fit_window(sightings: Sequence[Sighting], prior: tuple[float, float],
               prior_info: FloatArray, *, r_ref: float, inflation: float = 4.0,
               outlier_sigma: float = 4.0, iterations: int = 8) -> WindowFit | None:
    """The posterior of ``(ln d₀, b)`` given sightings, from the prior mean and
    information matrix. ``None`` if no mark was seen twice."""
    marks_ids = sorted({s.mark for s in sightings})
    index = {m: i for i, m in enumerate(marks_ids)}
    counts = np.bincount([index[s.mark] for s in sightings], minlength=len(marks_ids))
    keep = [s for s in sightings if counts[index[s.mark]] >= 2]
    if not keep:
        return None
    dropped = 0
    fit = _gauss_newton(keep, prior, prior_info, r_ref, inflation, iterations)
    res, sig = fit
    per = np.abs(res)
    med = float(np.median(per)) if len(per) else 0.0
    if med > 0:
        good = [s for s, e in zip(keep, per, strict=True) if e <= outlier_sigma * med]
        if len(good) < len(keep) and len(good) >= 2:
            dropped = len(keep) - len(good)
            keep = good
            res, sig = _gauss_newton(keep, prior, prior_info, r_ref, inflation, iterations)
    theta, info = sig
    cov = np.linalg.inv(info)
    n_marks = len({s.mark for s in keep})
    dof = max(len(keep) - n_marks - 2, 1)
    chi = math.sqrt(float(res @ res) / dof)
    # Scatter beyond the noise model (χ > 1) is not information: widen the posterior by χ²
    # (else a first approach with χ 1.6 "knew" its scale to 7 % and moved a correct law 29 %).
    cov = cov * max(1.0, chi * chi)
    return WindowFit(ln_d0=float(theta[0]), b=float(theta[1]),
                     cov=((float(cov[0, 0]), float(cov[0, 1])),
                          (float(cov[1, 0]), float(cov[1, 1]))),
                     chi=chi, samples=len(keep), marks=n_marks, dropped=dropped)


def _gauss_newton(sightings: Sequence[Sighting], prior: tuple[float, float],
                  prior_info: FloatArray, r_ref: float, inflation: float,
                  iterations: int) -> tuple[FloatArray, tuple[FloatArray, FloatArray]]:
    ids = sorted({s.mark for s in sightings})
    index = {m: i for i, m in enumerate(ids)}
    arr = np.array([(s.x, s.y, s.theta, s.radius_px, s.left_mm) for s in sightings])
    marks = np.array([index[s.mark] for s in sightings], dtype=np.intp)
    mu = np.array(prior, dtype=np.float64)
    theta = mu.copy()
    k = len(ids)
    info = prior_info
    for _ in range(iterations):
        # Weights fixed at this iterate (they depend on the range only weakly).
        d = np.exp(theta[0]) * (arr[:, 3] / r_ref) ** theta[1]
        w = 1.0 / _noise_mm(d) ** 2
        e = _residuals(theta, arr, marks, k, r_ref, w)
        jac = np.empty((len(e), 2))
        for j, h in enumerate((1e-5, 1e-5)):
            t2 = theta.copy()
            t2[j] += h
            jac[:, j] = (_residuals(t2, arr, marks, k, r_ref, w) - e) / h
        jtj = jac.T @ jac / inflation
        grad = jac.T @ e / inflation + prior_info @ (theta - mu)
        info = jtj + prior_info
        step = np.linalg.solve(info, -grad)
        theta = theta + step
        if float(np.max(np.abs(step))) < 1e-6:
            break
    d = np.exp(theta[0]) * (arr[:, 3] / r_ref) ** theta[1]
    e = _residuals(theta, arr, marks, k, r_ref, 1.0 / _noise_mm(d) ** 2)
    return e, (theta, info)


@dataclass
class _Cluster:
    colour: str
    last: Sighting  # its latest sighting (placed with the current law when compared)
    id: int


@dataclass
class RangeLawLearner:
    """Learns ``d = a · r^b`` online from sightings (see the module doc).

    Every sighting is kept (the newest ``max_samples``) with the mark it belongs to; each
    :meth:`update` after ``refit_every`` new sightings refits all of them from the prior, once
    some mark has been seen ``min_samples`` times across ``min_log_spread`` of ln r (a drive of
    ~22 % of its range toward it). The long baseline of one approach is what makes the law
    observable: a mark approached from 2 m to 1 m pins the law's slope over that whole metre.
    Small marks reach ``min_radius_px`` only near the bypass distance, so an approach to them
    spans less: once some mark has ``min_scale_samples`` sightings across ``min_scale_spread``
    of ln r, the scale alone is fitted, the exponent held (random mission 531: marks of
    68.6 mm radius, a law 25 % short, no step in 101 s before, a collision).

    Args:
        prior: the law to start from (the mission's, or the pinhole law of the intrinsics).
        r_ref: reference radius (px) of the parametrisation; default the prior's radius at 1 m.
        prior_sigma_scale: σ of ln d₀ of the prior (0.3: a law 30 % off is one σ).
        prior_sigma_exponent: σ of b of the prior.
        learn_exponent: also learn b (else only the scale).
        max_sigma: a fit replaces the law only once σ of its ln d₀ is at most this.
        min_samples, min_log_spread: a full fit (scale and exponent) once some mark has this
            many sightings across this spread of ln r.
        min_scale_samples, min_scale_spread: a scale-only fit, the same way.
        max_scale_sigma: the same as ``max_sigma`` for a scale-only fit (its σ includes the
            held exponent's σ times the distance in ln r from ``r_ref``: far sightings of large
            marks stay out).
        max_turn_rad: no sightings from frames whose pose turned more than this since the
            previous frame's.
        max_bearing_rad: no sightings of marks farther off the camera's axis (0.2 rad: where
            the lens and the detector measure the radius within a pixel).
        min_radius_px: no sightings of marks smaller than this (the caller sets it from the
            image width: :data:`MIN_RADIUS_FRACTION`).
    """

    prior: PowerLaw
    r_ref: float = 0.0
    prior_sigma_scale: float = 0.3
    prior_sigma_exponent: float = 0.1
    learn_exponent: bool = True
    max_range_mm: float = 3000.0
    min_range_mm: float = 250.0
    cluster_mm: float = 300.0
    cluster_fraction: float = 0.2
    min_samples: int = 30
    min_log_spread: float = 0.25
    min_scale_samples: int = 20
    min_scale_spread: float = 0.12
    max_scale_sigma: float = 0.05
    max_samples: int = 600
    refit_every: int = 10
    inflation: float = 2.0
    outlier_sigma: float = 4.0
    max_chi: float = 4.0
    max_step: float = 0.4
    max_sigma: float = 0.08
    max_turn_rad: float = 0.01
    max_bearing_rad: float = 0.2
    min_radius_px: float = 0.0
    steps: list[RangeLawStep] = field(default_factory=list)
    rejected: int = 0
    _sightings: list[Sighting] = field(default_factory=list)
    _clusters: list[_Cluster] = field(default_factory=list)
    _next_id: int = 0
    _new: int = 0
    _last_pose: tuple[float, float, float] | None = None
    _turning: bool = False
    _theta: tuple[float, float] = (0.0, 0.0)
    _theta0: tuple[float, float] = (0.0, 0.0)
    _info0: FloatArray = field(default_factory=lambda: np.zeros((2, 2)))
    _cov: FloatArray = field(default_factory=lambda: np.zeros((2, 2)))

    def __post_init__(self) -> None:
        if self.r_ref <= 0:
            self.r_ref = self.prior.radius_px(1000.0)
        self._theta0 = (math.log(self.prior.distance_mm(self.r_ref)), self.prior.b)
        self._theta = self._theta0
        sb = self.prior_sigma_exponent if self.learn_exponent else 1e-6
        self._info0 = np.diag([1.0 / self.prior_sigma_scale ** 2, 1.0 / sb ** 2])
        self._cov = np.asarray(np.linalg.inv(self._info0), dtype=np.float64)

    @property
    def law(self) -> PowerLaw:
        """The current law."""
        ln_d0, b = self._theta
        return PowerLaw(a=math.exp(ln_d0) * self.r_ref ** (-b), b=b)

    @property
    def samples(self) -> int:
        return len(self._sightings)

    @property
    def sigma(self) -> tuple[float, float]:
        """Current σ of (ln d₀, b)."""
        return (math.sqrt(float(self._cov[0, 0])), math.sqrt(float(self._cov[1, 1])))

    def interrupt(self) -> None:
        """Odometry is not to be trusted across this moment (a bump, a re-anchored wheel):
        sightings from now on belong to new marks, never tied to the ones before."""
        self._clusters = []

    def add(self, colour: str, pose: tuple[float, float, float], radius_px: float,
            left_mm: float) -> None:
        """One sighting of a ``colour`` mark from odometry ``pose`` (x, y, θ)."""
        if not (radius_px > 0 and math.isfinite(radius_px) and math.isfinite(left_mm)):
            return
        if radius_px < self.min_radius_px:
            return  # too few pixels: the radius's bias is a large part of it
        if pose != self._last_pose:  # a new frame: is the robot turning?
            last, self._last_pose = self._last_pose, pose
            self._turning = last is not None and abs(
                math.remainder(pose[2] - last[2], 2.0 * math.pi)) > self.max_turn_rad
        if self._turning:
            return  # a frame's latency shows up as a sideways error while the robot turns
        d = self.law.distance_mm(radius_px)
        if not self.min_range_mm <= d <= self.max_range_mm:
            return
        if abs(math.atan2(left_mm, d)) > self.max_bearing_rad:
            return
        x, y, th = pose
        mx, my = self._place(x, y, th, radius_px, left_mm)
        gate = max(self.cluster_mm, self.cluster_fraction * math.hypot(d, left_mm))
        near = []
        for c in self._clusters:
            if c.colour == colour:
                # The cluster's latest sighting, placed with today's law (it may have changed
                # since): a mark followed frame by frame stays one cluster.
                cx, cy = self._place(c.last.x, c.last.y, c.last.theta, c.last.radius_px,
                                     c.last.left_mm)
                g = math.hypot(mx - cx, my - cy)
                if g <= gate:
                    near.append((g, c))
        if near:
            cluster = min(near, key=lambda gc: gc[0])[1]
        else:
            cluster = _Cluster(colour, Sighting(x, y, th, radius_px, left_mm, self._next_id),
                               self._next_id)
            self._next_id += 1
            self._clusters.append(cluster)
        sighting = Sighting(x, y, th, radius_px, left_mm, cluster.id)
        cluster.last = sighting
        self._sightings.append(sighting)
        if len(self._sightings) > self.max_samples:
            del self._sightings[: len(self._sightings) - self.max_samples]
        self._new += 1

    def _place(self, x: float, y: float, th: float, radius_px: float,
               left_mm: float) -> tuple[float, float]:
        d = self.law.distance_mm(radius_px)
        return (x + math.cos(th) * d - math.sin(th) * left_mm,
                y + math.sin(th) * d + math.cos(th) * left_mm)

    def _ready(self) -> tuple[bool, bool]:
        """(a full fit is due, a scale-only fit is due): some mark's sightings are many and
        spread enough for each."""
        by_mark: dict[int, list[float]] = {}
        for s in self._sightings:
            by_mark.setdefault(s.mark, []).append(s.radius_px)
        spreads = [(len(r), math.log(max(r)) - math.log(min(r))) for r in by_mark.values()]
        return (any(n >= self.min_samples and d >= self.min_log_spread for n, d in spreads),
                any(n >= self.min_scale_samples and d >= self.min_scale_spread
                    for n, d in spreads))

    def update(self) -> RangeLawStep | None:
        """Refit when due; an accepted fit replaces the law and is returned."""
        if self._new < self.refit_every:
            return None
        full, scale_only = self._ready()
        if not full and not scale_only:
            return None
        self._new = 0
        theta0, info0 = self._theta0, self._info0
        if not full:  # too little spread of radii to pin the exponent: hold it, fit the scale
            theta0, info0 = (theta0[0], self._theta[1]), np.diag([info0[0, 0], 1e12])
        fit = fit_window(self._sightings, theta0, info0, r_ref=self.r_ref,
                         inflation=self.inflation, outlier_sigma=self.outlier_sigma)
        if fit is None:
            return None
        if not full:
            # The range is pinned at the sightings' radii; at r_ref it is as uncertain as the
            # held exponent makes the extrapolation (L = ln(r̄ / r_ref)).
            sb2 = float(self._cov[1, 1])
            ell = float(np.mean([math.log(s.radius_px / self.r_ref) for s in self._sightings]))
            fit = replace(fit, b=theta0[1], cov=((fit.cov[0][0] + sb2 * ell * ell, -sb2 * ell),
                                                 (-sb2 * ell, sb2)))
        before = self.law
        after_b = fit.b if self.learn_exponent else before.b
        after = PowerLaw(a=math.exp(fit.ln_d0) * self.r_ref ** (-after_b), b=after_b)
        radii = [s.radius_px for s in self._sightings[-self.refit_every * 4:]]
        change = max(abs(after.distance_mm(r) / before.distance_mm(r) - 1.0)
                     for r in (min(radii), max(radii)))
        if math.sqrt(fit.cov[0][0]) > (self.max_sigma if full else self.max_scale_sigma):
            return None  # not precise enough yet: keep the law, keep collecting
        if fit.chi > self.max_chi or change > self.max_step or not -2.0 < after_b < -0.4:
            self.rejected += 1
            return None
        self._theta = (fit.ln_d0, after_b)
        self._cov = np.array(fit.cov, dtype=np.float64)
        sig = self.sigma
        step = RangeLawStep(before=before, after=after, sigma_scale=sig[0], sigma_exponent=sig[1],
                            fit=fit)
        self.steps.append(step)
        return step
