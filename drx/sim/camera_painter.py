"""The camera's painter: the road, borders, dashed centre line, start line and walls on a raster.

It paints the ground texture the first-person camera samples (:mod:`drx.sim.camera`,
grayscale); the top-down pictures for people (:mod:`drx.sim.pictures`, RGB) paint with it
too, so both show the same road.

A *track* here is any object with ``center``, ``inner`` and ``outer`` ((N, 2)
float64 arrays in driving order, closing duplicate kept for loops), ``closed``
(bool) and ``name`` (str), such as :class:`drx.sim.track.Track`.

World frame: metres, x to the east, y to the north, yaw in radians
counter-clockwise from +x. Images have y pointing down, so north is up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

from drx.sim.scene import (
    BORDER_LINE_WIDTH,
    CENTER_DASH,
    CENTER_GAP,
    CENTER_LINE_WIDTH,
    DEFAULT_COLORS,
    GRAY_WEIGHTS,
    RGB,
    START_LINE_WIDTH,
    FieldBox,
    SceneColors,
    to_gray,
)

# Car geometry [m] (DEEPRACER.md section 1) used to draw it.
WHEELBASE = 0.164
CAR_LENGTH = 0.20
CAR_WIDTH = 0.12

FIXED_POINT_BITS = 4  # fractional bits for cv2 drawing coordinates (1/16 px precision)
_ONE = 1 << FIXED_POINT_BITS


class TrackLike(Protocol):
    """What the renderers need from a track (duck typed; :class:`drx.sim.track.Track` fits)."""

    # Read-only (properties), so a frozen track such as drx.sim.track.Track fits.
    @property
    def name(self) -> str: ...
    @property
    def center(self) -> np.ndarray: ...
    @property
    def inner(self) -> np.ndarray: ...
    @property
    def outer(self) -> np.ndarray: ...
    @property
    def closed(self) -> bool: ...


@dataclass(frozen=True)
class GroundFrame:
    """Maps world metres to the pixels of a north-up raster.

    Pixel centres sit at integer coordinates: column ``(x - x0) / res``, row
    ``(y1 - y) / res``.
    """

    x0: float  # world x [m] of column 0
    y1: float  # world y [m] of row 0
    res: float  # metres per pixel
    width: int  # raster size [px]
    height: int

    def to_px(self, points: np.ndarray) -> np.ndarray:
        """World (k, 2) metres -> (k, 2) float pixel coordinates."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return np.column_stack(((pts[:, 0] - self.x0) / self.res, (self.y1 - pts[:, 1]) / self.res))

    def to_fixed(self, points: np.ndarray) -> np.ndarray:
        """World points -> int32 pixel coordinates with :data:`FIXED_POINT_BITS` fractional bits for cv2."""
        return np.round(self.to_px(points) * _ONE).astype(np.int32)

    @classmethod
    def fit(cls, track: TrackLike, res: float, margin: float) -> GroundFrame:
        """A frame covering the track's borders plus ``margin`` metres at ``res`` m/px."""
        pts = track_points(track)
        lo = pts.min(axis=0) - margin
        hi = pts.max(axis=0) + margin
        width = int(math.ceil((hi[0] - lo[0]) / res)) + 1
        height = int(math.ceil((hi[1] - lo[1]) / res)) + 1
        return cls(float(lo[0]), float(hi[1]), res, width, height)


def track_points(track: TrackLike) -> np.ndarray:
    """All centre and border points of a track, (3N, 2)."""
    return np.concatenate(
        [np.asarray(track.center, float), np.asarray(track.inner, float), np.asarray(track.outer, float)]
    )


def _ring(points: np.ndarray, closed: bool) -> np.ndarray:
    """The polyline with its closing point appended when a loop lacks the closing duplicate."""
    pts = np.asarray(points, dtype=np.float64)
    if closed and len(pts) > 2 and not np.allclose(pts[0], pts[-1]):
        pts = np.vstack([pts, pts[:1]])
    return pts


def _color(color: RGB | int, channels: int) -> tuple[int, ...]:
    if isinstance(color, int | np.integer):
        return (int(color),) * channels
    return tuple(color) if channels == 3 else (to_gray(color),)


def _dashes(center: np.ndarray, dash: float, gap: float) -> list[np.ndarray]:
    """Pieces of the centre polyline [m] that carry paint: ``dash`` on, ``gap`` off, from the start.

    Each dash's ends are interpolated exactly at arc lengths ``k (dash + gap)`` and
    ``k (dash + gap) + dash``, with the polyline's own vertices in between.
    """
    seg = np.linalg.norm(np.diff(center, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 1e-9])  # repeated points would break interpolation
    pts = center[keep]
    s = np.concatenate([[0.0], np.cumsum(seg[keep[1:]])])
    if s[-1] <= 0:
        return []
    starts = np.arange(0.0, s[-1], dash + gap)
    ends = np.minimum(starts + dash, s[-1])
    pieces = []
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        if b - a < 1e-4:
            continue
        inside = np.flatnonzero((s > a) & (s < b))
        arc = np.concatenate([[a], s[inside], [b]])
        pieces.append(np.column_stack((np.interp(arc, s, pts[:, 0]), np.interp(arc, s, pts[:, 1]))))
    return pieces


def _strip(points: np.ndarray, width: float) -> np.ndarray:
    """The outline [m] of a band ``width`` wide along a polyline: out along one side, back along the other."""
    tangent = np.gradient(points, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    offset = np.column_stack([-tangent[:, 1], tangent[:, 0]]) * (width / 2)
    return np.vstack([points + offset, (points - offset)[::-1]])


def _nearest_on(polyline: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The point of ``polyline`` (k, 2) nearest to ``p``."""
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0.0, 1.0)
    foot = a + t[:, None] * ab
    return foot[np.argmin(np.einsum("ij,ij->i", foot - p, foot - p))]


def _cross_line(
    center: np.ndarray, inner: np.ndarray, outer: np.ndarray, index: int
) -> tuple[np.ndarray, ...]:
    """A line across the road, perpendicular to the centre line at waypoint ``index``.

    Returns (end_a, end_b, forward) [m]: the ends reach the borders' nearest points, projected
    onto the perpendicular (DeepRacer's border rows can be skewed, so the rows themselves are not used).
    """
    c = center[index]
    seg = np.diff(center, axis=0)
    ok = np.flatnonzero(np.linalg.norm(seg, axis=1) > 1e-9)
    k = ok[np.argmin(np.abs(ok - min(index, len(seg) - 1)))]  # nearest non-degenerate segment
    fwd = seg[k] / np.linalg.norm(seg[k])
    normal = np.array([-fwd[1], fwd[0]])
    ends = [c + normal * float((_nearest_on(border, c) - c) @ normal) for border in (inner, outer)]
    return ends[0], ends[1], fwd


def _checker_cells(a: np.ndarray, b: np.ndarray, fwd: np.ndarray, cells: int) -> list[np.ndarray]:
    """Quads [m] of the dark cells of a two-row checkered band along ``a``-``b``, centred on it."""
    across = b - a
    depth = float(np.linalg.norm(across)) / cells
    quads = []
    for row in range(2):
        for i in range(cells):
            if (i + row) % 2:
                continue
            p = a + across * (i / cells) + fwd * (depth * (row - 1))
            q = a + across * ((i + 1) / cells) + fwd * (depth * (row - 1))
            quads.append(np.array([p, q, q + fwd * depth, p + fwd * depth]))
    return quads


def paint_track(
    canvas: np.ndarray,
    track: TrackLike,
    frame: GroundFrame,
    colors: SceneColors = DEFAULT_COLORS,
    *,
    checkered_start: bool = False,
    start_line: bool = True,
    antialias: bool = True,
) -> None:
    """Paint road, start line, dashed centre line and border lines onto ``canvas`` in place.

    ``canvas`` is (H, W) grayscale or (H, W, 3) RGB uint8 laid out by ``frame``. Sizes are
    DeepRacer's (:mod:`drx.sim.scene`): border lines 7.62 cm wide inside the road, centre-line
    dashes 5.08 cm long, 2.54 cm wide, every 10.16 cm. ``start_line=False`` leaves the start line
    out, as DeepRacer's reinvent_base world has none (the camera's scene); people's pictures
    keep it. Runs once per renderer, so plain loops over the waypoints are fine here.
    """
    ch = 3 if canvas.ndim == 3 else 1
    line = cv2.LINE_AA if antialias else cv2.LINE_8
    closed = bool(track.closed)
    center = _ring(track.center, closed)
    inner = _ring(track.inner, closed)
    outer = _ring(track.outer, closed)

    # Road: DeepRacer's road polygon, the area inside the outer border and outside the inner one
    # (for an open track, the polygon that runs out along one border and back along the other).
    road = _color(colors.road, ch)
    inner_px = frame.to_fixed(inner)
    outer_px = frame.to_fixed(outer)
    mask = np.zeros(canvas.shape[:2], np.uint8)
    if closed:
        cv2.fillPoly(mask, [outer_px], 255, line, FIXED_POINT_BITS)
        cv2.fillPoly(mask, [inner_px], 0, line, FIXED_POINT_BITS)
    else:
        cv2.fillPoly(mask, [np.vstack([inner_px, outer_px[::-1]])], 255, line, FIXED_POINT_BITS)
    _blend(canvas, mask, road)

    # Start line (and the finish line of an open track), across the road.
    for row in ([0] if closed else [0, len(center) - 1]) if start_line else []:
        end_a, end_b, fwd = _cross_line(center, inner, outer, row)
        pa, pb = (tuple(int(v) for v in p) for p in frame.to_fixed(np.array([end_a, end_b])))
        if checkered_start:
            cells = max(4, int(round(float(np.linalg.norm(end_b - end_a)) / 0.06)))
            depth = float(np.linalg.norm(end_b - end_a)) / cells
            thick = max(1, int(round(2 * depth / frame.res)))
            cv2.line(canvas, pa, pb, _color(colors.start, ch), thick, line, FIXED_POINT_BITS)
            dark = (20, 20, 20)[:ch]
            for quad in _checker_cells(end_a, end_b, fwd, cells):
                cv2.fillConvexPoly(canvas, frame.to_fixed(quad), dark, line, FIXED_POINT_BITS)
        else:
            thick = max(1, int(round(START_LINE_WIDTH / frame.res)))
            cv2.line(canvas, pa, pb, _color(colors.start, ch), thick, line, FIXED_POINT_BITS)

    # Dashed centre line: each dash a filled strip with square ends (thick polylines get round caps).
    dashes = _dashes(center, CENTER_DASH, CENTER_GAP)
    if dashes:
        strips = [frame.to_fixed(_strip(d, CENTER_LINE_WIDTH)) for d in dashes]
        cv2.fillPoly(canvas, strips, _color(colors.center, ch), line, FIXED_POINT_BITS)

    # Border lines: within BORDER_LINE_WIDTH of a border polyline and on the road (DeepRacer's
    # lie inside the road): a band twice as wide centred on the border, cut by the road mask.
    thick = max(1, int(round(2 * BORDER_LINE_WIDTH / frame.res)))
    band = np.zeros(canvas.shape[:2], np.uint8)
    for pts in (inner_px, outer_px):
        cv2.polylines(band, [pts], closed, 255, thick, line, FIXED_POINT_BITS)
    np.minimum(band, mask, out=band)
    _blend(canvas, band, _color(colors.border, ch))


def paint_walls(canvas: np.ndarray, frame: GroundFrame, field: FieldBox, colors: Sequence[RGB | int]) -> None:
    """Paint everything outside ``field`` with the colour of the wall in between, in place.

    ``colors`` are the west, east, south and north walls' (RGB, or grey for a 2-D canvas); the
    regions beyond the field's corners are split along the diagonals. Seen from inside, a wall
    covers exactly the ground beyond it, so the camera's ground texture carries the walls there.
    """
    ch = 3 if canvas.ndim == 3 else 1
    far = (frame.width + frame.height) * frame.res + 10.0  # beyond the raster on every side
    x0, y0, x1, y1 = field.x0, field.y0, field.x1, field.y1
    quads = (
        [(x0, y0), (x0, y1), (x0 - far, y1 + far), (x0 - far, y0 - far)],  # west
        [(x1, y1), (x1, y0), (x1 + far, y0 - far), (x1 + far, y1 + far)],  # east
        [(x1, y0), (x0, y0), (x0 - far, y0 - far), (x1 + far, y0 - far)],  # south
        [(x0, y1), (x1, y1), (x1 + far, y1 + far), (x0 - far, y1 + far)],  # north
    )
    for quad, color in zip(quads, colors, strict=True):
        pts = frame.to_fixed(np.array(quad, float))
        cv2.fillConvexPoly(canvas, pts, _color(color, ch), cv2.LINE_8, FIXED_POINT_BITS)


def _blend(canvas: np.ndarray, alpha: np.ndarray, color: tuple[int, ...]) -> None:
    """Paint ``color`` over ``canvas`` with coverage ``alpha`` (uint8, 255 = opaque), in place.

    Fully covered pixels are set outright; only the anti-aliased edge pixels are mixed, so a
    large texture costs no full-size arithmetic.
    """
    col = np.asarray(color, np.uint8)
    full = alpha == 255
    if canvas.ndim == 3:
        np.copyto(canvas, col, where=full[:, :, None])
    else:
        np.copyto(canvas, col[0], where=full)
    rows, cols = np.nonzero((alpha > 0) & ~full)
    if len(rows):
        a = alpha[rows, cols].astype(np.uint16)
        if canvas.ndim == 3:
            a = a[:, None]
        old = canvas[rows, cols].astype(np.uint16)
        canvas[rows, cols] = ((old * (255 - a) + col.astype(np.uint16) * a + 127) // 255).astype(np.uint8)


def ground_texture(shape: tuple[int, ...], res: float, colors: SceneColors, seed: int = 0) -> np.ndarray:
    """Off-track ground: the ground colour with a soft mottled texture (blobs of ~0.3 m, grain of ~6 cm).

    Deterministic (fixed seed) so that frames are reproducible. Low-frequency on purpose: fine
    grain would shimmer in the distance. Built at 2 cm/px at most and enlarged, so that a large
    fine texture costs little.
    """
    h, w = shape[:2]
    work_res = max(res, 0.02)  # the finest octave (6 cm) needs no finer raster
    wh, ww = max(2, int(round(h * res / work_res))), max(2, int(round(w * res / work_res)))
    rng = np.random.default_rng(seed)
    noise = np.zeros((wh, ww), np.float32)
    # two octaves: blobs of ~0.3 m, and a weaker grain of ~6 cm that gives a sense of motion up close
    for cell, amplitude in ((0.3, 1.0), (0.06, 0.5)):
        if cell < 2 * work_res:
            continue  # finer than the raster can show
        gh = max(2, int(math.ceil(wh * work_res / cell)) + 1)
        gw = max(2, int(math.ceil(ww * work_res / cell)) + 1)
        grid = rng.uniform(-amplitude, amplitude, size=(gh, gw)).astype(np.float32)
        noise += cv2.resize(grid, (ww, wh), interpolation=cv2.INTER_CUBIC)
    noise *= float(colors.ground_texture)
    if len(shape) == 3:
        small = np.array(colors.ground, np.float32)[None, None, :] + noise[:, :, None]
    else:
        small = to_gray(colors.ground) + noise
    small = np.clip(small, 0, 255).astype(np.uint8)
    if (wh, ww) == (h, w):
        return small
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


__all__: list[str] = [
    "GRAY_WEIGHTS",
    "DEFAULT_COLORS",
    "GroundFrame",
    "SceneColors",
    "TrackLike",
    "ground_texture",
    "paint_track",
    "paint_walls",
    "to_gray",
    "track_points",
]
