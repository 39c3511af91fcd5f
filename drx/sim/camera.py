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
from dataclasses import dataclass, replace

import cv2
import numpy as np

from drx.sim.camera_boxes import DEFAULT_BOX_HEIGHT, BoxProjector
from drx.sim.camera_painter import TrackLike, track_points
from drx.sim.camera_textures import ground_textures, recolored_textures
from drx.sim.scene import DEFAULT_SCENE, WALL_HEIGHT, FieldBox, Scene, to_gray, wall_sides

# Mipmap choice: a row's footprint is across^(1-w) * along^w; 0.5 is the geometric mean, 0 the
# sharpest (across only). 0.25 keeps distant border lines crisp while damping most aliasing.
_ALONG_WEIGHT = 0.25

# DeepRacer's URDF (deepracer-simapp bundle/urdf/deepracer/deepracer_single_cam.urdf and
# deepracer_stereo_cam.urdf; wheel radius from bundle/meshes/deepracer/left_rear_wheel.STL).
_URDF_CHASSIS_Z = 0.023249  # base_link_joint: chassis above base_link
_URDF_REAR_AXLE = (-0.081663, 0.01575)  # left_rear_wheel_joint x, z in the chassis
_URDF_WHEEL_RADIUS = 0.0359994  # the wheel mesh's half height
_URDF_ZED = (0.091711, 0.080023, 0.2618)  # zed_camera_joint x, z in the chassis and its pitch
_URDF_LENS = (0.044755, 0.04)  # camera_joint x, z in the (pitched) zed_camera_link
_URDF_STEREO_Y = 0.03  # zed_camera_joint_leftcam / _rightcam: y = +/-0.03


def deepracer_mount() -> tuple[float, float, float, float]:
    """DeepRacer's camera from its URDF joint chain: (ahead of the rear axle [m], above the
    ground [m], pitch down [rad], stereo baseline [m]).

    The lens (camera_link) sits ``_URDF_LENS`` from the zed_camera_link, which is pitched
    0.2618 rad (15 deg) down; the ground is the wheels' lowest point. Gives 0.2270 m, 0.1273 m,
    0.2618 rad, 0.06 m.
    """
    zx, zz, pitch = _URDF_ZED
    lx, lz = _URDF_LENS
    # a child offset (lx, lz) in a frame pitched down by `pitch` (ROS: +pitch about y tilts x down)
    cam_x = zx + math.cos(pitch) * lx + math.sin(pitch) * lz
    cam_z = zz - math.sin(pitch) * lx + math.cos(pitch) * lz
    ground_z = _URDF_REAR_AXLE[1] - _URDF_WHEEL_RADIUS  # in the chassis frame
    return cam_x - _URDF_REAR_AXLE[0], cam_z - ground_z, pitch, 2 * _URDF_STEREO_Y


_MOUNT = deepracer_mount()


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


@dataclass(frozen=True)
class CameraConfig:
    """The front camera. Defaults are the DeepRacer simulator's.

    :param width: image width [px].
    :param height: image height [px].
    :param hfov: horizontal field of view [rad] (1.13 rad = 64.7 deg; racecar.gazebo).
    :param mount_forward: camera position ahead of the rear-axle centre [m] (URDF: 0.227).
    :param mount_height: camera height above the ground [m] (URDF: 0.127).
    :param pitch: downward tilt of the optical axis [rad] (URDF: 0.2618 = 15 deg).
    :param stereo_baseline: distance between the two stereo cameras [m]; each sits half of it
        left / right of the mono camera's position (URDF: +/-0.03).
    :param texture_resolution: ground texture pixel size [m]. 5 mm keeps the markings' edges clean
        right in front of the car (1 cm shows stair-steps there) at no measurable cost when the
        car drives on; rendering scattered poses in turn costs ~20% more than at 1 cm.
    :param max_texture_pixels: cap on the texture's pixel count (bytes per mipmap level 0);
        larger tracks get coarser texels. 8 M px holds re:Invent 2018 at 5 mm, Spain at ~6 mm.
    :param texture_margin: ground painted around the track's bounding box [m] (the field reaches
        0.91 m, the walls' colour the rest); beyond it the ground reads as the wall straight ahead.
    :param mip_levels: number of coarser pyramid levels for distant rows (0 = none).
    :param max_bands: most warps of the ground per frame (bands of rows sharing a pyramid level);
        each call costs ~3 us of overhead, so 3 bands trade a little far-field filtering for speed.
    :param footprint_scale: a row samples the mipmap level of ``footprint_scale`` times its pixel
        footprint: below 1 because DeepRacer's frame averages 640x480 samples (finer than a
        160x120 pixel), fitted by ``benchmarks/camera_speed.py --fit``.
    """

    width: int = 160
    height: int = 120
    hfov: float = 1.13
    mount_forward: float = _MOUNT[0]
    mount_height: float = _MOUNT[1]
    pitch: float = _MOUNT[2]
    stereo_baseline: float = _MOUNT[3]
    texture_resolution: float = 0.005
    max_texture_pixels: int = 8_000_000
    texture_margin: float = 2.5
    mip_levels: int = 4
    max_bands: int = 3
    footprint_scale: float = 0.7

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
        if self.footprint_scale <= 0:
            raise ValueError(f"footprint_scale {self.footprint_scale} must be > 0")

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

    def project(self, forward: float, left: float, up: float = 0.0) -> tuple[float, float]:
        """Pixel (column, row) of a point ``forward`` / ``left`` / ``up`` [m] of the camera.

        ``up`` is relative to the ground below the camera (0 = on the ground).
        """
        sp, cp = math.sin(self.pitch), math.cos(self.pitch)
        dz = up - self.mount_height
        zc = cp * forward - sp * dz  # along the optical axis
        yc = -(sp * forward + cp * dz)  # down
        cx, cy = self.principal_point
        return cx + self.focal * (-left) / zc, cy + self.focal * yc / zc


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
        if getattr(self, "_reference", None) is None or self._reference.scene != self.scene:
            cfg = self.config
            big = replace(cfg, width=4 * cfg.width, height=4 * cfg.height, footprint_scale=1.0, max_bands=64)
            self._reference = CameraRenderer(self.track, big, self.scene)
        big_img = self._reference._template.copy()
        self._reference._ground(big_img, x, y, yaw, lateral)
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
