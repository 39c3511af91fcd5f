"""The camera frame at a place on a track, as a picture for people (``drx sim camera``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from drx.errors import SettingError
from drx.sim.camera import CameraRenderer
from drx.sim.camera_painter import WHEELBASE, track_points
from drx.sim.domain_randomization import randomized_scene
from drx.sim.scene import DEFAULT_SCENE, WALL_MARGIN, Scene

MAX_SCALE = 8
PANEL_GAP = 8  # [px] between the stereo panels


@dataclass(frozen=True)
class CarPlace:
    """Where the car stands: its origin (the middle of the wheelbase) and heading, and its rear
    axle (what the camera takes)."""

    x: float
    y: float
    heading: float  # [deg]
    rear_x: float
    rear_y: float


def place_car(track: Any, progress: float, offset: float = 0.0, heading: float = 0.0) -> CarPlace:
    """The car's origin ``progress`` percent along the centre line, ``offset`` m to its left,
    heading along the track turned ``heading`` degrees to the left.

    :raises DrxError: progress outside 0-100, or a place outside the walled field.
    """
    if not 0.0 <= progress <= 100.0:
        raise SettingError(
            "{field} {value:g} is outside 0-100; give a percentage of the lap.", "progress", value=progress
        )
    if not -180.0 <= heading <= 180.0:
        raise SettingError("{field} {value:g} is outside -180..180 degrees.", "heading", value=heading)
    s = progress / 100.0 * track.length
    if track.closed:
        s %= track.length
    point = np.asarray(track.point_at(np.array([s])), float)[0]
    yaw = float(np.asarray(track.heading_at(np.array([s])), float).reshape(-1)[0])
    x = float(point[0] - math.sin(yaw) * offset)
    y = float(point[1] + math.cos(yaw) * offset)
    pts = track_points(track)
    lo, hi = pts.min(axis=0) - WALL_MARGIN, pts.max(axis=0) + WALL_MARGIN
    if not (lo[0] < x < hi[0] and lo[1] < y < hi[1]):
        raise SettingError(
            "{field} {value:g} m puts the car outside the walls around the track; give a smaller offset.",
            "offset",
            value=offset,
        )
    yaw += math.radians(heading)
    back = WHEELBASE / 2
    return CarPlace(x, y, math.degrees(yaw), x - back * math.cos(yaw), y - back * math.sin(yaw))


def camera_picture(
    track: Any,
    place: CarPlace,
    *,
    stereo: bool = False,
    randomize: bool = False,
    seed: int = 0,
    scale: int = 4,
) -> tuple[np.ndarray, np.ndarray, Scene]:
    """The frame the car's camera sees at ``place``, and a picture of it for people.

    :param stereo: both stereo cameras, left and right panels side by side.
    :param randomize: a domain-randomised scene drawn with ``seed``.
    :param scale: the picture's pixels per camera pixel (nearest neighbour, 1-8).
    :returns: (frame, picture, scene): the observation ((120, 160) or (120, 160, 2) uint8), the
        enlarged grey picture (H, W) uint8, and the scene used.
    """
    if not 1 <= scale <= MAX_SCALE:
        raise SettingError(
            "{field} {value} is outside 1-{hi}; give the picture's pixels per camera pixel.",
            "scale",
            value=scale,
            hi=MAX_SCALE,
        )
    scene = randomized_scene(np.random.default_rng(seed)) if randomize else DEFAULT_SCENE
    cam = CameraRenderer(track, scene=scene)
    yaw = math.radians(place.heading)
    if stereo:
        frame = cam.render_stereo(place.rear_x, place.rear_y, yaw)
        panels = [frame[:, :, 0], frame[:, :, 1]]
    else:
        frame = cam.render(place.rear_x, place.rear_y, yaw)
        panels = [frame]
    big = [
        cv2.resize(p, (p.shape[1] * scale, p.shape[0] * scale), interpolation=cv2.INTER_NEAREST)
        for p in panels
    ]
    if len(big) == 2:
        gap = np.full((big[0].shape[0], PANEL_GAP), 255, np.uint8)
        picture = np.hstack([big[0], gap, big[1]])
    else:
        picture = big[0]
    return frame, picture, scene


__all__ = ["CarPlace", "camera_picture", "place_car"]
