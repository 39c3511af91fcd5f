"""Drawing the track: the shared scene painter and the top-down view for people.

The same painter draws the ground texture the first-person camera samples
(:mod:`drx.sim.camera`, grayscale) and the top-down picture used for videos and
``drx track show --png`` (RGB), so both show the same road, borders, dashed
centre line and start line.

A *track* here is any object with ``center``, ``inner`` and ``outer`` ((N, 2)
float64 arrays in driving order, closing duplicate kept for loops), ``closed``
(bool) and ``name`` (str), such as :class:`drx.sim.track.Track`.

World frame: metres, x to the east, y to the north, yaw in radians
counter-clockwise from +x. Images have y pointing down, so north is up.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
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

_SHIFT = 4  # fractional bits for cv2 drawing coordinates (1/16 px precision)
_ONE = 1 << _SHIFT


class TrackLike(Protocol):
    """What the renderers need from a track (duck typed; :class:`drx.sim.track.Track` fits)."""

    name: str
    center: np.ndarray
    inner: np.ndarray
    outer: np.ndarray
    closed: bool


BOT_COLOR = (40, 90, 220)  # RGB of bot cars in the top-down view


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
        """World points -> int32 pixel coordinates with :data:`_SHIFT` fractional bits for cv2."""
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
        cv2.fillPoly(mask, [outer_px], 255, line, _SHIFT)
        cv2.fillPoly(mask, [inner_px], 0, line, _SHIFT)
    else:
        cv2.fillPoly(mask, [np.vstack([inner_px, outer_px[::-1]])], 255, line, _SHIFT)
    _blend(canvas, mask, road)

    # Start line (and the finish line of an open track), across the road.
    for row in ([0] if closed else [0, len(center) - 1]) if start_line else []:
        end_a, end_b, fwd = _cross_line(center, inner, outer, row)
        pa, pb = (tuple(int(v) for v in p) for p in frame.to_fixed(np.array([end_a, end_b])))
        if checkered_start:
            cells = max(4, int(round(float(np.linalg.norm(end_b - end_a)) / 0.06)))
            depth = float(np.linalg.norm(end_b - end_a)) / cells
            thick = max(1, int(round(2 * depth / frame.res)))
            cv2.line(canvas, pa, pb, _color(colors.start, ch), thick, line, _SHIFT)
            dark = (20, 20, 20)[:ch]
            for quad in _checker_cells(end_a, end_b, fwd, cells):
                cv2.fillConvexPoly(canvas, frame.to_fixed(quad), dark, line, _SHIFT)
        else:
            thick = max(1, int(round(START_LINE_WIDTH / frame.res)))
            cv2.line(canvas, pa, pb, _color(colors.start, ch), thick, line, _SHIFT)

    # Dashed centre line: each dash a filled strip with square ends (thick polylines get round caps).
    dashes = _dashes(center, CENTER_DASH, CENTER_GAP)
    if dashes:
        strips = [frame.to_fixed(_strip(d, CENTER_LINE_WIDTH)) for d in dashes]
        cv2.fillPoly(canvas, strips, _color(colors.center, ch), line, _SHIFT)

    # Border lines: within BORDER_LINE_WIDTH of a border polyline and on the road (DeepRacer's
    # lie inside the road): a band twice as wide centred on the border, cut by the road mask.
    thick = max(1, int(round(2 * BORDER_LINE_WIDTH / frame.res)))
    band = np.zeros(canvas.shape[:2], np.uint8)
    for pts in (inner_px, outer_px):
        cv2.polylines(band, [pts], closed, 255, thick, line, _SHIFT)
    np.minimum(band, mask, out=band)
    _blend(canvas, band, _color(colors.border, ch))


def paint_walls(canvas: np.ndarray, frame: GroundFrame, field: FieldBox, colors: Sequence[RGB]) -> None:
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
        cv2.fillConvexPoly(canvas, pts, _color(color, ch), cv2.LINE_8, _SHIFT)


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


def _frame_for_canvas(track: TrackLike, width: int, height: int, margin_px: int) -> GroundFrame:
    """The frame that fits the track, centred, into a ``width`` x ``height`` image."""
    pts = track_points(track)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi - lo, 1e-3)
    res = max(span[0] / max(width - 2 * margin_px, 1), span[1] / max(height - 2 * margin_px, 1))
    mid = (lo + hi) / 2
    x0 = mid[0] - (width - 1) / 2 * res
    y1 = mid[1] + (height - 1) / 2 * res
    return GroundFrame(float(x0), float(y1), float(res), width, height)


def _paint_grid(canvas: np.ndarray, frame: GroundFrame, spacing: float, color: RGB) -> None:
    """Faint metre grid so that a person can judge distances."""
    x_start = math.ceil(frame.x0 / spacing) * spacing
    y_end = frame.y1 - (frame.height - 1) * frame.res
    y_start = math.ceil(y_end / spacing) * spacing
    for gx in np.arange(x_start, frame.x0 + frame.width * frame.res, spacing):
        c = int(round((gx - frame.x0) / frame.res))
        canvas[:, c] = color
    for gy in np.arange(y_start, frame.y1, spacing):
        r = int(round((frame.y1 - gy) / frame.res))
        canvas[r, :] = color


def _panel_size(canvas: np.ndarray, lines: list[str]) -> tuple[int, int, float, int, int]:
    """A text panel's (width, height) [px], font scale, line step and baseline for ``lines``."""
    h, w = canvas.shape[:2]
    scale = max(0.4, min(h, w) / 960)
    (_, th), base = cv2.getTextSize("Ag", cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    step = th + base + 6
    width = max(cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0] for t in lines) + 16
    return min(w, width), min(h, step * len(lines) + 8), scale, step, base


def _text_panel(canvas: np.ndarray, lines: list[str], at: tuple[int, int] = (0, 0)) -> None:
    """Lines of white text on a translucent dark panel with its top-left corner at ``at`` (x, y)."""
    if not lines:
        return
    width, height, scale, step, base = _panel_size(canvas, lines)
    x0, y0 = at
    x1, y1 = min(canvas.shape[1], x0 + width), min(canvas.shape[0], y0 + height)
    canvas[y0:y1, x0:x1] = (canvas[y0:y1, x0:x1] * 0.45).astype(np.uint8)
    for i, text in enumerate(lines):
        cv2.putText(
            canvas,
            text,
            (x0 + 8, y0 + 4 + step * (i + 1) - base),
            cv2.FONT_HERSHEY_SIMPLEX,
            scale,
            (255, 255, 255),
            1,
            cv2.LINE_AA,
        )


Corner = str  # "top-left", "top-right", "bottom-left" or "bottom-right"
CORNERS: tuple[Corner, ...] = ("top-left", "bottom-left", "top-right", "bottom-right")


def _corner_origin(
    corner: Corner, size: tuple[int, int], canvas: tuple[int, int], pad: int, bottom: int
) -> tuple[int, int]:
    """The (x, y) [px] where a ``size`` (w, h) box sits in ``corner`` of a (w, h) canvas."""
    (bw, bh), (w, h) = size, canvas
    x = pad if corner.endswith("left") else w - bw - pad
    y = pad if corner.startswith("top") else h - bh - pad - bottom
    return max(0, x), max(0, y)


class TopDownRenderer:
    """The whole track from above with the car, for people (videos, ``render_mode="rgb_array"``).

    :param track: the track (see :class:`TrackLike`).
    :param size: (width, height) of the picture [px]; multiples of 16 suit video encoders.
    :param colors: scene colours.
    :param min_car_length_px: the car is drawn at least this long, so that it stays visible
        on large tracks (its true footprint is about 0.20 x 0.12 m).
    """

    def __init__(
        self,
        track: TrackLike,
        size: tuple[int, int] = (640, 480),
        colors: SceneColors = DEFAULT_COLORS,
        min_car_length_px: float = 16.0,
    ) -> None:
        width, height = int(size[0]), int(size[1])
        if width < 32 or height < 32:
            raise ValueError(f"top-down size {size} is too small; use at least 32 x 32 px")
        self.track = track
        self.size = (width, height)
        self.colors = colors
        margin = max(8, min(width, height) // 20)
        self.frame = _frame_for_canvas(track, width, height, margin)
        px_per_m = 1.0 / self.frame.res
        self.car_scale = max(1.0, min_car_length_px / (CAR_LENGTH * px_per_m))
        bg = ground_texture((height, width, 3), self.frame.res, colors)
        paint_walls(bg, self.frame, FieldBox.around(track_points(track)), [colors.wall] * 4)
        _paint_grid(bg, self.frame, 1.0, tuple(int(v * 0.9) for v in colors.ground))
        paint_track(bg, track, self.frame, colors, checkered_start=True)
        self._background = bg
        self.bottom_reserve = 0  # [px] kept clear at the bottom edge (a video's gauges)
        self._panel_corner: Corner = "top-left"

    @property
    def background(self) -> np.ndarray:
        """The static picture (track without car), (H, W, 3) RGB uint8; do not modify."""
        return self._background

    def car_polygon(self, x: float, y: float, yaw: float) -> np.ndarray:
        """The drawn (exaggerated) car footprint as (4, 2) world points [m].

        ``(x, y)`` is the rear-axle centre; the body is centred half a wheelbase ahead of it.
        """
        c, s = math.cos(yaw), math.sin(yaw)
        cx, cy = x + c * WHEELBASE / 2, y + s * WHEELBASE / 2
        hl, hw = CAR_LENGTH / 2 * self.car_scale, CAR_WIDTH / 2 * self.car_scale
        local = np.array([[hl, hw], [hl, -hw], [-hl, -hw], [-hl, hw]])
        rot = np.array([[c, -s], [s, c]])
        return local @ rot.T + np.array([cx, cy])

    def render(
        self,
        x: float,
        y: float,
        yaw: float,
        trail: np.ndarray | Sequence[Sequence[float]] | None = None,
        camera_frame: np.ndarray | None = None,
        text_lines: Iterable[str] | None = None,
        boxes: Iterable[Sequence[float]] | None = None,
        cars: Iterable[Sequence[float]] | None = None,
    ) -> np.ndarray:
        """The picture with the car at rear-axle ``(x, y)`` [m] heading ``yaw`` [rad].

        :param trail: (k, 2) world points [m] of the path so far, drawn as a polyline.
        :param camera_frame: a camera observation ((120, 160), (120, 160, 1) or (120, 160, 2)
            uint8; stereo shows the left camera) drawn as an inset in the top-right corner.
        :param text_lines: lines of text drawn in the top-left corner.
        :param boxes: obstacles as rows ``(x, y, yaw, length, width[, height])`` [m, rad].
        :param cars: other cars (head-to-bot's bots) as rows ``(x, y, yaw, ...)`` of their body
            centre [m, rad], drawn like the car in blue.
        :returns: (H, W, 3) uint8 RGB, a new array.
        """
        img = self._background.copy()
        fr = self.frame
        if trail is not None:
            pts = np.asarray(trail, dtype=np.float64).reshape(-1, 2)
            if len(pts) >= 2:
                cv2.polylines(img, [fr.to_fixed(pts)], False, (255, 120, 0), 2, cv2.LINE_AA, _SHIFT)
        if boxes is not None:
            for box in boxes:
                bx, by, byaw, blen, bwid = (float(v) for v in list(box)[:5])
                cb, sb = math.cos(byaw), math.sin(byaw)
                local = np.array([[blen, bwid], [blen, -bwid], [-blen, -bwid], [-blen, bwid]]) / 2
                quad = local @ np.array([[cb, -sb], [sb, cb]]).T + np.array([bx, by])
                cv2.fillConvexPoly(img, fr.to_fixed(quad), self.colors.box, cv2.LINE_AA, _SHIFT)
                cv2.polylines(img, [fr.to_fixed(quad)], True, (60, 40, 20), 1, cv2.LINE_AA, _SHIFT)
        if cars is not None:
            for row in cars:
                cx, cy, cyaw = (float(v) for v in list(row)[:3])
                back = WHEELBASE / 2  # the drawing takes the rear axle, half a wheelbase behind the centre
                self._draw_car(img, cx - back * math.cos(cyaw), cy - back * math.sin(cyaw), cyaw, BOT_COLOR)
        self._draw_car(img, x, y, yaw)
        lines = [str(t) for t in text_lines] if text_lines is not None else []
        panel = self._place_panel(img, lines, (x, y)) if lines else None
        if camera_frame is not None:
            self._draw_inset(img, camera_frame, (x, y), avoid=panel)
        if panel is not None:
            _text_panel(img, lines, panel[1])
        return img

    def car_px(self, xy: tuple[float, float]) -> tuple[float, float]:
        """The car's (column, row) [px] in the picture."""
        c, r = self.frame.to_px(np.array([xy]))[0]
        return float(c), float(r)

    def car_reach_px(self) -> float:
        """How far [px] from its reference point the drawn car reaches, with a margin."""
        return 0.6 * CAR_LENGTH * self.car_scale / self.frame.res + 6

    def _covers_car(
        self, origin: tuple[int, int], size: tuple[int, int], car_xy: tuple[float, float]
    ) -> bool:
        (x0, y0), (bw, bh) = origin, size
        c, r = self.car_px(car_xy)
        reach = self.car_reach_px()
        return x0 - reach <= c <= x0 + bw + reach and y0 - reach <= r <= y0 + bh + reach

    def _place_panel(
        self, img: np.ndarray, lines: list[str], car_xy: tuple[float, float]
    ) -> tuple[Corner, tuple[int, int]]:
        """Where the text panel goes: its corner as last time, unless the car is under it; then
        the first corner clear of the car (it stays there until the car comes by again)."""
        h, w = img.shape[:2]
        width, height = _panel_size(img, lines)[:2]
        order = [self._panel_corner, *(c for c in CORNERS if c != self._panel_corner)]
        for corner in order:
            origin = _corner_origin(corner, (width, height), (w, h), 0, self.bottom_reserve)
            if not self._covers_car(origin, (width, height), car_xy):
                self._panel_corner = corner
                return corner, origin
        corner = self._panel_corner
        return corner, _corner_origin(corner, (width, height), (w, h), 0, self.bottom_reserve)

    def _draw_car(
        self, img: np.ndarray, x: float, y: float, yaw: float, color: tuple[int, int, int] = (220, 30, 30)
    ) -> None:
        fr = self.frame
        body = self.car_polygon(x, y, yaw)
        cv2.fillConvexPoly(img, fr.to_fixed(body), color, cv2.LINE_AA, _SHIFT)
        cv2.polylines(img, [fr.to_fixed(body)], True, (20, 20, 20), 1, cv2.LINE_AA, _SHIFT)
        # a white nose triangle shows which way the car faces
        front_l, front_r, rear_r, rear_l = body
        mid_l = front_l * 0.55 + rear_l * 0.45
        mid_r = front_r * 0.55 + rear_r * 0.45
        nose = (front_l + front_r) / 2
        tip = nose * 0.9 + (mid_l + mid_r) * 0.05
        tri = np.array([mid_l * 0.75 + mid_r * 0.25, mid_r * 0.75 + mid_l * 0.25, tip])
        cv2.fillConvexPoly(img, fr.to_fixed(tri), (255, 255, 255), cv2.LINE_AA, _SHIFT)

    def _draw_inset(
        self,
        img: np.ndarray,
        camera_frame: np.ndarray,
        car_xy: tuple[float, float],
        avoid: tuple[Corner, tuple[int, int]] | None = None,
    ) -> None:
        """Draw the camera frame, white-framed, top right (another corner when the car, or the text
        panel ``avoid``, is there)."""
        cam = np.asarray(camera_frame)
        if cam.ndim == 3:
            cam = cam[:, :, 0]
        if cam.dtype != np.uint8:
            cam = np.clip(cam, 0, 255).astype(np.uint8)
        h, w = img.shape[:2]
        scale = max(1, int(min(w * 0.35 / cam.shape[1], h * 0.4 / cam.shape[0])))
        inset = cv2.resize(cam, (cam.shape[1] * scale, cam.shape[0] * scale), interpolation=cv2.INTER_NEAREST)
        ih, iw = inset.shape
        pad = 6
        if iw + 2 * pad > w or ih + 2 * pad > h:
            return  # the picture is too small for an inset
        inset_corners = ("top-right", "bottom-right", "bottom-left", "top-left")
        order = [c for c in inset_corners if avoid is None or c != avoid[0]]
        origins = [_corner_origin(c, (iw, ih), (w, h), pad, self.bottom_reserve) for c in order]
        x0, y0 = origins[0]
        for left, top in origins:
            if not self._covers_car((left, top), (iw, ih), car_xy):
                x0, y0 = left, top
                break
        img[y0 - 2 : y0 + ih + 2, x0 - 2 : x0 + iw + 2] = 255
        img[y0 : y0 + ih, x0 : x0 + iw] = inset[:, :, None]


def track_picture(
    track: TrackLike,
    width: int = 1200,
    colors: SceneColors = DEFAULT_COLORS,
    title: bool = True,
) -> np.ndarray:
    """A top-down picture of a track for ``drx track show --png``: (H, W, 3) uint8 RGB.

    The height follows the track's aspect ratio (rounded to a multiple of 16). The driving
    direction is marked with an arrow at the start line; ``title`` writes the track's name,
    centre-line length and the 1 m grid spacing.
    """
    pts = track_points(track)
    span = np.maximum(pts.max(axis=0) - pts.min(axis=0), 1e-3)
    height = int(round(width * min(max(span[1] / span[0], 0.3), 2.0) / 16)) * 16 + 64
    renderer = TopDownRenderer(track, size=(width, height), colors=colors)
    img = renderer.background.copy()
    center = np.asarray(track.center, float)
    if len(center) >= 2:
        seg = np.linalg.norm(np.diff(center, axis=0), axis=1)
        k = int(np.argmax(seg > 1e-9))
        direction = (center[k + 1] - center[k]) / seg[k]
        tip = center[0] + direction * max(0.5, 0.03 * float(seg.sum()))
        a, b = renderer.frame.to_px(np.array([center[0], tip]))
        cv2.arrowedLine(
            img,
            tuple(int(v) for v in np.round(a)),
            tuple(int(v) for v in np.round(b)),
            (255, 60, 60),
            max(2, width // 400),
            cv2.LINE_AA,
            tipLength=0.3,
        )
    if title:
        seg = np.linalg.norm(np.diff(center, axis=0), axis=1)
        length = float(getattr(track, "length", seg.sum()))
        kind = "loop" if track.closed else "open"
        _text_panel(img, [f"{track.name}   {length:.2f} m, {kind}, grid 1 m"])
    return img


def any_to_rgb(image: np.ndarray) -> np.ndarray:
    """A grayscale (H, W), (H, W, 1) or (H, W, 2) camera frame as (H, W, 3) RGB, for saving."""
    img = np.asarray(image)
    if img.ndim == 3:
        img = img[:, :, 0]
    return np.repeat(img[:, :, None], 3, axis=2)


__all__: list[str] = [
    "GRAY_WEIGHTS",
    "DEFAULT_COLORS",
    "GroundFrame",
    "SceneColors",
    "TopDownRenderer",
    "TrackLike",
    "any_to_rgb",
    "ground_texture",
    "paint_track",
    "paint_walls",
    "to_gray",
    "track_picture",
    "track_points",
]
