"""The front camera's configuration: size, field of view and mount, DeepRacer's by default.

Geometry: a pinhole camera with square pixels, horizontal field of view ``hfov``, mounted
``mount_forward`` ahead of the rear-axle centre and ``mount_height`` above the ground, pitched ``pitch``
down; the figures come from DeepRacer's URDF joint chain (:func:`deepracer_mount`). Camera axes
follow OpenCV: X right, Y down, Z forward; pixel centres at integers, the principal point at the
image centre. The renderer is :mod:`drx.sim.camera`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
