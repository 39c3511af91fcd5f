"""The car's front camera: 160x120 grayscale frames in perspective, fast.

The scene is flat ground inside a walled field (:mod:`drx.sim.scene`), so each frame is
two projective warps of textures painted once per track:

* the *ground* texture (road, border lines, dashed centre line, mottled field) at
  ``texture_resolution`` m/px, with the wall's colour beyond the field (seen from inside,
  a wall covers exactly the ground behind it), sampled for the rows below the horizon in
  bands of rows that each read the mipmap level matching their ground footprint;
* the *ceiling* texture, the plane at the wall's height: the sky inside the field, the wall
  beyond it (a ray going up meets that plane outside the field exactly when it hits the wall
  first), sampled for the rows above the horizon.

DeepRacer's image pipeline (``DEEPRACER.md`` section 1): Gazebo renders 640x480 RGB, which is
resized 4:1 bilinearly (cv2 ``INTER_LINEAR``: each output pixel is the mean of the middle 2x2 of
its 4x4 block) and converted to grey. :func:`deepracer_downsample` is that resize;
:meth:`CameraRenderer.render_reference` renders at 640x480 and applies it (a reference for tests
and ``benchmarks/camera_speed.py``). The fast path renders at 160x120 directly and matches the
blur of thin lines and distant edges by sampling the mipmap level for a footprint
``footprint_scale`` times the pixel's (fitted against the reference by the benchmark).

Geometry: a pinhole camera with square pixels, horizontal field of view ``hfov``, mounted
``mount_forward`` ahead of the rear-axle centre and ``mount_height`` above the ground, pitched ``pitch``
down; the figures come from DeepRacer's URDF joint chain (:func:`deepracer_mount`). Camera axes
follow OpenCV: X right, Y down, Z forward; pixel centres at integers, the principal point at the
image centre.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace

import cv2
import numpy as np

from drx.sim.camera_boxes import DEFAULT_BOX_HEIGHT, BoxProjector
from drx.sim.camera_config import CameraConfig, deepracer_mount
from drx.sim.camera_painter import TrackLike, track_points
from drx.sim.camera_textures import ground_textures, recolored_textures
from drx.sim.scene import DEFAULT_SCENE, WALL_HEIGHT, FieldBox, Scene, to_gray, wall_sides

# Mipmap choice: a row's footprint is across^(1-w) * along^w; 0.5 is the geometric mean, 0 the
# sharpest (across only). 0.25 keeps distant border lines crisp while damping most aliasing.
_ALONG_WEIGHT = 0.25


def deepracer_downsample(image: np.ndarray) -> np.ndarray:
    """DeepRacer's 640x480 -> 160x120 step: a 4:1 bilinear resize, then grey for an RGB image.

    RGB input is taken as RGB (DeepRacer's weights, :data:`drx.sim.scene.GRAY_WEIGHTS`).
    """
    img = np.asarray(image)
    h, w = img.shape[:2]
    small = cv2.resize(img, (w // 4, h // 4), interpolation=cv2.INTER_LINEAR)
    if small.ndim == 3 and small.shape[2] == 3:
        small = cv2.cvtColor(small, cv2.COLOR_RGB2GRAY)
    return small


class CameraRenderer:
    """Renders the front camera's view of a flat track inside its walled field.

    :param track: the track (any object with ``center``, ``inner``, ``outer``, ``closed``, ``name``).
    :param config: the camera; DeepRacer's by default.
    :param scene: colours and lighting (:class:`~drx.sim.scene.Scene`); DeepRacer's by default.
        :meth:`set_scene` changes it (domain randomisation, once per episode).

    Call :meth:`render` (mono) or :meth:`render_stereo` per step. Not thread-safe (scratch buffers).
    """

    def __init__(
        self, track: TrackLike, config: CameraConfig | None = None, scene: Scene = DEFAULT_SCENE
    ) -> None:
        cfg = config or CameraConfig()
        self.config = cfg
        self.track = track
        self._focal = cfg.focal
        self._cx, self._cy = cfg.principal_point
        self._sin_p, self._cos_p = math.sin(cfg.pitch), math.cos(cfg.pitch)
        self._tan_half = math.tan(cfg.hfov / 2)
        self._q = np.empty((2, 3))
        self._band_m = np.empty((0, 3, 3))
        self._install(scene)
        self._stereo_scratch = (
            np.empty((cfg.height, cfg.width), np.uint8),
            np.empty((cfg.height, cfg.width), np.uint8),
        )

    # ----------------------------------------------------------------------------------- set-up
    def set_scene(self, scene: Scene) -> None:
        """Change the scene's colours and lighting (domain randomisation, once per episode).

        Any scene but the default is recoloured from label textures painted once per track (one
        lookup table and the mipmaps, a few ms; edges without anti-aliasing); the default scene
        returns to the shared anti-aliased textures. A randomised texture is this renderer's own.
        """
        if scene != self.scene:
            self._install(scene, recolor=scene != DEFAULT_SCENE)

    def _install(self, scene: Scene, recolor: bool = False) -> None:
        cfg = self.config
        self.scene = scene
        self.colors = scene.colors
        textures = (
            recolored_textures(self.track, cfg, scene) if recolor else ground_textures(self.track, cfg, scene)
        )
        self.frame, self._levels, self._ceil_frame, self._ceiling = textures
        lit = scene.lit()
        walls = [to_gray(lit[f"wall_{side}"]) for side in wall_sides()]
        self._wall_greys = [float(w) for w in walls]  # west, east, south, north
        self._field = FieldBox.around(track_points(self.track))
        self._template = np.full((cfg.height, cfg.width), int(round(np.mean(walls))), np.uint8)
        self._bands = self._make_bands(cfg)
        # Per-band constants for the per-frame homography (see _ground). A band's map is
        # S_k [Q; 0 0 1] G_b with S_k = diag(1/res_k, 1/res_k, 1): its top rows are Q (G_b / res_k),
        # its last row G_b's, so the per-level scale is folded into G once here. The ceiling
        # (rows above the horizon) is one more band, on its own texture.
        first = cfg.first_ground_row
        g = [b[3] for b in self._bands]
        inv_res = [1.0 / (self.frame.res * 2 ** b[2]) for b in self._bands]
        warps = [
            (self._levels[level], (cfg.width, row1 - row0), row0, row1)
            for row0, row1, level, _ in self._bands
        ]
        if first > 0:
            g.append(self._ceiling_from_pixel(0))
            inv_res.append(1.0 / self._ceil_frame.res)
            warps.append((self._ceiling, (cfg.width, first), 0, first))
        g_arr = np.stack(g or [np.eye(3)])
        self._band_g_scaled = g_arr * np.asarray(inv_res or [1.0])[:, None, None]
        self._band_m = np.empty((len(g_arr), 3, 3))
        self._band_m[:, 2, :] = g_arr[:, 2, :]
        self._band_top = self._band_m[:, :2, :]  # the rows written per frame
        # (the ceiling texture shares the ground texture's origin, so one Q serves both). The
        # ceiling is sampled nearest-neighbour: it is flat colours with one edge (the walls' top),
        # and linear sampling costs half as much again (drawing it at half size and enlarging
        # it costs more than either).
        linear, nearest = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP
        self._band_warps = [
            (tex, self._band_m[i], size, row0, row1, nearest if tex is self._ceiling else linear)
            for i, (tex, size, row0, row1) in enumerate(warps)
        ]
        self._boxes = BoxProjector(
            self._focal, (self._cx, self._cy), cfg.pitch, cfg.mount_forward, cfg.mount_height, cfg.hfov,
            to_gray(scene.lighting.shade(scene.colors.box)),
        )  # fmt: skip

    def _make_bands(self, cfg: CameraConfig) -> list[tuple[int, int, int, np.ndarray]]:
        """Split the ground rows into bands of equal mipmap level.

        A row's level follows its pixel footprint on the ground across (slant range / f) and
        along the view (h / (D^2 f), D = yn cos p + sin p), weighted by :data:`_ALONG_WEIGHT` and
        scaled by ``footprint_scale``: the texture is then sampled near one texel per
        ``footprint_scale`` pixel, sharp across, mildly aliased along.
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
            fp = cfg.footprint_scale * across ** (1 - _ALONG_WEIGHT) * along**_ALONG_WEIGHT / self.frame.res
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
        m1 = np.array([[0.0, -h * sp, h * cp], [-h, 0.0, 0.0], [0.0, cp, sp]])
        return m1 @ self._k_inv(row0)

    def _ceiling_from_pixel(self, row0: int) -> np.ndarray:
        """Like :meth:`_ground_from_pixel` for the plane at the wall's height (rays going up).

        The ray meets the plane ``c = H - h`` above the camera at t = c / -(yn cos p + sin p).
        """
        c = WALL_HEIGHT - self.config.mount_height
        sp, cp = self._sin_p, self._cos_p
        m1 = np.array([[0.0, -c * sp, c * cp], [-c, 0.0, 0.0], [0.0, -cp, -sp]])
        return m1 @ self._k_inv(row0)

    def _k_inv(self, row0: int) -> np.ndarray:
        f = self._focal
        return np.array([[1 / f, 0.0, -self._cx / f], [0.0, 1 / f, (row0 - self._cy) / f], [0.0, 0.0, 1.0]])

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
            self._ground(img, x, y, yaw, lateral)
            if shapes:
                self._boxes.draw(img, shapes, lateral)
        if out is None:
            out = np.empty((cfg.height, cfg.width, 2), np.uint8)
        else:
            self._check_out(out, (cfg.height, cfg.width, 2))
        return cv2.merge((left, right), dst=out)

    def render_reference(self, x: float, y: float, yaw: float, lateral: float = 0.0) -> np.ndarray:
        """DeepRacer's pipeline done the slow way: render at 4x the size (640x480), each pixel
        sampling the mipmap level of its own footprint, then :func:`deepracer_downsample`.

        ``lateral`` [m] moves the camera to the left (a stereo eye: +/- half the baseline).
        For tests and benchmarks (about 20x the cost of :meth:`render`); no boxes.
        """
        reference: CameraRenderer | None = getattr(self, "_reference", None)  # made on first use
        if reference is None or reference.scene != self.scene:
            cfg = self.config
            big = replace(cfg, width=4 * cfg.width, height=4 * cfg.height, footprint_scale=1.0, max_bands=64)
            reference = self._reference = CameraRenderer(self.track, big, self.scene)
        big_img = reference._template.copy()
        reference._ground(big_img, x, y, yaw, lateral)
        return deepracer_downsample(big_img)

    @staticmethod
    def _check_out(out: np.ndarray, shape: tuple[int, ...]) -> None:
        # cv2 silently allocates a new array when ``dst`` does not fit; refuse instead
        if out.shape != shape or out.dtype != np.uint8 or not out.flags.c_contiguous:
            got = f"{out.dtype} {out.shape}" + ("" if out.flags.c_contiguous else ", not contiguous")
            raise ValueError(f"out must be a C-contiguous uint8 array of shape {shape}, got {got}")

    def _ground(self, out: np.ndarray, x: float, y: float, yaw: float, lateral: float) -> None:
        """Warp the ground texture into the rows below the horizon of ``out`` and the ceiling
        texture into those above it, in place (every pixel is written)."""
        c, s = math.cos(yaw), math.sin(yaw)
        fr = self.frame
        a = self.config.mount_forward
        px, py = x + c * a - s * lateral, y + s * a + c * lateral  # the camera's foot [m]
        # ground (forward, left) relative to the camera's foot -> world [m], expressed directly in
        # texture axes (column = (X - x0), row = (y1 - Y)); the per-level 1/res is in _band_g_scaled.
        q = self._q
        q[0, 0], q[0, 1], q[0, 2] = c, -s, px - fr.x0
        q[1, 0], q[1, 1], q[1, 2] = -s, -c, fr.y1 - py
        np.matmul(q, self._band_g_scaled, out=self._band_top)
        # Beyond the textures (the rows nearest the horizon) lies the wall straight ahead: the one
        # the optical axis meets first (a constant border; replicating edges costs 5x as much).
        fb = self._field
        tx = ((fb.x1 - px) / c if c > 0 else (fb.x0 - px) / c) if abs(c) > 1e-9 else math.inf
        ty = ((fb.y1 - py) / s if s > 0 else (fb.y0 - py) / s) if abs(s) > 1e-9 else math.inf
        border = self._wall_greys[(1 if c > 0 else 0) if tx < ty else (3 if s > 0 else 2)]
        constant = cv2.BORDER_CONSTANT
        for tex, m, size, row0, row1, flags in self._band_warps:
            # positional arguments: keywords cost cv2 ~0.6 us per call
            cv2.warpPerspective(tex, m, size, out[row0:row1], flags, constant, border)


__all__ = ["CameraConfig", "CameraRenderer", "DEFAULT_BOX_HEIGHT", "deepracer_downsample", "deepracer_mount"]
