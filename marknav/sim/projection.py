"""The marks' rims through the pinhole camera: projection, near-plane clip, the fill's inset.

Every frame projects each mark in front of the camera (``RIM_POINTS`` rim points) and moves each
polygon in by the anti-aliased fill's reach before it is drawn. As NumPy calls on 96-point
arrays this cost ≈ 0.17 ms a frame, almost all of it the calls (≈ 7 % of a simulated control
cycle); :func:`rim_projection` and :func:`inset` do the same arithmetic in one compiled call
each (:mod:`marknav.core.compiled`). ``tests/sim/test_builtin_camera_fast_paths.py`` checks the
projection bit for bit against one-rim-at-a-time NumPy and the inset against the NumPy inset it
replaced.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt

from marknav.core.compiled import compiled_ieee

if TYPE_CHECKING:
    from marknav.planning.kinematics import Pose
    from marknav.sim.world.schema import World


class CameraConfig(Protocol):
    """What projecting needs of a pinhole camera (:class:`marknav.sim.builtin_camera.CameraConfig`
    is
    one): image size (px), focal length and principal point (px), the camera's offset ahead of
    the robot's centre and its near plane (mm)."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def focal_px(self) -> float: ...
    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def forward_offset_mm(self) -> float: ...
    @property
    def near_mm(self) -> float: ...

__all__ = ["RIM_POINTS", "MarkGeometry", "ProjectedMark", "clip_near", "inset", "rim_projection",
           "warm_up"]

FloatArray = npt.NDArray[np.float64]

#: Points on a mark's rim; with the area-matched radius the polygon's area equals the disc's.
RIM_POINTS = 96


@dataclass(frozen=True)
class ProjectedMark:
    """A mark as the camera sees it: ``polygon`` is its rim in pixels (u right, v down), clipped
    at the near plane; (u, v) is the projection of its centre; ``depth_mm`` the centre's distance
    along the camera axis."""

    index: int
    depth_mm: float
    u: float
    v: float
    polygon: FloatArray

    @functools.cached_property
    def bbox(self) -> tuple[float, float, float, float]:
        """(u_min, v_min, u_max, v_max) of the rim (computed once: the renderer and the
        visibility test both ask)."""
        lo = self.polygon.min(axis=0)
        hi = self.polygon.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def inside(self, config: CameraConfig, margin_px: float = 0.0) -> bool:
        """Whether the whole rim lies in the image, ``margin_px`` from its edges."""
        u0, v0, u1, v1 = self.bbox
        return (u0 >= margin_px and v0 >= margin_px and u1 <= config.width - 1 - margin_px
                and v1 <= config.height - 1 - margin_px)

    def visible(self, config: CameraConfig) -> bool:
        """Whether any of the rim's box overlaps the image."""
        u0, v0, u1, v1 = self.bbox
        return u1 >= -0.5 and v1 >= -0.5 and u0 <= config.width - 0.5 and v0 <= config.height - 0.5


@compiled_ieee
def rim_projection(rims: FloatArray, keep: npt.NDArray[np.intp], ox: float, oy: float,
                   c: float, s: float, f: float, cx: float, cy: float, near: float,
                   width: float, height: float,
                   ) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_],
                              npt.NDArray[np.bool_]]:
    """The rims ``keep`` (indices into ``rims``, marks × points × (x, y, height)) seen from a
    camera at (``ox``, ``oy``) with heading cosine/sine ``c``, ``s``: camera coordinates
    (x right, y down, z forward; rows × points × 3), pixels (u, v), each rim's box (u_lo, v_lo,
    u_hi, v_hi), whether it lies wholly beyond the near plane and whether its box meets the
    image. Each number is the one NumPy's element-wise expressions give (same operations, same
    order; a point at z = 0 projects to ±inf or nan)."""
    k, n = len(keep), rims.shape[1]
    xyz = np.empty((k, n, 3))
    uv = np.empty((k, n, 2))
    boxes = np.empty((k, 4))
    whole = np.empty(k, np.bool_)
    shown = np.empty(k, np.bool_)
    for row in range(k):
        j = keep[row]
        z_lo = np.inf
        u_lo = v_lo = np.inf
        u_hi = v_hi = -np.inf
        for i in range(n):
            dx = rims[j, i, 0] - ox
            dy = rims[j, i, 1] - oy
            z = dx * c + dy * s
            x = dx * s - dy * c
            y = -rims[j, i, 2]
            u = cx + f * x / z
            v = cy + f * y / z
            xyz[row, i, 0] = x
            xyz[row, i, 1] = y
            xyz[row, i, 2] = z
            uv[row, i, 0] = u
            uv[row, i, 1] = v
            z_lo = min(z_lo, z)
            u_lo = min(u_lo, u)
            u_hi = max(u_hi, u)
            v_lo = min(v_lo, v)
            v_hi = max(v_hi, v)
        boxes[row, 0] = u_lo
        boxes[row, 1] = v_lo
        boxes[row, 2] = u_hi
        boxes[row, 3] = v_hi
        whole[row] = z_lo > near
        shown[row] = (u_hi >= -0.5 and v_hi >= -0.5 and u_lo <= width - 0.5
                      and v_lo <= height - 0.5)
    return xyz, uv, boxes, whole, shown


@compiled_ieee
def inset(poly: FloatArray, by: float) -> FloatArray:
    """A convex polygon's vertices moved inward by ``by`` px (limited for very thin polygons
    to half their mean half-width: 0.25·2A/P), each along the normal of the chord between its
    neighbours; a polygon of no area is returned as it is (a copy)."""
    n = len(poly)
    out = poly.copy()
    forward = backward = perimeter = 0.0
    for i in range(n):
        nxt = (i + 1) % n
        forward += poly[i, 0] * poly[nxt, 1]
        backward += poly[nxt, 0] * poly[i, 1]
        ex = poly[nxt, 0] - poly[i, 0]
        ey = poly[nxt, 1] - poly[i, 1]
        perimeter += math.sqrt(ex * ex + ey * ey)
    area2 = forward - backward
    if area2 == 0.0:
        return out
    by = min(by, 0.25 * abs(area2) / perimeter)
    signed = math.copysign(by, area2)
    for i in range(n):
        nxt = (i + 1) % n
        prv = (i - 1) % n
        tx = poly[nxt, 0] - poly[prv, 0]
        ty = poly[nxt, 1] - poly[prv, 1]
        norm = math.sqrt(tx * tx + ty * ty)
        if norm == 0.0:
            norm = 1.0
        k = signed / norm
        out[i, 0] -= ty * k
        out[i, 1] += tx * k
    return out


def clip_near(pts: FloatArray, near: float) -> FloatArray:
    """Sutherland–Hodgman clip of a closed 3-D polygon to z ≥ near: for each edge a → b, a if
    it is in front, then the edge's crossing of the plane if it crosses (all edges at once)."""
    nxt = np.roll(pts, -1, axis=0)
    a_in = pts[:, 2] >= near
    cross = a_in != (nxt[:, 2] >= near)
    a, b = pts[cross], nxt[cross]
    t = (near - a[:, 2]) / (b[:, 2] - a[:, 2])
    crossings = a + t[:, None] * (b - a)
    # Output order: vertex i (slot 2i), then the crossing of edge i (slot 2i + 1).
    slots = np.concatenate([2 * np.nonzero(a_in)[0], 2 * np.nonzero(cross)[0] + 1])
    return np.concatenate([pts[a_in], crossings])[np.argsort(slots)]


class MarkGeometry:
    """The marks' rims in world coordinates (x, y, height above the camera: the world's
    ``mark_height_offset_mm`` lifts them), computed once."""

    def __init__(self, world: World) -> None:
        #: The marks' centres above the camera (mm): world.conditions.mark_height_offset_mm.
        self.lift_mm = float(world.conditions.mark_height_offset_mm)
        n = RIM_POINTS
        phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
        # Area-matched polygon: (n/2)·ρ²·sin(2π/n) = π·R².
        k = math.sqrt((2.0 * math.pi / n) / math.sin(2.0 * math.pi / n))
        rims = np.empty((len(world.marks), n, 3))
        centres = np.empty((len(world.marks), 2))
        for j, m in enumerate(world.marks):
            r = m.radius() * k
            ax, ay = math.cos(m.yaw_rad), math.sin(m.yaw_rad)  # in-plane horizontal axis
            rims[j, :, 0] = m.x_mm + r * np.cos(phi) * ax
            rims[j, :, 1] = m.y_mm + r * np.cos(phi) * ay
            rims[j, :, 2] = r * np.sin(phi) + self.lift_mm
            centres[j] = m.xy
        self.rims = rims
        self.centres = centres
        self.radii = np.array([m.radius() for m in world.marks])

    def project(self, pose: Pose, config: CameraConfig) -> list[ProjectedMark]:
        """The marks any part of which the camera at ``pose`` sees, far to near."""
        if len(self.centres) == 0:
            return []
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        ox = pose.x + config.forward_offset_mm * c
        oy = pose.y + config.forward_offset_mm * s
        # Camera frame: Z forward (heading), X right (heading − 90°), Y down.
        dcx = self.centres[:, 0] - ox
        dcy = self.centres[:, 1] - oy
        zc = dcx * c + dcy * s
        keep = np.nonzero(zc + self.radii > config.near_mm)[0]
        if len(keep) == 0:
            return []
        out: list[ProjectedMark] = []
        f, cx, cy = config.focal_px, config.cx, config.cy
        # Every kept rim in one call; a rim crossing the near plane is clipped and projected
        # again on its own below.
        xyz, uv, boxes, whole, shown = rim_projection(
            self.rims, keep, float(ox), float(oy), c, s, float(f), float(cx), float(cy),
            float(config.near_mm), float(config.width), float(config.height))
        for row, j in enumerate(keep.tolist()):
            if not whole[row]:
                pts = clip_near(xyz[row], config.near_mm)
                if len(pts) < 3:
                    continue
                x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
                poly = np.stack([cx + f * x / z, cy + f * y / z], axis=1)
                bbox = None
            elif shown[row]:
                poly = uv[row]
                u_lo, v_lo, u_hi, v_hi = boxes[row].tolist()
                bbox = (u_lo, v_lo, u_hi, v_hi)
            else:
                continue
            zj = float(zc[j])
            xj = float(dcx[j] * s - dcy[j] * c)
            u = cx + f * xj / zj if zj > config.near_mm else math.nan
            v = cy - f * self.lift_mm / zj if zj > config.near_mm else math.nan
            pm = ProjectedMark(index=j, depth_mm=zj, u=u, v=v, polygon=poly)
            if bbox is not None:
                pm.__dict__["bbox"] = bbox  # the cached_property's value, already known
            elif not pm.visible(config):
                continue
            out.append(pm)
        out.sort(key=lambda p: -p.depth_mm)  # painter's order: far to near
        return out


def warm_up() -> None:
    """Compile the loops (or load them from the cache) now, at set-up, not in the first frame."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    inset(square, 0.1)
    rim_projection(np.zeros((1, 3, 3)), np.zeros(1, np.intp), 0.0, 0.0, 1.0, 0.0, 1.0, 0.0,
                   0.0, 1.0, 1.0, 1.0)
