"""The car's front camera: 160x120 grayscale frames in perspective, fast.

The scene is flat (road markings on the ground plane), so each frame is one
projective warp of a top-down ground texture painted once per track:

* :class:`CameraRenderer` paints the track (road, white borders, dashed centre
  line, start line, mottled off-track ground) at ``texture_resolution`` m/px
  and builds a mipmap pyramid of it;
* per frame it composes the 3x3 homography image -> ground texture from the
  car's pose and the camera's mount, and calls :func:`cv2.warpPerspective` once
  per band of image rows, each band sampling the pyramid level that matches its
  ground footprint (distant rows read coarser levels, which keeps them from
  aliasing into noise);
* rows above the horizon are a precomputed sky (the car neither rolls nor
  pitches, so the horizon row is fixed).

Geometry (DEEPRACER.md section 1): a pinhole camera with square pixels,
horizontal field of view ``hfov``, mounted ``mount_forward`` ahead of and
``mount_height`` above the rear-axle centre, pitched ``pitch`` down. Camera
axes follow OpenCV: X right, Y down, Z forward; pixel centres at integers, the
principal point at the image centre.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from drx.sim.camera_boxes import DEFAULT_BOX_HEIGHT, BoxProjector
from drx.sim.render import (
    DEFAULT_COLORS,
    GroundFrame,
    SceneColors,
    TrackLike,
    ground_texture,
    paint_track,
    to_gray,
)

# Mipmap choice: a row's footprint is across^(1-w) * along^w; 0.5 is the geometric mean, 0 the
# sharpest (across only). 0.25 keeps distant border lines crisp while damping most aliasing.
_ALONG_WEIGHT = 0.25


@dataclass(frozen=True)
class CameraConfig:
    """The front camera. Defaults are the DeepRacer simulator's.

    :param width: image width [px].
    :param height: image height [px].
    :param hfov: horizontal field of view [rad] (1.13 rad = 64.7 deg).
    :param mount_forward: camera position ahead of the rear-axle centre [m].
    :param mount_height: camera height above the ground [m].
    :param pitch: downward tilt of the optical axis [rad] (15 deg).
    :param stereo_baseline: distance between the two stereo cameras [m]; each sits half of it
        left / right of the mono camera's position.
    :param texture_resolution: ground texture pixel size [m]. 5 mm keeps the markings' edges clean
        right in front of the car (1 cm shows stair-steps there) at no measurable cost when the
        car drives on; rendering scattered poses in turn costs ~20% more than at 1 cm.
    :param max_texture_pixels: cap on the texture's pixel count (bytes per mipmap level 0);
        larger tracks get coarser texels. 8 M px holds re:Invent 2018 at 5 mm, Spain at ~6 mm.
    :param texture_margin: off-track ground painted around the track's bounding box [m]; beyond it
        the ground is flat grey.
    :param mip_levels: number of coarser pyramid levels for distant rows (0 = none).
    :param max_bands: most warps per frame (bands of rows sharing a pyramid level); each call
        costs ~3 us of overhead, so 3 bands trade a little far-field filtering for speed.
    """

    width: int = 160
    height: int = 120
    hfov: float = 1.13
    mount_forward: float = 0.145
    mount_height: float = 0.13
    pitch: float = math.radians(15.0)
    stereo_baseline: float = 0.06
    texture_resolution: float = 0.005
    max_texture_pixels: int = 8_000_000
    texture_margin: float = 2.0
    mip_levels: int = 4
    max_bands: int = 3

    def __post_init__(self) -> None:
        if self.width < 2 or self.height < 2:
            raise ValueError(f"camera image {self.width}x{self.height} is too small")
        if not 0.05 < self.hfov < math.pi - 0.05:
            raise ValueError(f"hfov {self.hfov} rad must be within (0.05, pi - 0.05)")
        if self.mount_height <= 0:
            raise ValueError(f"mount_height {self.mount_height} m must be above the ground (> 0)")
        if not -math.pi / 2 < self.pitch < math.pi / 2:
            raise ValueError(f"pitch {self.pitch} rad must be within (-pi/2, pi/2)")
        if self.texture_resolution <= 0:
            raise ValueError(f"texture_resolution {self.texture_resolution} m must be > 0")

    @property
    def focal(self) -> float:
        """Focal length [px], the same horizontally and vertically (square pixels)."""
        return (self.width / 2) / math.tan(self.hfov / 2)

    @property
    def principal_point(self) -> tuple[float, float]:
        """(cx, cy) [px], the image centre with pixel centres at integers."""
        return (self.width - 1) / 2, (self.height - 1) / 2

    @property
    def vfov(self) -> float:
        """Vertical field of view [rad]."""
        return 2 * math.atan((self.height / 2) / self.focal)

    @property
    def horizon_row(self) -> float:
        """Image row (fractional, from the top) of the horizon: ``cy - f tan(pitch)``."""
        return self.principal_point[1] - self.focal * math.tan(self.pitch)

    @property
    def first_ground_row(self) -> int:
        """The first image row whose centre looks at the ground."""
        return max(0, min(self.height, math.floor(self.horizon_row) + 1))


_PYRAMIDS: dict[str, tuple[GroundFrame, list[np.ndarray]]] = {}
_PYRAMID_CACHE_SIZE = 4  # textures kept per process (several envs on one track share one)


def _ground_pyramid(
    track: TrackLike, cfg: CameraConfig, colors: SceneColors
) -> tuple[GroundFrame, list[np.ndarray]]:
    """The painted ground texture and its mipmap levels (read-only), shared by identical renderers.

    Keyed by the track's geometry and the texture settings, so vectorised envs on one track in
    one process paint it once and share its cache footprint.
    """
    digest = hashlib.blake2b(digest_size=16)
    for arr in (track.center, track.inner, track.outer):
        digest.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    key = repr(
        (
            digest.hexdigest(),
            bool(track.closed),
            cfg.texture_resolution,
            cfg.max_texture_pixels,
            cfg.texture_margin,
            cfg.mip_levels,
            colors,
        )
    )
    hit = _PYRAMIDS.get(key)
    if hit is not None:
        return hit
    frame = _texture_frame(track, cfg)
    tex = ground_texture((frame.height, frame.width), frame.res, colors)
    paint_track(tex, track, frame, colors)
    levels = [tex]
    for _ in range(max(0, cfg.mip_levels)):
        if min(levels[-1].shape) < 8:
            break
        levels.append(cv2.pyrDown(levels[-1]))
    for level in levels:
        level.setflags(write=False)
    while len(_PYRAMIDS) >= _PYRAMID_CACHE_SIZE:
        _PYRAMIDS.pop(next(iter(_PYRAMIDS)))
    _PYRAMIDS[key] = (frame, levels)
    return frame, levels


def _texture_frame(track: TrackLike, cfg: CameraConfig) -> GroundFrame:
    """The ground texture's frame: the track plus a margin, coarser if it would be too big."""
    frame = GroundFrame.fit(track, cfg.texture_resolution, cfg.texture_margin)
    pixels = frame.width * frame.height
    # cv2's remap needs coordinates below 32767 px; keep well inside.
    longest = max(frame.width, frame.height)
    factor = max(math.sqrt(pixels / cfg.max_texture_pixels), longest / 30000, 1.0)
    if factor > 1.0:
        frame = GroundFrame.fit(track, cfg.texture_resolution * factor, cfg.texture_margin)
    return frame


class CameraRenderer:
    """Renders the front camera's view of a flat track.

    :param track: the track (any object with ``center``, ``inner``, ``outer``, ``closed``, ``name``).
    :param config: the camera; DeepRacer's by default.
    :param colors: scene colours (grayscale is taken with DeepRacer's weights).

    Call :meth:`render` (mono) or :meth:`render_stereo` per step. Not thread-safe (scratch buffers).
    """

    def __init__(
        self, track: TrackLike, config: CameraConfig | None = None, colors: SceneColors = DEFAULT_COLORS
    ) -> None:
        cfg = config or CameraConfig()
        self.config = cfg
        self.track = track
        self.colors = colors
        self._focal = cfg.focal
        self._cx, self._cy = cfg.principal_point
        self._sin_p, self._cos_p = math.sin(cfg.pitch), math.cos(cfg.pitch)
        self._tan_half = math.tan(cfg.hfov / 2)

        self.frame, self._levels = _ground_pyramid(track, cfg, colors)
        self._border = float(to_gray(colors.ground))

        self._sky = self._sky_rows(cfg, colors)
        self._template = np.empty((cfg.height, cfg.width), np.uint8)
        self._template[: len(self._sky)] = self._sky
        self._template[len(self._sky) :] = int(self._border)
        self._bands = self._make_bands(cfg)
        # Per-band constants for the per-frame homography (see _ground). A band's map is
        # S_k [Q; 0 0 1] G_b with S_k = diag(1/res_k, 1/res_k, 1): its top rows are Q (G_b / res_k),
        # its last row G_b's, so the per-level scale is folded into G once here.
        g = np.stack([b[3] for b in self._bands] or [np.eye(3)])  # (B, 3, 3) band pixel -> ground [m]
        inv_res = np.array([1.0 / (self.frame.res * 2 ** b[2]) for b in self._bands] or [1.0])
        self._band_g_scaled = g * inv_res[:, None, None]
        self._band_m = np.empty((len(self._bands), 3, 3))
        self._band_m[:, 2, :] = g[:, 2, :]
        self._band_top = self._band_m[:, :2, :]  # the rows written per frame
        self._band_warps = [
            (self._levels[level], self._band_m[i], (cfg.width, row1 - row0), row0, row1)
            for i, (row0, row1, level, _) in enumerate(self._bands)
        ]
        self._q = np.empty((2, 3))
        self._boxes = BoxProjector(
            self._focal, (self._cx, self._cy), cfg.pitch, cfg.mount_forward, cfg.mount_height, cfg.hfov,
            to_gray(colors.box),
        )  # fmt: skip
        self._stereo_scratch = (
            np.empty((cfg.height, cfg.width), np.uint8),
            np.empty((cfg.height, cfg.width), np.uint8),
        )

    # ----------------------------------------------------------------------------------- set-up
    @staticmethod
    def _sky_rows(cfg: CameraConfig, colors: SceneColors) -> np.ndarray:
        """The sky above the horizon: a vertical gradient, lighter towards the horizon."""
        rows = cfg.first_ground_row
        top, low = to_gray(colors.sky_top), to_gray(colors.sky_horizon)
        t = np.linspace(0.0, 1.0, max(rows, 1))[:rows, None]
        return np.repeat(np.round(top + (low - top) * t).astype(np.uint8), cfg.width, axis=1)

    def _make_bands(self, cfg: CameraConfig) -> list[tuple[int, int, int, np.ndarray]]:
        """Split the ground rows into bands of equal mipmap level.

        A row's level follows its pixel footprint on the ground across (slant range / f) and
        along the view (h / (D^2 f), D = yn cos p + sin p), weighted by :data:`_ALONG_WEIGHT`:
        the texture is then sampled near one texel per pixel, sharp across, mildly aliased along.
        Returns (row0, row1, level, G) where G maps band pixels (u, v - row0, 1) to homogeneous
        ground coordinates (forward, left, 1) [m] relative to the point below the camera.
        """
        f, h = self._focal, cfg.mount_height
        sp, cp = self._sin_p, self._cos_p
        first = cfg.first_ground_row
        levels = []
        for v in range(first, cfg.height):
            yn = (v - self._cy) / f
            d = yn * cp + sp
            across = h / d * math.sqrt(1 + yn * yn) / f
            along = h / (d * d * f)
            fp = across ** (1 - _ALONG_WEIGHT) * along**_ALONG_WEIGHT / self.frame.res
            levels.append(int(min(len(self._levels) - 1, max(0, math.floor(math.log2(max(fp, 1e-9)))))))
        runs: list[list[int]] = []  # [row0, row1) of equal level
        for i, level in enumerate(levels):
            if runs and levels[i - 1] == level:
                runs[-1][1] = first + i + 1
            else:
                runs.append([first + i, first + i + 1])
        # Each warp call costs a few microseconds however few its rows: merge the smallest
        # neighbouring runs until at most max_bands remain; a merged run takes its rows' mean level.
        while len(runs) > max(1, cfg.max_bands):
            k = min(range(len(runs) - 1), key=lambda j: runs[j + 1][1] - runs[j][0])
            runs[k : k + 2] = [[runs[k][0], runs[k + 1][1]]]
        bands = []
        for row0, row1 in runs:
            level = int(round(sum(levels[row0 - first : row1 - first]) / (row1 - row0)))
            bands.append((row0, row1, level, self._ground_from_pixel(row0)))
        return bands

    def _ground_from_pixel(self, row0: int) -> np.ndarray:
        """3x3 map from band pixels (u, v', 1), v = v' + row0, to ground (forward, left, 1) ~ homogeneous.

        The ray through pixel (xn, yn) in car axes (forward, left, up) is
        (cos p - yn sin p, -xn, -(yn cos p + sin p)); it meets the ground at
        t = h / (yn cos p + sin p).
        """
        h, sp, cp = self.config.mount_height, self._sin_p, self._cos_p
        f = self._focal
        m1 = np.array([[0.0, -h * sp, h * cp], [-h, 0.0, 0.0], [0.0, cp, sp]])
        k_inv = np.array([[1 / f, 0.0, -self._cx / f], [0.0, 1 / f, (row0 - self._cy) / f], [0.0, 0.0, 1.0]])
        return m1 @ k_inv

    # ----------------------------------------------------------------------------------- frames
    def render(
        self,
        x: float,
        y: float,
        yaw: float,
        boxes: Iterable[Sequence[float]] | None = None,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """The camera frame of a car with rear-axle centre ``(x, y)`` [m] heading ``yaw`` [rad].

        :param boxes: obstacles standing on the ground, rows ``(x, y, yaw, length, width[, height])``
            [m, rad] (height defaults to :data:`DEFAULT_BOX_HEIGHT`).
        :param out: a (height, width) uint8 C-contiguous array to draw into (saves an allocation).
        :returns: (height, width) uint8 grayscale, ``out`` when given, else a new array.
        """
        if out is None:
            out = self._template.copy()
        else:
            self._check_out(out, (self.config.height, self.config.width))
            out[: len(self._sky)] = self._sky
        self._ground(out, x, y, yaw, 0.0)
        if boxes is not None:
            shapes = self._boxes.shapes(x, y, yaw, boxes, 0.0)
            if shapes:
                self._boxes.draw(out, shapes, 0.0)
        return out

    def render_stereo(
        self,
        x: float,
        y: float,
        yaw: float,
        boxes: Iterable[Sequence[float]] | None = None,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Both stereo cameras: (height, width, 2) uint8, channel 0 left, channel 1 right.

        The cameras sit ``stereo_baseline / 2`` left and right of the mono camera's position.
        Boxes are projected once for both (the cameras differ by a sideways shift only, so a
        corner's row is the same in both and its column moves by ``f * shift / depth``); which
        sides of a box show is judged from the middle, which differs from an eye's own view only
        for sides seen edge-on.
        """
        cfg = self.config
        half = cfg.stereo_baseline / 2
        shapes = self._boxes.shapes(x, y, yaw, boxes, half) if boxes is not None else None
        left, right = self._stereo_scratch
        for img, lateral in ((left, half), (right, -half)):
            img[: len(self._sky)] = self._sky
            self._ground(img, x, y, yaw, lateral)
            if shapes:
                self._boxes.draw(img, shapes, lateral)
        if out is None:
            out = np.empty((cfg.height, cfg.width, 2), np.uint8)
        else:
            self._check_out(out, (cfg.height, cfg.width, 2))
        return cv2.merge((left, right), dst=out)

    @staticmethod
    def _check_out(out: np.ndarray, shape: tuple[int, ...]) -> None:
        # cv2 silently allocates a new array when ``dst`` does not fit; refuse instead
        if out.shape != shape or out.dtype != np.uint8 or not out.flags.c_contiguous:
            got = f"{out.dtype} {out.shape}" + ("" if out.flags.c_contiguous else ", not contiguous")
            raise ValueError(f"out must be a C-contiguous uint8 array of shape {shape}, got {got}")

    def _ground(self, out: np.ndarray, x: float, y: float, yaw: float, lateral: float) -> None:
        """Warp the ground texture into the rows below the horizon of ``out``, in place."""
        c, s = math.cos(yaw), math.sin(yaw)
        fr = self.frame
        a = self.config.mount_forward
        # ground (forward, left) relative to the camera's foot -> world [m], expressed directly in
        # texture axes (column = (X - x0), row = (y1 - Y)); the per-level 1/res is in _band_g_scaled.
        q = self._q
        q[0, 0], q[0, 1], q[0, 2] = c, -s, x + c * a - s * lateral - fr.x0
        q[1, 0], q[1, 1], q[1, 2] = -s, -c, fr.y1 - (y + s * a + c * lateral)
        np.matmul(q, self._band_g_scaled, out=self._band_top)
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        border = self._border
        for level, m, size, row0, row1 in self._band_warps:
            cv2.warpPerspective(
                level,
                m,
                size,
                dst=out[row0:row1],
                flags=flags,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=border,
            )


__all__ = ["CameraConfig", "CameraRenderer", "DEFAULT_BOX_HEIGHT"]
