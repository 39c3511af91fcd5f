"""Race objects on the track: box placements, lane coordinates and collisions.

Placement follows DeepRacer's simulator (``ObstaclesCtrl``): boxes sit on the
centre of the inside or outside lane (halfway between the centre line and a
border), at fractions of the lap measured from the start line along the
driving direction; without given places they are spread evenly, alternating
lanes from the inside; randomised, each episode draws new places at least
13% of the lap apart and a random lane for each.

A box is :data:`BOX_SIZE` (length along the lane, width, height); DeepRacer
tests crashes against the box grown by 5 cm on every side
(:data:`BOX_CRASH_SIZE`), and so does drx. A crash is the car's body
rectangle (``CarParams.length`` x ``width``, centred between the axles)
overlapping an object's crash rectangle (separating-axis test, scalar).
"""

from __future__ import annotations

import bisect
import math
from typing import Any, NamedTuple

import numpy as np

from drx.settings.race import OBJECT_MIN_GAP, OBJECT_PLACE_RANGE, RaceConfig
from drx.sim.dynamics import CarParams
from drx.sim.track import Track

BOX_SIZE = (0.30, 0.40, 0.25)  # [m] length (along the lane), width, height of a box
BOX_CRASH_SIZE = (0.40, 0.50)  # [m] DeepRacer's crash footprint of a box (5 cm around it)


def no_objects() -> dict[str, Any]:
    """DeepRacer's object keys (``closest_objects``, ``objects_*``) with no race objects, as in a
    time trial; new lists on every call, so a reward that changes them changes nothing else."""
    return {
        "closest_objects": [0, 0],
        "objects_location": [],
        "objects_left_of_center": [],
        "objects_speed": [],
        "objects_heading": [],
        "objects_distance": [],
    }


class Rect(NamedTuple):
    """An oriented rectangle on the ground: centre [m], direction cosines, half sizes [m]."""

    x: float
    y: float
    c: float
    s: float
    half_length: float
    half_width: float

    @property
    def radius(self) -> float:
        """Half its diagonal [m]."""
        return math.hypot(self.half_length, self.half_width)


def make_rect(x: float, y: float, yaw: float, length: float, width: float) -> Rect:
    """The rectangle of a ``length`` x ``width`` object at ``(x, y)`` heading ``yaw`` [rad]."""
    return Rect(x, y, math.cos(yaw), math.sin(yaw), 0.5 * length, 0.5 * width)


def rects_overlap(a: Rect, b: Rect) -> bool:
    """Separating-axis test of two oriented rectangles (touching counts as overlapping)."""
    dx, dy = b.x - a.x, b.y - a.y
    for ux, uy in ((a.c, a.s), (-a.s, a.c), (b.c, b.s), (-b.s, b.c)):
        ra = a.half_length * abs(a.c * ux + a.s * uy) + a.half_width * abs(a.c * uy - a.s * ux)
        rb = b.half_length * abs(b.c * ux + b.s * uy) + b.half_width * abs(b.c * uy - b.s * ux)
        if abs(dx * ux + dy * uy) > ra + rb:
            return False
    return True


def car_rect(rear_x: float, rear_y: float, yaw: float, car: CarParams) -> Rect:
    """The car's body: ``length`` x ``width`` centred halfway between the axles."""
    c, s = math.cos(yaw), math.sin(yaw)
    mid = 0.5 * car.wheelbase
    return Rect(rear_x + c * mid, rear_y + s * mid, c, s, 0.5 * car.length, 0.5 * car.width)


class LaneFrame:
    """Lane coordinates ``(s, offset)`` on a track: distance along the centre line from the start
    line [m] and signed offset to its left [m], turned into world poses with scalar code.

    Headings are interpolated between waypoints (each waypoint takes the mean direction of its two
    segments), so an object driving a lane moves and turns smoothly through corners.
    """

    def __init__(self, track: Track) -> None:
        self.track = track
        self.length = track.length
        self.closed = track.closed
        cum = track.cumulative
        center = track.center
        keep = np.concatenate([[True], np.diff(cum) > 1e-9])  # drop repeated points
        self._cum = cum[keep].tolist()
        self._x = center[keep, 0].tolist()
        self._y = center[keep, 1].tolist()
        seg = np.arctan2(np.diff(center[keep, 1]), np.diff(center[keep, 0]))
        if track.closed:
            before = np.concatenate([[seg[-1]], seg])
            after = np.concatenate([seg, [seg[0]]])
        else:
            before = np.concatenate([[seg[0]], seg])
            after = np.concatenate([seg, [seg[-1]]])
        vertex = before + 0.5 * np.angle(np.exp(1j * (after - before)))
        self._h = vertex.tolist()
        # the turn from vertex k to k+1, wrapped, so interpolation never goes the long way round
        self._dh = np.angle(np.exp(1j * np.diff(vertex))).tolist()
        self._n = len(self._cum)
        # per waypoint: +1 where the inner border lies left of the driving direction, else -1
        # (DeepRacer's inside lane follows the inner border, also where a track's turns change side)
        tangent = np.gradient(center, axis=0)
        to_inner = track.inner - center
        side = np.where(tangent[:, 0] * to_inner[:, 1] - tangent[:, 1] * to_inner[:, 0] >= 0, 1.0, -1.0)
        self._inside = side.tolist()
        self._inside_cum = cum.tolist()
        self.inside = float(np.sign(side.sum()) or 1.0)  # the side the inner border is on mostly

    def wrap(self, s: float) -> float:
        """``s`` folded into ``[0, length)`` on a loop, clamped on an open track."""
        if self.closed:
            return s % self.length
        return 0.0 if s < 0.0 else (self.length if s > self.length else s)

    def pose(self, s: float, offset: float = 0.0) -> tuple[float, float, float]:
        """World ``(x, y, heading [rad])`` of the point ``offset`` m left of the centre line at ``s``."""
        s = self.wrap(s)
        cum = self._cum
        i = bisect.bisect_right(cum, s) - 1
        i = 0 if i < 0 else (self._n - 2 if i > self._n - 2 else i)
        t = (s - cum[i]) / (cum[i + 1] - cum[i])
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        x = self._x[i] + t * (self._x[i + 1] - self._x[i])
        y = self._y[i] + t * (self._y[i + 1] - self._y[i])
        h = self._h[i] + t * self._dh[i]
        return x - offset * math.sin(h), y + offset * math.cos(h), h

    def lane_offset(self, s: float, lane: float) -> float:
        """Offset [m] of lane coordinate ``lane`` at ``s``: +1 = the left lane's centre (a quarter of
        the road width left of the centre line), -1 = the right lane's, 0 = the centre line."""
        return lane * 0.25 * self.track.width_at(self.wrap(s))

    def lane_of(self, side: str, s: float | None = None) -> float:
        """``inside`` / ``outside`` as a lane coordinate (+1 left, -1 right) at ``s`` [m] (the
        inside is the inner border's side there); without ``s``, on most of the track."""
        inside = self.inside
        if s is not None:
            k = bisect.bisect_right(self._inside_cum, self.wrap(s)) - 1
            inside = self._inside[min(max(k, 0), len(self._inside) - 1)]
        return inside if side == "inside" else -inside


def box_places(race: RaceConfig, rng: np.random.Generator | None = None) -> list[tuple[float, str]]:
    """Where the boxes go: ``(fraction of the lap, lane)`` pairs in driving order.

    The user's places when given; random ones when ``race.randomize_objects`` and an ``rng`` is
    given (uniform over every layout that keeps the 13% spacing); else evenly spread over
    7%-90% of the lap, alternating lanes from the inside (DeepRacer's fixed layout).
    """
    n = race.box_count
    if race.object_positions:
        return list(race.object_positions)
    lo, hi = OBJECT_PLACE_RANGE
    if race.randomize_objects and rng is not None:
        slack = (hi - lo) - (n - 1) * OBJECT_MIN_GAP
        draws = rng.random(2 * n).tolist()  # one call: n places, then n lanes (resets are frequent)
        places = sorted(slack * u for u in draws[:n])
        return [
            (lo + u + i * OBJECT_MIN_GAP, "outside" if k >= 0.5 else "inside")
            for i, (u, k) in enumerate(zip(places, draws[n:], strict=True))
        ]
    return [(lo + (hi - lo) * (i + 0.5) / n, ("inside", "outside")[i % 2]) for i in range(n)]


class SceneObject:
    """One box or bot as the env sees it this step (all poses are the object's centre).

    :param kind: ``box`` or ``bot``.
    :param size: ``(length, width, height)`` [m] as seen by the camera and the lidar.
    :param crash: ``(length, width)`` [m] of the footprint a crash is tested against.

    After :meth:`place`: ``s`` (distance along the centre line from the start line [m], in
    ``[0, length)``), ``offset`` (signed, left of the centre line [m]), ``x``, ``y``, ``yaw``,
    ``row`` (the camera's), ``crash_rect`` and ``body_rect`` (the lidar's).
    """

    __slots__ = ("kind", "x", "y", "yaw", "s", "offset", "speed", "size", "crash", "row", "crash_rect",
                 "body_rect", "reach", "_halves", "_same")  # fmt: skip

    def __init__(self, kind: str, size: tuple[float, float, float], crash: tuple[float, float]) -> None:
        self.kind, self.size, self.crash = kind, size, crash
        self.x = self.y = self.yaw = self.s = self.offset = self.speed = 0.0
        self.row: tuple[float, ...] = (0.0, 0.0, 0.0, *size)
        self.crash_rect = self.body_rect = make_rect(0.0, 0.0, 0.0, *crash)
        self.reach = math.hypot(0.5 * crash[0], 0.5 * crash[1])  # [m] the crash footprint's half diagonal
        self._halves = (0.5 * size[0], 0.5 * size[1], 0.5 * crash[0], 0.5 * crash[1])
        self._same = tuple(crash) == tuple(size[:2])  # the crash footprint is the body (bots)

    def place(self, frame: LaneFrame, s: float, offset: float, yaw_extra: float = 0.0) -> None:
        """Put the object at lane coordinates ``(s, offset)``, heading along the lane (+ ``yaw_extra``)."""
        self.s = s = frame.wrap(s)
        self.offset = offset
        x, y, h = frame.pose(s, offset)
        yaw = h + yaw_extra
        self.x, self.y, self.yaw = x, y, yaw
        c, sn = math.cos(yaw), math.sin(yaw)
        half_l, half_w, crash_l, crash_w = self._halves
        self.row = (x, y, yaw, *self.size)
        self.body_rect = Rect(x, y, c, sn, half_l, half_w)
        self.crash_rect = self.body_rect if self._same else Rect(x, y, c, sn, crash_l, crash_w)


def put_object(obj: SceneObject, frame: LaneFrame, x: float, y: float, yaw: float, s: float) -> None:
    """Put ``obj`` at a world pose (its centre ``(x, y)`` [m], ``yaw`` [rad]) that projects to ``s`` [m]
    on the centre line: a car driven by a policy, not by lane coordinates."""
    obj.s = frame.wrap(s)
    cx, cy, _ = frame.pose(obj.s)
    h = frame.pose(obj.s)[2]
    obj.offset = -(x - cx) * math.sin(h) + (y - cy) * math.cos(h)
    obj.x, obj.y, obj.yaw = x, y, yaw
    c, sn = math.cos(yaw), math.sin(yaw)
    half_l, half_w, crash_l, crash_w = obj._halves
    obj.row = (x, y, yaw, *obj.size)
    obj.body_rect = Rect(x, y, c, sn, half_l, half_w)
    obj.crash_rect = obj.body_rect if obj._same else Rect(x, y, c, sn, crash_l, crash_w)
