"""The race scene: a track's boxes or bot cars, episode by episode (:class:`RaceScene`).

:class:`RaceScene` holds a track's boxes or bots for one episode and hands
the environment what it needs each step: camera/top-down rows, lidar
rectangles, the ``params`` object keys, and the index of an object hit.
Its pieces (lane frame, boxes, rectangles) are in :mod:`drx.sim.objects`, the bots in :mod:`drx.sim.bots`.
"""

from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np

from drx.settings.race import RaceConfig
from drx.sim.dynamics import CarParams
from drx.sim.objects import (
    BOX_CRASH_SIZE,
    BOX_SIZE,
    LaneFrame,
    Rect,
    SceneObject,
    box_places,
    no_objects,
    rects_overlap,
)
from drx.sim.track import Track

START_CLEARANCE = 0.15  # [m] a training start is moved until the car is this far from every object


class RaceScene:
    """The boxes or bot cars of one race, episode by episode.

    :param track: the track in the episode's driving direction.
    :param race: the race settings.
    :param car: the agent car's constants (its body, for crashes).
    """

    def __init__(self, track: Track, race: RaceConfig, car: CarParams | None = None) -> None:
        from drx.sim.bots import BotTraffic  # highway-env's models load only for head-to-bot

        self.track, self.race, self.car = track, race, car or CarParams()
        self.frame = LaneFrame(track)
        self.objects: list[SceneObject] = []
        self.bots = BotTraffic(self.frame, race) if race.race_type == "head-to-bot" else None
        self._rows: list[tuple[float, ...]] = []
        self._crash: list[Rect] = []
        self._bodies: list[Rect] = []
        self._reach: list[float] = []
        self._order: list[int] = []
        self._sorted_s: list[float] = []
        self._lists: tuple[list[Any], ...] = ([], [], [], [], [])

    @property
    def moving(self) -> bool:
        """Whether objects move (bots)."""
        return self.bots is not None

    def reset(self, rng: np.random.Generator, start_s: float, training: bool) -> None:
        """Place the objects for a new episode that starts at ``start_s`` [m].

        Boxes are placed from the start line (fixed, or random when ``randomize_objects`` and
        ``training``); bots from the episode's start (DeepRacer's 2 m ahead to 1 m behind).
        """
        if self.bots is not None:
            self.objects = self.bots.reset(rng, start_s, training and self.race.randomize_bots)
        elif self.race.race_type == "object-avoidance":
            places = box_places(self.race, rng if training else None)
            self.objects = []
            for frac, lane in places:
                obj = SceneObject("box", BOX_SIZE, BOX_CRASH_SIZE)
                s = frac * self.track.length
                obj.place(self.frame, s, self.frame.lane_offset(s, self.frame.lane_of(lane, s)))
                self.objects.append(obj)
        else:
            self.objects = []
        self._reach = []
        self._refresh()

    def step(self, dt: float) -> None:
        """Advance moving objects by ``dt`` [s]."""
        if self.bots is not None:
            self.bots.step(dt)
            self._refresh()

    def _refresh(self) -> None:
        """Rebuild the per-step views (camera rows, rectangles, params lists) from the objects."""
        objs = self.objects
        self._rows = [o.row for o in objs]
        self._crash = [o.crash_rect for o in objs]
        self._bodies = [o.body_rect for o in objs]
        dist = [o.s for o in objs]
        order = sorted(range(len(objs)), key=dist.__getitem__)
        self._order = order
        self._sorted_s = [dist[i] for i in order]
        self._lists = (
            [[o.x, o.y] for o in objs],
            [o.offset > 0.0 for o in objs],
            [o.speed for o in objs],
            [o.yaw if o.kind == "bot" else 0.0 for o in objs],  # DeepRacer: boxes have heading 0
            dist,
        )
        if len(self._reach) != len(objs):
            car_r = math.hypot(0.5 * self.car.length, 0.5 * self.car.width)
            self._reach = [(car_r + o.reach) ** 2 for o in objs]

    # ----- per step ---------------------------------------------------------------------------
    def rows(self) -> list[tuple[float, ...]]:
        """Camera / top-down rows ``(x, y, yaw, length, width, height)``."""
        return self._rows

    def bodies(self) -> list[Rect]:
        """The objects' visible rectangles (for the lidar)."""
        return self._bodies

    def hit(self, rear_x: float, rear_y: float, yaw: float, grow: float = 0.0) -> int | None:
        """Index of the first object the car's body overlaps (grown by ``grow`` m), else ``None``."""
        if not self.objects:
            return None
        car = self.car
        c, s = math.cos(yaw), math.sin(yaw)
        mid = 0.5 * car.wheelbase
        bx, by = rear_x + c * mid, rear_y + s * mid
        reaches = self._reach
        if grow:
            reaches = [(math.sqrt(r) + 1.5 * grow) ** 2 for r in reaches]
        body = None
        for i, rect in enumerate(self._crash):
            dx, dy = rect.x - bx, rect.y - by
            if dx * dx + dy * dy > reaches[i]:
                continue  # too far to touch: no rectangle test
            if body is None:
                body = Rect(bx, by, c, s, 0.5 * car.length + grow, 0.5 * car.width + grow)
            if rects_overlap(body, rect):
                return i
        return None

    def params(self, car_s: float) -> dict[str, Any]:
        """DeepRacer's object keys for a car whose reference point projects to ``car_s`` [m].

        ``closest_objects`` is DeepRacer's ``find_prev_next`` over the objects' distances along the
        centre line (the object just behind and just ahead, wrapping around the lap); drx applies it
        in sorted order, so it stays right while bots overtake each other.
        """
        loc, left, speed, heading, dist = self._lists
        if not loc:
            return no_objects()
        n = len(loc)
        k = bisect.bisect_right(self._sorted_s, car_s)
        prev_k = k - 1 if k > 0 else n - 1
        next_k = k if k < n else 0
        return {
            "closest_objects": [self._order[prev_k], self._order[next_k]],
            "objects_location": [list(p) for p in loc],
            "objects_left_of_center": list(left),
            "objects_speed": list(speed),
            "objects_heading": list(heading),
            "objects_distance": list(dist),
        }

    def clear_start(self, s: float, step: float = 0.05) -> float:
        """The first distance from ``s`` onwards [m] where a car on the centre line, heading along
        the track, keeps :data:`START_CLEARANCE` from every object."""
        for k in range(int(self.track.length / step) + 1):
            t = self.frame.wrap(s + k * step) if self.track.closed else min(s + k * step, self.track.length)
            if self.clear_at(t):
                return t
        return s

    def clear_at(self, s: float) -> bool:
        """Whether a car with its reference point on the centre line at ``s`` is clear of objects."""
        x, y, h = self.frame.pose(s)
        rx, ry = x - self.car.reference_offset * math.cos(h), y - self.car.reference_offset * math.sin(h)
        return self.hit(rx, ry, h, grow=START_CLEARANCE) is None

    def behind(self, index: int, gap: float) -> float:
        """The centre-line distance [m] ``gap`` behind object ``index`` (where a crashed car resumes)."""
        obj = self.objects[index]
        back = obj.s - 0.5 * obj.crash[0] - gap
        return self.frame.wrap(back) if self.track.closed else max(back, self.car.reference_offset + 0.02)
