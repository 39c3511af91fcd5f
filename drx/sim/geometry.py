"""Small, vectorised plane-geometry helpers shared by the track and the env.

Everything here works on NumPy arrays of points shaped ``(k, 2)`` in metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_angle(a: float) -> float:
    """Wrap an angle [rad] to [-pi, pi)."""
    return (a + math.pi) % TWO_PI - math.pi


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """Vectorised :func:`wrap_angle`."""
    return (a + np.pi) % TWO_PI - np.pi


def signed_area(poly: np.ndarray) -> float:
    """Shoelace signed area [m^2] of a polygon (closing duplicate optional); > 0 when counter-clockwise."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def nearest_on_polyline(points: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point on a polyline for each query point.

    :param points: ``(k, 2)`` query points.
    :param line: ``(n, 2)`` polyline vertices (zero-length segments allowed).
    :return: ``(feet, dist)``: the ``(k, 2)`` nearest points and their ``(k,)`` distances.
    """
    a = line[:-1]
    d = line[1:] - a
    dd = np.einsum("ij,ij->i", d, d)
    inv = np.divide(1.0, dd, out=np.zeros_like(dd), where=dd > 0)
    rel = points[:, None, :] - a[None, :, :]  # (k, n-1, 2)
    t = np.clip(np.einsum("kij,ij->ki", rel, d) * inv, 0.0, 1.0)
    foot = a[None] + t[..., None] * d[None]
    dist2 = np.sum((points[:, None, :] - foot) ** 2, axis=2)
    best = np.argmin(dist2, axis=1)
    rows = np.arange(len(points))
    return foot[rows, best], np.sqrt(dist2[rows, best])


class Corner(NamedTuple):
    """A corner of a track, for ``drx track show`` and tests.

    :param start_s: where the curve starts [m along the centre line].
    :param end_s: where it ends [m].
    :param apex_s: the point of highest curvature [m].
    :param angle_deg: total heading change [deg], + = left.
    :param radius: smallest radius of the centre line in the corner [m].
    """

    start_s: float
    end_s: float
    apex_s: float
    angle_deg: float
    radius: float


def curvature_profile(
    heading_at: Callable[[Any], Any], length: float, closed: bool, step: float, window: float
) -> tuple[np.ndarray, np.ndarray]:
    """Signed curvature [1/m] of a line given its heading function, sampled every ``step`` m and
    smoothed as the heading change over ``±window`` m."""
    s = np.arange(0.0, length, step)
    ahead, behind = np.asarray(heading_at(s + window)), np.asarray(heading_at(s - window))
    if closed:
        span = np.full_like(s, 2.0 * window)
    else:  # near the ends the window is cut short
        span = np.minimum(s + window, length) - np.maximum(s - window, 0.0)
    return s, wrap_angles(ahead - behind) / np.maximum(span, 1e-9)


def find_corners(
    s: np.ndarray, k: np.ndarray, step: float, closed: bool, min_angle_deg: float, max_radius: float
) -> list[Corner]:
    """Group a curvature profile into corners: same-sign runs tighter than ``max_radius`` turning
    at least ``min_angle_deg``."""
    sign = np.where(k > 1.0 / max_radius, 1, np.where(k < -1.0 / max_radius, -1, 0))
    runs: list[list[int]] = []
    for i, sg in enumerate(sign):
        if sg and runs and sign[runs[-1][-1]] == sg and runs[-1][-1] == i - 1:
            runs[-1].append(i)
        elif sg:
            runs.append([i])
    wraps = closed and len(runs) > 1 and runs[0][0] == 0 and runs[-1][-1] == len(s) - 1
    if wraps and sign[0] == sign[-1]:
        runs[0] = runs.pop() + runs[0]  # a corner spanning the start line
    out = []
    for run in runs:
        angle = math.degrees(float(np.sum(k[run])) * step)
        if abs(angle) >= min_angle_deg:
            apex = run[int(np.argmax(np.abs(k[run])))]
            radius = 1.0 / float(abs(k[apex]))
            out.append(Corner(float(s[run[0]]), float(s[run[-1]]), float(s[apex]), angle, radius))
    return out


def rasterise_road(
    inner: np.ndarray, outer: np.ndarray, closed: bool, resolution: float
) -> tuple[np.ndarray, float, float]:
    """Rasterise the road surface as DeepRacer's road polygon: outer minus inner for loops, the
    strip outer + reversed inner for open tracks.

    :return: ``(mask, x0, y0)``: uint8 mask, pixel ``[iy, ix]`` centred at ``(x0 + ix*res, y0 + iy*res)``.
    """
    import cv2  # loaded when a road is rasterised, not by every command that imports tracks

    pts = np.vstack([inner, outer])
    margin = 0.05
    x0, y0 = float(pts[:, 0].min()) - margin, float(pts[:, 1].min()) - margin
    w = int(math.ceil((float(pts[:, 0].max()) + margin - x0) / resolution)) + 1
    h = int(math.ceil((float(pts[:, 1].max()) + margin - y0) / resolution)) + 1
    shift = 4  # sub-pixel precision for fillPoly

    def pix(poly: np.ndarray) -> np.ndarray:
        q = (poly - (x0, y0)) / resolution * (1 << shift)
        return np.round(q).astype(np.int32).reshape(-1, 1, 2)

    mask = np.zeros((h, w), dtype=np.uint8)
    if closed:
        cv2.fillPoly(mask, [pix(outer)], 1, lineType=cv2.LINE_8, shift=shift)
        cv2.fillPoly(mask, [pix(inner)], 0, lineType=cv2.LINE_8, shift=shift)
    else:
        cv2.fillPoly(mask, [pix(np.vstack([outer, inner[::-1]]))], 1, lineType=cv2.LINE_8, shift=shift)
    mask.setflags(write=False)
    return mask, x0, y0


def width_table(
    center: np.ndarray, cum: np.ndarray, inner: np.ndarray, outer: np.ndarray, step: float
) -> np.ndarray:
    """Road width every ``step`` m along the centre line, measured as DeepRacer does: the distance
    between the inner-border point and the outer-border point nearest to the centre-line point
    (skewed border rows make the row-wise distance overstate it)."""
    s = np.arange(0.0, float(cum[-1]) + step, step)
    pts = np.stack([np.interp(s, cum, center[:, 0]), np.interp(s, cum, center[:, 1])], axis=1)
    widths = np.empty(len(s))
    for k0 in range(0, len(s), 500):  # chunks bound the (k, n, 2) temporaries
        chunk = pts[k0 : k0 + 500]
        fi, _ = nearest_on_polyline(chunk, inner)
        fo, _ = nearest_on_polyline(chunk, outer)
        widths[k0 : k0 + 500] = np.hypot(*(fi - fo).T)
    return widths
