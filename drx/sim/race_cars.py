"""The other cars of a multi-car race, as one car's scene (:class:`OtherCars`).

In a race of several models (``drx race``, :mod:`drx.evaluate.head_to_head`) every car is an
env of its own, and the other cars are objects in its scene: its camera and lidar see them, its
``params`` object keys list them (as DeepRacer gives them to each agent: ``objects_location``,
``objects_heading``, ``objects_speed``, ``closest_objects``, ...) and the env's crash test
(:meth:`RaceScene.hit`) tests its body against theirs. The race moves them (:meth:`OtherCars.move`)
from the other envs' cars before every step; the scene moves nothing itself.

A car standing out a penalty is a *ghost* (:meth:`OtherCars.move` with ``ghost=True``): still seen
by the cameras and the lidar, never hit, as DeepRacer takes a paused agent out of the collision
list while it blinks (deepracer-simapp ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``,
``_judge_action_at_run_phase``). A parked car (finished, under ``DONE_CONDITION`` ``all``) leaves
the track.
"""

from __future__ import annotations

import math

import numpy as np

from drx.settings.race import TIME_TRIAL
from drx.sim.dynamics import CarParams
from drx.sim.objects import Rect, SceneObject, make_rect, put_object
from drx.sim.race_scene import RaceScene
from drx.sim.track import Track

CAR_HEIGHT = 0.15  # [m] seen by the camera (DeepRacer's car is about as tall as its bot car)
PARKED = 1e6  # [m] where a parked car's rectangles go: off every track, out of every reach
_FAR: Rect = make_rect(PARKED, PARKED, 0.0, 0.01, 0.01)


class OtherCars(RaceScene):
    """The other cars of a race as one car's scene objects.

    :param track: the track in the race's driving direction.
    :param car: this car's constants (its body, for the crash test).
    :param others: the other cars' constants, in the race's order without this car.
    """

    def __init__(self, track: Track, car: CarParams, others: list[CarParams]) -> None:
        super().__init__(track, TIME_TRIAL, car)
        self.objects = [
            SceneObject("car", (o.length, o.width, CAR_HEIGHT), (o.length, o.width)) for o in others
        ]
        self._others = list(others)
        self._ghost = [False] * len(others)
        self._parked = [False] * len(others)
        self._refresh()

    @property
    def moving(self) -> bool:
        """The other cars move (they are drawn as cars)."""
        return True

    def reset(self, rng: np.random.Generator, start_s: float, training: bool) -> None:
        """Nothing: the race places the cars (:meth:`move`)."""

    def clear_start(self, s: float, step: float = 0.05) -> float:
        """The race's own start places stand: ``s``."""
        return s

    def move(
        self, index: int, rear_x: float, rear_y: float, yaw: float, speed: float, s: float,
        ghost: bool = False, parked: bool = False,
    ) -> None:  # fmt: skip
        """Put other car ``index`` at its rear-axle pose (projecting to ``s`` [m] on the centre line).

        :param ghost: it stands out a penalty: seen, never hit.
        :param parked: it finished and left the track: neither seen nor hit.
        """
        other, obj = self._others[index], self.objects[index]
        mid = 0.5 * other.wheelbase  # the body's centre, as RaceScene.hit takes this car's
        put_object(obj, self.frame, rear_x + mid * math.cos(yaw), rear_y + mid * math.sin(yaw), yaw, s)
        obj.speed = speed
        self._ghost[index], self._parked[index] = ghost, parked

    def refresh(self) -> None:
        """Rebuild the views after every :meth:`move` of a step."""
        self._refresh()

    def _refresh(self) -> None:
        super()._refresh()
        ghost, parked = getattr(self, "_ghost", ()), getattr(self, "_parked", ())
        for i in range(len(self.objects)):
            if i < len(ghost) and (ghost[i] or parked[i]):
                self._crash[i] = _FAR
            if i < len(parked) and parked[i]:
                self._bodies[i] = _FAR
        self._rows = [o.row for i, o in enumerate(self.objects) if not (i < len(parked) and parked[i])]
        heading = self._lists[3]
        for i, obj in enumerate(self.objects):
            heading[i] = obj.yaw  # a car has a heading (RaceScene gives boxes 0)

    def rows(self) -> list[tuple[float, ...]]:
        """Camera / top-down rows of the cars on the track."""
        return self._rows
