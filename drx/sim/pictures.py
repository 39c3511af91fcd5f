"""The top-down pictures for people: videos, ``render_mode="rgb_array"``, the watch page and
``drx track show --png``, painted with the camera's painter (:mod:`drx.sim.camera_painter`).

World frame: metres, x to the east, y to the north, yaw in radians
counter-clockwise from +x. Images have y pointing down, so north is up.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import cv2
import numpy as np

from drx.sim.camera_painter import (
    CAR_LENGTH,
    CAR_WIDTH,
    FIXED_POINT_BITS,
    WHEELBASE,
    GroundFrame,
    TrackLike,
    ground_texture,
    paint_track,
    paint_walls,
    track_points,
)
from drx.sim.scene import (
    DEFAULT_COLORS,
    RGB,
    FieldBox,
    SceneColors,
)

BOT_COLOR = (40, 90, 220)  # RGB of bot cars in the top-down view


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
        r, g, b = colors.ground
        _paint_grid(bg, self.frame, 1.0, (int(r * 0.9), int(g * 0.9), int(b * 0.9)))
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
                cv2.polylines(img, [fr.to_fixed(pts)], False, (255, 120, 0), 2, cv2.LINE_AA, FIXED_POINT_BITS)
        if boxes is not None:
            for box in boxes:
                bx, by, byaw, blen, bwid = (float(v) for v in list(box)[:5])
                cb, sb = math.cos(byaw), math.sin(byaw)
                local = np.array([[blen, bwid], [blen, -bwid], [-blen, -bwid], [-blen, bwid]]) / 2
                quad = local @ np.array([[cb, -sb], [sb, cb]]).T + np.array([bx, by])
                cv2.fillConvexPoly(img, fr.to_fixed(quad), self.colors.box, cv2.LINE_AA, FIXED_POINT_BITS)
                cv2.polylines(img, [fr.to_fixed(quad)], True, (60, 40, 20), 1, cv2.LINE_AA, FIXED_POINT_BITS)
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

    def draw_car(self, img: np.ndarray, x: float, y: float, yaw: float, color: tuple[int, int, int]) -> None:
        """Draw a car at rear-axle ``(x, y)`` [m], ``yaw`` [rad] in ``color`` on ``img`` (a race's cars)."""
        self._draw_car(img, x, y, yaw, color)

    def _draw_car(
        self, img: np.ndarray, x: float, y: float, yaw: float, color: tuple[int, int, int] = (220, 30, 30)
    ) -> None:
        fr = self.frame
        body = self.car_polygon(x, y, yaw)
        cv2.fillConvexPoly(img, fr.to_fixed(body), color, cv2.LINE_AA, FIXED_POINT_BITS)
        cv2.polylines(img, [fr.to_fixed(body)], True, (20, 20, 20), 1, cv2.LINE_AA, FIXED_POINT_BITS)
        # a white nose triangle shows which way the car faces
        front_l, front_r, rear_r, rear_l = body
        mid_l = front_l * 0.55 + rear_l * 0.45
        mid_r = front_r * 0.55 + rear_r * 0.45
        nose = (front_l + front_r) / 2
        tip = nose * 0.9 + (mid_l + mid_r) * 0.05
        tri = np.array([mid_l * 0.75 + mid_r * 0.25, mid_r * 0.75 + mid_l * 0.25, tip])
        cv2.fillConvexPoly(img, fr.to_fixed(tri), (255, 255, 255), cv2.LINE_AA, FIXED_POINT_BITS)

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
    "TopDownRenderer",
    "any_to_rgb",
    "track_picture",
]
