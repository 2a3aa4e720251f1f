"""Camera calibration from photographs of a chessboard (OpenCV's method, Zhang 2000).

Each image must show the whole board; its inner corners are found
(``cv2.findChessboardCorners``), refined to a tenth of a pixel (``cv2.cornerSubPix``), and
``cv2.calibrateCamera`` fits the camera matrix and the distortion coefficients (k1, k2, p1, p2,
k3) to all of them. The result's RMS is the reprojection error over every corner, in pixels;
0.1–0.5 px is a good calibration, above 1 px something moved (a blurred view, a bent board).

Every problem with the input is an :class:`~marknav.core.errors.InputError` naming the file: an
unreadable image, no board found, images of different sizes, fewer than :data:`MIN_IMAGES`
usable images.
"""

from __future__ import annotations

import contextlib
import logging
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.errors import InputError
from marknav.core.figures import save_figure
from marknav.vision.imagefile import read_image
from marknav.vision.undistort import Intrinsics

__all__ = ["MIN_IMAGES", "BoardView", "CameraCalibration", "calibrate_images", "find_board",
           "parse_board", "write_opencv_yml"]

log = logging.getLogger(__name__)

#: Fewer views than this leave the fit underdetermined or meaningless.
MIN_IMAGES = 3
#: Fewest inner corners along a side: OpenCV's chessboard finder needs more than 2.
MIN_CORNERS = 3
#: Most inner corners along a side: a printed board with squares big enough to find (a 50-square
#: side of A3 has 8 mm squares).
MAX_CORNERS = 50
#: Square sides accepted (mm): from a fine printed target to a floor-sized board.
MIN_SQUARE_MM = 0.5
MAX_SQUARE_MM = 1000.0
_SUBPIX = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)

FloatArray = npt.NDArray[np.float64]


def parse_board(text: str) -> tuple[int, int]:
    """``"9x6"`` → (9, 6): inner corners per row and per column (both ≥ 2)."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if m is None:
        raise InputError(f"expected COLSxROWS inner corners (e.g. 9x6), got {text!r}",
                         field="--board")
    cols, rows = int(m.group(1)), int(m.group(2))
    if min(cols, rows) < MIN_CORNERS or max(cols, rows) > MAX_CORNERS:
        raise InputError(f"a board has {MIN_CORNERS} to {MAX_CORNERS} inner corners a side "
                         f"(e.g. 9x6), got {text.strip()}", field="--board")
    return cols, rows


@dataclass(frozen=True)
class BoardView:
    """One image in which the board was found: its file and its refined corners (N×2 px)."""

    path: str
    size: tuple[int, int]  # (width, height)
    corners: FloatArray


@dataclass(frozen=True)
class CameraCalibration:
    """The fitted camera: intrinsics, RMS reprojection error (px) and each view's error."""

    intrinsics: Intrinsics
    rms_px: float
    image_size: tuple[int, int]
    board: tuple[int, int]
    square_mm: float
    images_used: tuple[str, ...]
    per_view_px: tuple[float, ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        i = self.intrinsics
        return {"fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy, "dist": list(i.dist),
                "rms": self.rms_px, "images_used": list(self.images_used),
                "image_size": list(self.image_size)}

    def yaml_snippet(self) -> str:
        """The block to paste under ``camera:`` in a mission."""
        i = self.intrinsics
        dist = ", ".join(f"{c:.6g}" for c in i.dist)
        return (f"intrinsics: {{fx: {i.fx:.2f}, fy: {i.fy:.2f}, cx: {i.cx:.2f}, "
                f"cy: {i.cy:.2f}, dist: [{dist}]}}")


def write_opencv_yml(cal: CameraCalibration, out: str | Path) -> None:
    """Write ``cal`` in OpenCV's FileStorage YAML, with the node names of OpenCV's own
    calibration sample (``samples/cpp/calibration.cpp``): ``camera_matrix`` (3×3),
    ``distortion_coefficients`` (5×1: k1, k2, p1, p2, k3), ``image_width``, ``image_height``
    (px), ``avg_reprojection_error`` (px), ``per_view_reprojection_errors`` (px),
    ``nframes``, ``board_width``, ``board_height`` (inner corners) and ``square_size`` (mm;
    OpenCV's sample leaves the unit to the user). ``cv2.FileStorage(path, READ)`` reads it."""
    name = str(out)
    # Built in memory and written by Python: OpenCV's own file writer reports no error (on a
    # full disk it left a 0-byte file and the command said "written").
    fs = cv2.FileStorage(name, cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY
                         | cv2.FILE_STORAGE_FORMAT_YAML)
    i = cal.intrinsics
    w, h = cal.image_size
    try:
        fs.write("nframes", len(cal.images_used))
        fs.write("image_width", int(w))
        fs.write("image_height", int(h))
        fs.write("board_width", int(cal.board[0]))
        fs.write("board_height", int(cal.board[1]))
        fs.write("square_size", float(cal.square_mm))
        fs.write("camera_matrix", np.asarray(i.matrix, dtype=np.float64))
        fs.write("distortion_coefficients",
                 np.asarray(i.dist, dtype=np.float64).reshape(-1, 1))
        fs.write("avg_reprojection_error", float(cal.rms_px))
        if cal.per_view_px:
            fs.write("per_view_reprojection_errors",
                     np.asarray(cal.per_view_px, dtype=np.float64).reshape(-1, 1))
    finally:
        text = fs.releaseAndGetString()
    try:
        with open(name, "w", encoding="utf-8") as fh:
            fh.write(text)
    except OSError as exc:
        with contextlib.suppress(OSError):  # no half file left to be read as a calibration
            Path(name).unlink(missing_ok=True)
        raise InputError(f"cannot write: {exc.strerror or exc}", file=name) from None


def _read_grey(path: str) -> npt.NDArray[np.uint8]:
    return read_image(path, grey=True)


def find_board(path: str, board: tuple[int, int]) -> BoardView:
    """The board's inner corners in ``path``; :class:`InputError` if unreadable or not found."""
    grey = _read_grey(path)
    found, corners = cv2.findChessboardCorners(
        grey, board, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not found or corners is None:
        raise InputError(f"no {board[0]}x{board[1]} chessboard found (is the whole board in "
                         "view, and --board the number of INNER corners?)", file=path)
    corners = cv2.cornerSubPix(grey, corners, (11, 11), (-1, -1), _SUBPIX)
    h, w = grey.shape[:2]
    return BoardView(path=path, size=(w, h), corners=np.asarray(corners, dtype=np.float64)
                     .reshape(-1, 2))


def calibrate_images(paths: Sequence[str], board: tuple[int, int],
                     square_mm: float) -> CameraCalibration:
    """Calibrate from chessboard photographs (every one must show the board)."""
    if not (math.isfinite(square_mm) and square_mm > 0):
        raise InputError(f"must be a positive number, got {square_mm:g}", field="--square-mm")
    if not MIN_SQUARE_MM <= square_mm <= MAX_SQUARE_MM:
        raise InputError(f"must be from {MIN_SQUARE_MM:g} to {MAX_SQUARE_MM:g} mm, got "
                         f"{square_mm:g}", field="--square-mm")
    if len(paths) < MIN_IMAGES:
        raise InputError(f"need at least {MIN_IMAGES} images of the board, got {len(paths)}")
    views: list[BoardView] = []
    for path in paths:
        view = find_board(path, board)
        if views and view.size != views[0].size:
            w0, h0 = views[0].size
            raise InputError(f"image is {view.size[0]}x{view.size[1]}, but {views[0].path} is "
                             f"{w0}x{h0}: calibrate one camera at one resolution", file=path)
        views.append(view)
        log.debug("%s: board found", path)
    cols, rows = board
    obj = np.zeros((cols * rows, 3), np.float32)
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * float(square_mm)
    size = views[0].size
    rms, k, dist, _rv, _tv, _std_in, _std_ex, per_view = cv2.calibrateCameraExtended(
        [obj] * len(views), [v.corners.astype(np.float32).reshape(-1, 1, 2) for v in views],
        size, np.eye(3), np.zeros(5))
    coeffs = tuple(float(c) for c in np.asarray(dist).ravel()[:5])
    intr = Intrinsics(fx=float(k[0, 0]), fy=float(k[1, 1]), cx=float(k[0, 2]),
                      cy=float(k[1, 2]), dist=coeffs)
    return CameraCalibration(
        intrinsics=intr, rms_px=float(rms), image_size=size, board=board,
        square_mm=float(square_mm), images_used=tuple(v.path for v in views),
        per_view_px=tuple(float(e) for e in np.asarray(per_view).ravel()))


def plot_calibration(cal: CameraCalibration, out: str | Path) -> None:
    """The corners of every view over the image, and the lens's distortion field (arrows from
    where the ideal pinhole camera would image a grid to where this lens does)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(
            "--plot needs matplotlib: install it with  pip install 'marknav[plot]'") from None
    w, h = cal.image_size
    i = cal.intrinsics
    gx, gy = np.meshgrid(np.linspace(0, w - 1, 17), np.linspace(0, h - 1, 13))
    ideal = np.stack([gx.ravel(), gy.ravel()], axis=1)
    norm = np.stack([(ideal[:, 0] - i.cx) / i.fx, (ideal[:, 1] - i.cy) / i.fy,
                     np.ones(len(ideal))], axis=1)
    seen, _ = cv2.projectPoints(norm, np.zeros(3), np.zeros(3), i.matrix, i.coefficients)
    seen = seen.reshape(-1, 2)
    fig, ax = plt.subplots(figsize=(9.6, 5.6), dpi=100)
    ax.quiver(ideal[:, 0], ideal[:, 1], seen[:, 0] - ideal[:, 0], seen[:, 1] - ideal[:, 1],
              angles="xy", scale_units="xy", scale=1.0, color="0.4", width=0.002,
              label="distortion (ideal → imaged)")
    for n, (path, err) in enumerate(zip(cal.images_used, cal.per_view_px, strict=False)):
        view = find_board(path, cal.board)
        ax.plot(view.corners[:, 0], view.corners[:, 1], ".", ms=2,
                label=f"{Path(path).name} ({err:.2f} px)" if n < 14 else None)
    ax.plot([i.cx], [i.cy], "k+", ms=12, label="principal point")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("image column u [px]")
    ax.set_ylabel("image row v [px]")
    ax.set_title(f"fx {i.fx:.1f}  fy {i.fy:.1f}  cx {i.cx:.1f}  cy {i.cy:.1f}  "
                 f"RMS {cal.rms_px:.3f} px", fontsize=10)
    # beside the image, never on the corners or the arrows; per-view RMS in px
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), ncol=1,
              title="corners per view (RMS)", title_fontsize=7, frameon=False)
    save_figure(fig, out)
