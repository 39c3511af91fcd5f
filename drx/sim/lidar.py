"""The car's lidar: 64 beams over 360 degrees, 0.15-2 m, seeing only boxes and bot cars.

DeepRacer's lidar is mounted above the road, so it sees the race objects and
nothing else (no borders, no ground). Beam ``i`` points ``-pi + i * 2 pi / 64``
from the car's heading, counter-clockwise (as a ROS ``LaserScan`` from
``angle_min = -pi``): beam 0 looks straight back, beam 16 to the right, beam 32
straight ahead, beam 48 to the left. A beam reads the distance to the first
object it meets, clipped to ``[0.15, 2.0]`` m; a beam that meets nothing reads
2.0 m.

``SECTOR_LIDAR`` (:meth:`Lidar.sectors`) is DeepRacer's binary variant: the 64
beams in 8 sectors of 8, each 1.0 when any of its beams reads less than 0.5 m,
else 0.0.

Speed: a scan is scalar Python over the few beams each nearby object can cover
(those within its bounding circle as seen from the sensor), into a Python list
turned into an array once; with nothing within 2 m it is one copy of a constant
array.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from drx.sim.objects import Rect

LIDAR_BEAMS = 64
LIDAR_RANGE = (0.15, 2.0)  # [m]
LIDAR_SECTORS = 8
SECTOR_CLIPPING_DISTANCE = 0.5  # [m] DeepRacer's SECTOR_LIDAR_CLIPPING_DIST
LIDAR_MOUNT_FORWARD = 0.08  # [m] ahead of the rear axle, above the middle of the car


class Lidar:
    """A 2-D lidar on the car.

    :param beams: beams over 360 degrees.
    :param min_range: closest reading [m].
    :param max_range: farthest reading [m] (also the reading of a beam that hits nothing).
    :param mount_forward: the sensor's position ahead of the rear axle [m].
    """

    def __init__(
        self,
        beams: int = LIDAR_BEAMS,
        min_range: float = LIDAR_RANGE[0],
        max_range: float = LIDAR_RANGE[1],
        mount_forward: float = LIDAR_MOUNT_FORWARD,
    ) -> None:
        self.beams, self.min_range, self.max_range = int(beams), float(min_range), float(max_range)
        self.mount_forward = float(mount_forward)
        self.step = 2.0 * math.pi / self.beams
        self._empty = np.full(self.beams, self.max_range, np.float32)
        angles = [self.angle(i) for i in range(self.beams)]
        self._cos = [math.cos(a) for a in angles]  # beam directions in the car's frame
        self._sin = [math.sin(a) for a in angles]

    def angle(self, i: int) -> float:
        """Direction of beam ``i`` relative to the car's heading [rad]."""
        return -math.pi + i * self.step

    def scan(self, rear_x: float, rear_y: float, yaw: float, rects: Sequence[Rect]) -> np.ndarray:
        """Ranges [m] of every beam, ``(beams,) float32``, for a car with rear axle ``(rear_x, rear_y)``
        heading ``yaw`` [rad] among objects ``rects`` (their visible rectangles)."""
        if not rects:
            return self._empty.copy()
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy = rear_x + c * self.mount_forward, rear_y + s * self.mount_forward
        far = self.max_range
        ranges: list[float] | None = None  # a list while casting: scalar writes to NumPy are slow
        for rect in rects:
            dx, dy = rect.x - ox, rect.y - oy
            r = rect.radius
            if dx * dx + dy * dy > (far + r) ** 2:
                continue
            if ranges is None:
                ranges = [far] * self.beams
            self._cast(ranges, ox, oy, c, s, rect)
        if ranges is None:
            return self._empty.copy()
        return np.array(ranges, np.float32)

    def _cast(self, out: list[float], ox: float, oy: float, c: float, s: float, rect: Rect) -> None:
        """Lower ``out`` where the beams that can reach ``rect`` meet it (slab test per beam);
        ``(c, s)`` are the cosine and sine of the car's heading."""
        rc, rs, hl, hw = rect.c, rect.s, rect.half_length, rect.half_width
        # the sensor in the rectangle's frame
        dx, dy = ox - rect.x, oy - rect.y
        px, py = rc * dx + rs * dy, -rs * dx + rc * dy
        if -hl <= px <= hl and -hw <= py <= hw:  # inside the object: every beam is blocked at once
            out[:] = [self.min_range] * self.beams
            return
        # beams within the rectangle's bounding circle as seen from the sensor
        dist = math.hypot(dx, dy)
        r = rect.radius
        half = math.asin(r / dist) if dist > r else math.pi / 2
        base = (math.atan2(-dy, -dx) - math.atan2(s, c) + math.pi) / self.step  # beam i at -pi + i * step
        spread = half / self.step
        first, last = math.ceil(base - spread - 1e-9), math.floor(base + spread + 1e-9)
        # beam directions turned into the rectangle's frame: rotate the car-frame table by (yaw - rect yaw)
        cr, sr = rc * c + rs * s, rc * s - rs * c
        cos_t, sin_t = self._cos, self._sin
        n, floor, inf = self.beams, self.min_range, math.inf
        for k in range(first, last + 1):
            i = k % n
            bc, bs = cos_t[i], sin_t[i]
            ux, uy = cr * bc - sr * bs, sr * bc + cr * bs
            # slab test of the ray (px, py) + t (ux, uy), t >= 0, against |x| <= hl, |y| <= hw
            if ux > 1e-12:
                t0, t1 = (-hl - px) / ux, (hl - px) / ux
            elif ux < -1e-12:
                t0, t1 = (hl - px) / ux, (-hl - px) / ux
            elif -hl <= px <= hl:
                t0, t1 = -inf, inf
            else:
                continue
            if uy > 1e-12:
                u0, u1 = (-hw - py) / uy, (hw - py) / uy
            elif uy < -1e-12:
                u0, u1 = (hw - py) / uy, (-hw - py) / uy
            elif -hw <= py <= hw:
                u0, u1 = -inf, inf
            else:
                continue
            enter = t0 if t0 > u0 else u0
            leave = t1 if t1 < u1 else u1
            if enter <= leave and leave >= 0.0:
                near = enter if enter > floor else floor  # closer than the lidar's minimum reads it
                if near < out[i]:
                    out[i] = near

    def sectors(self, ranges: np.ndarray) -> np.ndarray:
        """DeepRacer's ``SECTOR_LIDAR``: 8 values, 1.0 where a sector's nearest reading < 0.5 m."""
        per = self.beams // LIDAR_SECTORS
        near = ranges[: per * LIDAR_SECTORS].reshape(LIDAR_SECTORS, per).min(axis=1)
        return (near < SECTOR_CLIPPING_DISTANCE).astype(np.float32)
