"""Boxes (and bot cars) standing on the ground, projected into the front camera and filled in.

:class:`BoxProjector` does for :class:`~drx.sim.camera.CameraRenderer` what its ground warp
cannot: objects that stand up from the ground plane. Each box is 8 corners; its visible
faces (at most two sides and the top) are filled, far boxes first, with a grey that
depends on the face (a fixed light from the north-east, the top lit from above).

Speed (the race envs render a box in about every second frame, twice for a stereo car):

* scalar Python per box (8 corners are far below the size where NumPy pays off); boxes
  clearly outside the view cone are culled before any projection;
* a box that does not move (object avoidance) keeps its world geometry (corners, side
  normals and greys) in a small cache keyed by its row, so a frame only turns it into
  camera coordinates;
* the stereo cameras share one projection: they differ by a sideways shift, so a corner's
  row is the same in both and its column moves by ``f * shift / depth``;
* each eye writes the corners of the visible faces, face after face, into one scratch array
  and fills every face from a slice of it (no per-face array building).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import cv2
import numpy as np

DEFAULT_BOX_HEIGHT = 0.2  # [m] height of an obstacle box given without one
NEAR = 0.01  # [m] near clipping plane for boxes
LIGHT = (0.6, 0.8)  # horizontal direction towards the light, for shading box sides
_CACHE_SIZE = 64  # static boxes whose geometry is kept
_TOP = (4, 5, 6, 7)
_SIDES = tuple((i, (i + 1) % 4, (i + 1) % 4 + 4, i + 4) for i in range(4))


def _geometry(box: Sequence[float], gray: float) -> tuple[Any, ...]:
    """A box's world geometry: ground corners, height, top grey and its sides.

    Sides are ``(face, nx, ny, mx, my, grey)``: the face's corner indices, its outward normal,
    the middle of its ground edge and its grey.
    """
    if len(box) > 5:
        bx, by, byaw, blen, bwid, bh = (float(v) for v in box[:6])
    else:
        bx, by, byaw, blen, bwid = (float(v) for v in box[:5])
        bh = DEFAULT_BOX_HEIGHT
    cb, sb = math.cos(byaw), math.sin(byaw)
    ax, ay = 0.5 * blen * cb, 0.5 * blen * sb  # half length along the box
    wx, wy = -0.5 * bwid * sb, 0.5 * bwid * cb  # half width to its left
    # ground corners counter-clockwise seen from above
    ground = (
        (bx + ax + wx, by + ay + wy),
        (bx - ax + wx, by - ay + wy),
        (bx - ax - wx, by - ay - wy),
        (bx + ax - wx, by + ay - wy),
    )
    sides = []
    # outward normals of sides 0-1, 1-2, 2-3, 3-0: +width, -length, -width, +length
    for i, (nx, ny) in enumerate(((-sb, cb), (-cb, -sb), (sb, -cb), (cb, sb))):
        j = (i + 1) % 4
        mx, my = 0.5 * (ground[i][0] + ground[j][0]), 0.5 * (ground[i][1] + ground[j][1])
        # fixed light from the north-east: sides facing it are a little brighter
        light = 0.8 + 0.15 * (nx * LIGHT[0] + ny * LIGHT[1])
        sides.append((_SIDES[i], nx, ny, mx, my, int(min(255, round(gray * light)))))
    top = int(min(255, round(gray * 1.1)))  # the top, lit from above
    return ground, bh, top, tuple(sides)


class BoxProjector:
    """Projects boxes into a pinhole camera and fills them into its frames.

    :param focal: focal length [px].
    :param center: principal point ``(cx, cy)`` [px].
    :param pitch: downward tilt [rad].
    :param mount_forward: camera ahead of the rear axle [m].
    :param mount_height: camera above the ground [m].
    :param hfov: horizontal field of view [rad].
    :param gray: the boxes' grey (0-255).
    """

    def __init__(
        self,
        focal: float,
        center: tuple[float, float],
        pitch: float,
        mount_forward: float,
        mount_height: float,
        hfov: float,
        gray: float,
    ) -> None:
        self.focal = focal
        self.cx, self.cy = center
        self.sin_p, self.cos_p = math.sin(pitch), math.cos(pitch)
        self.mount_forward, self.mount_height = mount_forward, mount_height
        self.tan_half = math.tan(hfov / 2)
        self.gray = gray
        self._static: dict[tuple[float, ...], tuple[Any, ...]] = {}
        self._pts = np.empty((20, 2), np.int32)  # an eye's corners of up to 5 faces

    def _geometry_of(self, box: Sequence[float]) -> tuple[Any, ...]:
        key = tuple(box)
        geo = self._static.get(key)
        if geo is None:
            if len(self._static) >= _CACHE_SIZE:
                self._static.clear()
            geo = self._static[key] = _geometry(box, self.gray)
        return geo

    def shapes(
        self, x: float, y: float, yaw: float, boxes: Iterable[Sequence[float]], margin: float
    ) -> list[tuple[Any, ...]]:
        """Project boxes for the (middle) camera of a car at ``(x, y, yaw)``, far ones first.

        Boxes are rows ``(x, y, yaw, length, width[, height])``. Boxes clearly outside the view
        cone (widened by ``margin`` m for stereo) are culled. A box wholly in front of the near
        plane (the usual case) becomes ``(False, x_over_z, f_over_z, rows16, grays)``: the corners
        of its visible faces, face after face (4 each), with ``f X / Z``, ``f / Z`` and the row in
        1/16 px (int32, shared by both stereo eyes), and each face's grey; one
        that reaches behind it becomes ``(True, faces)`` of near-plane-clipped camera points.
        """
        c, s = math.cos(yaw), math.sin(yaw)
        cam_x = x + c * self.mount_forward
        cam_y = y + s * self.mount_forward
        h = self.mount_height
        tan_half = self.tan_half
        items = []
        for box in boxes:
            bx, by = box[0], box[1]
            dx, dy = bx - cam_x, by - cam_y
            fwd, left = c * dx + s * dy, -s * dx + c * dy
            r = 0.5 * math.hypot(box[3], box[4])
            if fwd + r < NEAR:
                continue  # behind the camera
            # a ground point shows only if |left| <= Zc tan(hfov/2), and Zc <= fwd + h
            if abs(left) - r - margin > (fwd + r + h) * tan_half + 0.01:
                continue
            items.append((dx * dx + dy * dy, box))
        if not items:
            return []
        if len(items) > 1:
            items.sort(key=lambda item: -item[0])
        sp, cp, f, cy = self.sin_p, self.cos_p, self.focal, self.cy
        y0, z0 = cp * h, sp * h  # a ground point's camera y and z before its forward distance
        shapes: list[tuple[Any, ...]] = []
        for _, box in items:
            ground, bh, top, sides = self._geometry_of(box)
            # camera coordinates (OpenCV axes) of the 4 ground corners, then the 4 top corners
            xs, ys, zs = [], [], []
            for gx, gy in ground:
                dx, dy = gx - cam_x, gy - cam_y
                fwd = c * dx + s * dy
                xs.append(s * dx - c * dy)
                ys.append(y0 - sp * fwd)
                zs.append(cp * fwd + z0)
            dy_top, dz_top = -cp * bh, -sp * bh
            xs += xs
            ys += [v + dy_top for v in ys]
            zs += [v + dz_top for v in zs]
            # visible faces: the top when below the camera, sides facing it
            faces: list[tuple[tuple[int, int, int, int], int]] = [(_TOP, top)] if bh < h else []
            for face, nx, ny, mx, my, g in sides:
                if nx * (cam_x - mx) + ny * (cam_y - my) > 0:
                    faces.append((face, g))
            if min(zs) >= NEAR:
                # the visible faces' corners one after another (face k at rows 4k..4k+3 of the
                # eye's point array): per corner f X / Z and f / Z, and the row in 1/16 px
                order = [k for face, _ in faces for k in face]
                inv = [f / z for z in zs]
                shapes.append(
                    (
                        False,
                        [xs[k] * inv[k] for k in order],
                        [inv[k] for k in order],
                        np.array([round((ys[k] * inv[k] + cy) * 16) for k in order], np.int32),
                        [g for _, g in faces],
                    )
                )
            else:
                cam = list(zip(xs, ys, zs, strict=True))
                clipped = [(clip_near([cam[k] for k in idx]), g) for idx, g in faces]
                shapes.append((True, [(poly, g) for poly, g in clipped if len(poly) >= 3]))
        return shapes

    def draw(self, out: np.ndarray, shapes: list[tuple[Any, ...]], lateral: float) -> None:
        """Fill projected boxes into ``out`` for the camera ``lateral`` m left of the middle."""
        cx, cy, f = self.cx, self.cy, self.focal
        fill, aa = cv2.fillConvexPoly, cv2.LINE_AA
        pts = self._pts
        for shape in shapes:
            if not shape[0]:
                _, fx, inv, rows16, grays = shape
                n = len(fx)
                # a camera `lateral` m to the left sees every point `lateral` m further right
                pts[:n, 0] = [round((u + lateral * k + cx) * 16) for u, k in zip(fx, inv, strict=True)]
                pts[:n, 1] = rows16
                for j, g in enumerate(grays):
                    fill(out, pts[4 * j : 4 * j + 4], g, aa, 4)
                continue
            for poly, g in shape[1]:
                corners = np.array(
                    [
                        (round((f * (px + lateral) / pz + cx) * 16), round((f * py / pz + cy) * 16))
                        for px, py, pz in poly
                    ],
                    np.int32,
                )
                fill(out, corners, g, aa, 4)


def clip_near(poly: list[tuple[float, float, float]]) -> list[tuple[float, float, float]]:
    """Clip a convex polygon in camera coordinates to the half-space Z >= near (Sutherland-Hodgman)."""
    if all(p[2] >= NEAR for p in poly):
        return poly
    kept = []
    n = len(poly)
    for i in range(n):
        p, q = poly[i], poly[(i + 1) % n]
        p_in, q_in = p[2] >= NEAR, q[2] >= NEAR
        if p_in:
            kept.append(p)
        if p_in != q_in:
            t = (NEAR - p[2]) / (q[2] - p[2])
            kept.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), NEAR))
    return kept


__all__ = ["BoxProjector", "DEFAULT_BOX_HEIGHT", "clip_near"]
