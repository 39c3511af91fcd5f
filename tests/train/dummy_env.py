"""A tiny stand-in for ``drx/DeepRacer-v0`` with the same spaces and info keys.

The car drives a straight road; the camera frame shows a bright bar where the
road's centre is relative to the car. Steering moves the car sideways; leaving
|offset| > 1 ends the episode off track; 100% progress completes the lap.
A policy that steers toward the bar laps; a random one mostly does not.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from drx.vehicle import Vehicle, default_vehicle


class CorridorEnv(gym.Env):
    """Camera-shaped corridor env.

    :param vehicle: the car (discrete or continuous).
    :param mode: ``training`` (random start offset) or ``evaluation`` (start centred).
    :param lap_steps: steps to complete a lap at full speed.
    :param reward_function: optional DeepRacer reward function called with ``params``.
    :param lidar: add a ``lidar`` key (Dict observation).
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        vehicle: Vehicle | None = None,
        mode: str = "training",
        lap_steps: int = 60,
        reward_function: Any = None,
        lidar: bool = False,
    ) -> None:
        self.vehicle = vehicle or default_vehicle()
        self.mode = mode
        self.lap_steps = lap_steps
        self.reward_function = reward_function
        camera = spaces.Box(0, 255, (120, 160, 1), np.uint8)
        if lidar:
            self.observation_space: spaces.Space = spaces.Dict(
                {"camera": camera, "lidar": spaces.Box(0.0, 2.0, (8,), np.float32)}
            )
        else:
            self.observation_space = camera
        if self.vehicle.continuous:
            self.action_space: spaces.Space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        else:
            self.action_space = spaces.Discrete(self.vehicle.n_actions)
        self.offset = 0.0
        self.drift = 0.0
        self.progress = 0.0
        self.steps = 0
        self.episode = 0

    def _obs(self) -> Any:
        frame = np.zeros((120, 160, 1), np.uint8)
        col = int(np.clip(80 - self.offset * 60, 0, 159))
        frame[40:, max(0, col - 4) : col + 4, 0] = 255
        if isinstance(self.observation_space, spaces.Dict):
            return {"camera": frame, "lidar": np.full(8, 1.0 - abs(self.offset) / 2, np.float32)}
        return frame

    def _params(self, steering: float, speed: float) -> dict[str, Any]:
        return {
            "x": self.progress / 10.0, "y": self.offset, "heading": 0.0, "speed": speed,
            "steering_angle": steering, "progress": self.progress, "steps": self.steps,
            "track_length": 10.0, "track_width": 1.0, "distance_from_center": abs(self.offset) / 2,
            "is_left_of_center": self.offset > 0, "all_wheels_on_track": abs(self.offset) < 0.8,
            "is_offtrack": abs(self.offset) > 1.0, "is_crashed": False, "is_reversed": False,
            "closest_waypoints": [0, 1], "waypoints": [(0.0, 0.0), (10.0, 0.0)],
            "closest_objects": [0, 0], "objects_location": [], "objects_left_of_center": [],
            "objects_speed": [], "objects_heading": [], "objects_distance": [],
        }  # fmt: skip

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.offset = 0.0 if self.mode == "evaluation" else float(self.np_random.uniform(-0.5, 0.5))
        self.drift = 0.05 if self.episode % 2 else -0.05
        self.progress = 0.0
        self.steps = 0
        start = 0.0 if self.mode == "evaluation" else (self.episode * 0.05) % 1.0
        self.episode += 1
        return self._obs(), {"start_fraction": start, "params": self._params(0.0, 0.0)}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        if self.vehicle.continuous:
            steering, speed = self.vehicle.scale_continuous(np.asarray(action).reshape(-1))
        else:
            a = self.vehicle.actions[int(np.asarray(action).reshape(-1)[0])]
            steering, speed = a.steering_angle, a.speed
        self.steps += 1
        self.offset += steering / 30.0 * 0.15 + self.drift
        self.progress = min(100.0, self.progress + 100.0 / self.lap_steps * speed / self.vehicle.max_speed)
        params = self._params(steering, speed)
        if self.reward_function is not None:
            reward = float(self.reward_function(params))
        else:
            reward = float(1.0 - min(1.0, abs(self.offset)))
        off = abs(self.offset) > 1.0
        done_lap = self.progress >= 100.0
        status = "off_track" if off else "lap_complete" if done_lap else "in_progress"
        info = {"params": params, "episode_status": status, "progress": self.progress, "steps": self.steps}
        if done_lap:
            info["lap_time"] = self.steps / 15.0
        return self._obs(), reward, off or done_lap, False, info
