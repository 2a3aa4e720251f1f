"""Range calibration: fit the power law d = a · r^b (paper eq. 19) to measured (radius, distance).

The paper measured a mark straight ahead of the camera from 2000 mm down to 300 mm in 100 mm
steps (Table 1) and fitted a power law. Fitting a straight line to (ln r, ln d) by least squares
gives exactly the paper's a = 58958, b = −0.9434 for its table.

``r2`` is the coefficient of determination in log space (the space the fit minimises);
``max_rel_error`` is the largest |fitted − measured| / measured over the rows, in distance.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from marknav.core.errors import InputError
from marknav.core.figures import save_figure
from marknav.core.inputfile import MAX_TABLE_BYTES, read_text
from marknav.vision.estimate import PowerLaw

HEADER = ("radius_px", "distance_mm")
MIN_ROWS = 3
#: Longest cell accepted (a number needs a few characters; the csv module's own limit is 128 k).
MAX_CELL = 40
#: Plausible measurements: an image radius up to 100 000 px, a distance up to 1 km.
MAX_VALUE = {"radius_px": 1e5, "distance_mm": 1e6}
#: The radii must differ by at least 1 % (ln 1.01), or the slope b is noise.
MIN_LOG_SPREAD = math.log(1.01)


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


class FitError(ValueError):
    """The rows do not determine a usable law (radii too close, distance growing with the
    radius, numbers out of range)."""


@dataclass(frozen=True)
class CalibrationRow:
    radius_px: float
    distance_mm: float
    fitted_mm: float
    line: int | None = None  # line in the source table, when read from a file

    @property
    def rel_error(self) -> float:
        return (self.fitted_mm - self.distance_mm) / self.distance_mm

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "radius_px": self.radius_px,
            "distance_mm": self.distance_mm,
            "fitted_mm": round(self.fitted_mm, 3),
            "residual_mm": round(self.distance_mm - self.fitted_mm, 3),
            "rel_error": round(self.rel_error, 6),
        }
        if self.line is not None:
            out["line"] = self.line
        return out


@dataclass(frozen=True)
class PowerFit:
    """The fitted law, its quality and every row's residual."""

    a: float
    b: float
    r2: float
    rows: tuple[CalibrationRow, ...]

    @property
    def model(self) -> PowerLaw:
        return PowerLaw(self.a, self.b)

    @property
    def max_rel_error(self) -> float:
        return max(abs(r.rel_error) for r in self.rows)

    def worst_rows(self, n: int = 3) -> list[CalibrationRow]:
        return sorted(self.rows, key=lambda r: abs(r.rel_error), reverse=True)[:n]

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": "power",
            "a": self.a,
            "b": self.b,
            "r2": self.r2,
            "max_rel_error": self.max_rel_error,
            "rows": [r.to_dict() for r in self.rows],
        }

    def yaml_snippet(self) -> str:
        """The line to paste under ``camera:`` in a mission."""
        return f"range: {{model: power, a: {self.a:.6g}, b: {self.b:.6g}}}"


def fit_power_law(
    radii_px: Sequence[float],
    distances_mm: Sequence[float],
    lines: Sequence[int | None] | None = None,
) -> PowerFit:
    """Least-squares fit of ln d = ln a + b · ln r (eq. 19). Needs ≥ 3 positive rows and at
    least two different radii."""
    r = np.asarray(radii_px, dtype=float)
    d = np.asarray(distances_mm, dtype=float)
    if r.shape != d.shape or r.ndim != 1:
        raise ValueError("radii and distances must be 1-D sequences of the same length")
    if len(r) < MIN_ROWS:
        raise ValueError(f"need at least {MIN_ROWS} rows to fit, got {len(r)}")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(d)) and np.all(r > 0) and np.all(d > 0)):
        raise ValueError("radii and distances must be finite and positive")
    lr, ld = np.log(r), np.log(d)
    if np.ptp(lr) == 0:
        raise FitError("all radii are equal: the law cannot be fitted")
    if np.ptp(lr) < MIN_LOG_SPREAD:
        raise FitError(f"the radii differ by less than 1 % ({r.min():g} to {r.max():g} px): "
                       "the law cannot be fitted; measure over a wider range of distances")
    b, ln_a = (float(v) for v in np.polyfit(lr, ld, 1))
    if not (math.isfinite(b) and math.isfinite(ln_a)):
        raise FitError("the fit did not converge (numbers out of range)")
    if b >= 0:
        raise FitError(f"the fitted distance grows with the radius (b = {b:.4g} ≥ 0): a mark "
                       "must look smaller when farther; check the columns are radius_px, "
                       "distance_mm")
    if ln_a > 700:  # exp overflows near 709.8; no camera has a ~1e304
        raise FitError(f"the fitted law is out of range (a = e^{ln_a:.4g}); check the table")
    a = math.exp(ln_a)
    pred = ln_a + b * lr
    ss_res = float(np.sum((ld - pred) ** 2))
    ss_tot = float(np.sum((ld - ld.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    law = PowerLaw(a, float(b))
    line_list = list(lines) if lines is not None else [None] * len(r)
    rows = tuple(
        CalibrationRow(float(ri), float(di), law.distance_mm(float(ri)), ln)
        for ri, di, ln in zip(r, d, line_list, strict=True)
    )
    return PowerFit(a=a, b=float(b), r2=r2, rows=rows)


def read_table(path: str | Path) -> tuple[list[float], list[float], list[int]]:
    """Read a ``radius_px,distance_mm`` CSV; every problem is an :class:`InputError` naming the
    file and line. Blank lines and lines starting with ``#`` are ignored."""
    name = str(path)
    text = read_text(path, limit=MAX_TABLE_BYTES, what="a CSV table")  # BOM dropped
    radii: list[float] = []
    dists: list[float] = []
    lines: list[int] = []
    header_seen = False
    for lineno, raw in enumerate(text.splitlines(), start=1):
        if len(raw) > 2 * MAX_CELL + 8:
            raise InputError(f"line too long ({len(raw)} characters) for a "
                             "radius_px,distance_mm row", file=name, line=lineno)
        try:
            row = next(csv.reader([raw]), [])
        except csv.Error as exc:
            raise InputError(f"not a CSV row: {exc}", file=name, line=lineno) from None
        cells = [c.strip() for c in row]
        if not cells or all(c == "" for c in cells) or cells[0].startswith("#"):
            continue
        if not header_seen:
            if tuple(c.lower() for c in cells) != HEADER:
                raise InputError(
                    f"expected the header 'radius_px,distance_mm', got {','.join(cells)!r}",
                    file=name, line=lineno,
                )
            header_seen = True
            continue
        if len(cells) != 2:
            raise InputError(f"expected 2 values, got {len(cells)}", file=name, line=lineno)
        values: list[float] = []
        for field, cell in zip(HEADER, cells, strict=True):
            if len(cell) > MAX_CELL or not _NUMBER.fullmatch(cell):
                shown = cell if len(cell) <= MAX_CELL else cell[:MAX_CELL] + "…"
                raise InputError(f"not a number: {shown!r}", file=name, line=lineno,
                                 field=field)
            v = float(cell)
            if not math.isfinite(v) or v <= 0:
                raise InputError(f"must be a positive number, got {cell}", file=name,
                                 line=lineno, field=field)
            if v > MAX_VALUE[field]:
                raise InputError(f"out of range: {cell} (at most {MAX_VALUE[field]:g})",
                                 file=name, line=lineno, field=field)
            values.append(v)
        radii.append(values[0])
        dists.append(values[1])
        lines.append(lineno)
    if not header_seen:
        raise InputError("empty table: expected the header 'radius_px,distance_mm'", file=name,
                         line=1)
    if len(radii) < MIN_ROWS:
        raise InputError(f"need at least {MIN_ROWS} rows to fit, got {len(radii)}", file=name)
    if len(set(radii)) < 2:
        raise InputError("all radii are equal: the law cannot be fitted", file=name)
    return radii, dists, lines


def fit_table(path: str | Path) -> PowerFit:
    """Read a calibration CSV and fit it; a table that cannot be fitted is an
    :class:`InputError` naming the file."""
    radii, dists, lines = read_table(path)
    try:
        return fit_power_law(radii, dists, lines)
    except FitError as exc:
        raise InputError(str(exc), file=str(path)) from None


def plot_fit(fit: PowerFit, out: str | Path, title: str = "Range calibration") -> None:
    """Draw the measured rows and the fitted law (needs matplotlib: the ``plot`` extra)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(
            "--plot needs matplotlib: install it with  pip install 'marknav[plot]'"
        ) from None
    r = np.array([row.radius_px for row in fit.rows])
    d = np.array([row.distance_mm for row in fit.rows])
    grid = np.linspace(r.min() * 0.9, r.max() * 1.1, 200)
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
    ax.plot(r, d, "o", label="measured")
    ax.plot(grid, fit.a * grid**fit.b, "-",
            label=f"d = {fit.a:.0f} · r^{fit.b:.4f}  (R² = {fit.r2:.5f})")
    ax.set_xlabel("image radius r [px]")
    ax.set_ylabel("distance d [mm]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    # below the axes: inside, it would sit on the measured rows or the curve
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=8,
              frameon=False)
    save_figure(fig, out)
