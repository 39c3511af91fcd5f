"""``drx/DeepRacer-v0``: the Gymnasium environment a DeepRacer car trains in.

One step = one camera frame = 1/15 s. The step is scalar Python over
precomputed data (see :mod:`drx.sim.track`): move the car
(:func:`~drx.sim.dynamics.step_car`), project its reference point with a
windowed search around last step's segment, look the four wheels up in the
road raster, build DeepRacer's ``params``, call the reward function, render
the camera (:mod:`drx.sim.camera`, one warp of a pre-painted ground texture).
In object-avoidance and head-to-bot races (:mod:`drx.settings.race`) a
:class:`~drx.sim.race_scene.RaceScene` moves the bots, tests the car against every
object (a hit ends the episode as ``crashed``), fills the ``params`` object keys
and hands the boxes to the camera and the lidar (:mod:`drx.sim.lidar`).

From highway-env drx takes the configuration habit (documented defaults with
units), the kinematic-bicycle conventions of its ``Vehicle`` and its
top-down-video idea; its road network, vehicle classes and pygame renderer are
not used, because a highway-env step costs more than drx's whole step budget
and its lanes cannot represent DeepRacer's data-defined tracks (see the
module docstrings of ``track`` and ``dynamics``). Bot cars drive by its
IDM/MOBIL behaviour models on drx's lane coordinate (:mod:`drx.sim.bots`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from drx.errors import DrxError
from drx.settings.race import RaceConfig
from drx.sim.dynamics import CarParams, CarState, rear_axle_from_origin, rear_axle_from_reference, step_car
from drx.sim.episode_status import EpisodeStatus
from drx.sim.lidar import LIDAR_BEAMS, LIDAR_RANGE, LIDAR_SECTORS, Lidar
from drx.sim.noise import StepNoise
from drx.sim.params import PARAM_KEYS, compute_params
from drx.sim.reward_loader import RewardFunction, load_reward_function
from drx.sim.track import Track, load_track
from drx.vehicle import Vehicle, default_vehicle

ROUND_ROBIN_STEP = 0.05  # fraction of the lap the training start moves after every episode
IMMOBILIZED_STEPS = 15  # steps in a row moving less than IMMOBILIZED_DISTANCE
IMMOBILIZED_DISTANCE = 0.0003  # [m] 0.3 mm
REVERSED_STEPS = 15  # steps in a row with progress going down
DEFAULT_MAX_STEPS = 10_000  # truncation ("time_up"), 11 simulated minutes
CRASH_RESET_GAP = 0.5  # [m] a crashed car resumes this far behind the object's crash footprint
LIDAR_TYPES = ("lidar", "sector")  # 64 ranges, or DeepRacer's SECTOR_LIDAR (8 binary sectors)


def center_line_reward(params: dict[str, Any]) -> float:
    """drx's built-in reward: DeepRacer's "follow the centre line" example."""
    width, dist = params["track_width"], params["distance_from_center"]
    if dist <= 0.1 * width:
        return 1.0
    if dist <= 0.25 * width:
        return 0.5
    if dist <= 0.5 * width:
        return 0.1
    return 1e-3


class DeepRacerEnv(gym.Env):
    """A DeepRacer car on a track, seen through its front camera.

    :param track: a track name (``$DRX_HOME/tracks``, then the project's ``tracks/``), a ``.npy``
        route path, or a :class:`Track`; default the project's ``oval``.
    :param vehicle: a :class:`Vehicle`, its dict, or ``None`` for DeepRacer's default car.
    :param reward_function: a callable, a reward ``.py`` path, or ``None`` for :func:`center_line_reward`.
    :param mode: ``"training"`` (start moves 5% further every episode) or ``"evaluation"`` (start line).
    :param reverse: drive the track in its reverse direction (``params["is_reversed"]``).
    :param car: the car's physical constants (:class:`CarParams`).
    :param camera: a :class:`~drx.sim.camera.CameraConfig`, or any object with
        ``render(x, y, yaw) -> (H, W) uint8`` (and ``render_stereo`` for stereo cars),
        ``(x, y)`` the rear axle [m], ``yaw`` [rad].
    :param max_steps: steps before the episode is truncated with status ``time_up``.
    :param render_mode: ``None`` or ``"rgb_array"`` (top-down picture with the camera inset).
    :param extra_params: drx-only keys added to every ``params`` dict (e.g. a racing line's
        waypoints); they may not shadow DeepRacer's keys, so a DeepRacer reward runs unchanged.
    :param race: a :class:`~drx.settings.race.RaceConfig`, its dict, or a race type name; default a
        time trial. Object avoidance puts boxes on the track, head-to-bot bot cars
        (:mod:`drx.sim.race_scene`, :mod:`drx.sim.objects`, :mod:`drx.sim.bots`); hitting one ends
        the episode as ``crashed``.
    :param lidar_type: for a car with a lidar: ``"lidar"`` (64 ranges [m]) or ``"sector"``
        (DeepRacer's SECTOR_LIDAR, 8 values of 0/1); see :mod:`drx.sim.lidar`.
    :param deterministic: ``False`` (default): steps vary in length as DeepRacer's do
        (:mod:`drx.sim.noise`, seeded by ``reset(seed=...)``); ``True``: every step is exactly
        ``1 / rate_hz``, for tests and tools.
    :param domain_randomization: a new look (sun colour, surface colours) on every reset, drawn
        from the env's seeded ``np_random`` (:mod:`drx.sim.domain_randomization`); DeepRacer's
        ``ENABLE_DOMAIN_RANDOMIZATION``. Training turns it on for models that have it.
    :param car_randomization: in training mode, every reset draws a car between DeepRacer simulator
        5's and 6's (:mod:`drx.sim.car_randomization`) from the env's ``np_random``; ``car`` is the car
        before the first reset and the car of evaluation mode.
    :param clock: ``None``, or an object with ``step_time() -> s`` and ``reseed(rng)`` that every car of
        a multi-car race shares (:mod:`drx.evaluate.head_to_head`), so all of them step by the same
        length, as they do in DeepRacer's one Gazebo world.

    The env alone decides how a step ends (:meth:`step`, ``_step_status``): its
    :class:`~drx.sim.episode_status.EpisodeStatus` is ``info["episode_status"]`` and the attribute
    :attr:`status` (``prepare`` after a reset, ``pause`` after a penalised resume); ``terminated``
    is every ending but ``time_up``, which is ``truncated``. Evaluation and training read it
    (``docs/CONTRACTS.md``, Episodes); they place the car only through :meth:`reset`'s options.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 15}

    def __init__(
        self,
        track: str | Path | Track = "oval",
        vehicle: Vehicle | dict[str, Any] | None = None,
        reward_function: Callable[[dict], Any] | str | Path | None = None,
        mode: str = "training",
        reverse: bool = False,
        car: CarParams | None = None,
        camera: Any = None,
        max_steps: int = DEFAULT_MAX_STEPS,
        render_mode: str | None = None,
        extra_params: dict[str, Any] | None = None,
        race: RaceConfig | dict[str, Any] | str | None = None,
        lidar_type: str = "lidar",
        deterministic: bool = False,
        domain_randomization: bool = False,
        car_randomization: bool = False,
        clock: Any = None,
    ) -> None:
        if mode not in ("training", "evaluation"):
            raise DrxError(f"mode {mode!r} is unknown; use 'training' or 'evaluation'.")
        if render_mode not in (None, "rgb_array"):
            raise DrxError(f"render_mode {render_mode!r} is not supported; use None or 'rgb_array'.")
        base = track if isinstance(track, Track) else load_track(track)
        self.track = base.reversed() if reverse else base
        self.reverse = bool(reverse)
        if vehicle is None:
            vehicle = default_vehicle()
        elif isinstance(vehicle, dict):
            vehicle = Vehicle.from_dict(vehicle)
        self.vehicle: Vehicle = vehicle
        self.reward_fn: RewardFunction = load_reward_function(reward_function or center_line_reward)
        self.mode = mode
        self.car = car or CarParams()
        self.deterministic = bool(deterministic)
        # The step lengths: the env's own noise, or a clock the cars of one race share (its ``step_time()``
        # gives every car the same step, so they move in lockstep; ``reseed`` is then the clock's own).
        self._noise: Any = clock if clock is not None else StepNoise(
            self.car, self.np_random, enabled=not self.deterministic
        )
        self._sim_time = 0.0  # [s] simulated time since the episode (or lap) started
        self.max_steps = int(max_steps)
        self.extra_params = dict(extra_params or {})
        clash = sorted(set(self.extra_params) & set(PARAM_KEYS))
        if clash:
            raise DrxError(f"extra_params may not replace DeepRacer's params keys: {', '.join(clash)}.")
        self.render_mode = render_mode
        self.race = _race_config(race)
        self.scene: Any = None
        if self.race.has_objects:
            from drx.sim.race_scene import RaceScene

            self.scene = RaceScene(self.track, self.race, self.car)
            self.scene.reset(np.random.default_rng(0), 0.0, training=False)  # objects exist before reset
        self.camera = self._make_camera(camera)
        self.domain_randomization = bool(domain_randomization)
        self._car_randomizer: Any = None
        if car_randomization:  # a car between simulator 5's and 6's every episode (training only)
            from drx.sim.car_randomization import CarRandomizer

            self._car_randomizer = CarRandomizer.between_simulators()
        self._stereo = vehicle.sensor == "stereo"
        h, w = int(self.camera.config.height), int(self.camera.config.width)
        image = spaces.Box(0, 255, (h, w, 2 if self._stereo else 1), np.uint8)
        if lidar_type not in LIDAR_TYPES:
            raise DrxError(f"lidar_type {lidar_type!r} is unknown; use 'lidar' or 'sector'.")
        self.lidar_type = lidar_type
        self.lidar: Lidar | None = Lidar() if vehicle.lidar else None
        if vehicle.lidar:
            if lidar_type == "sector":
                lidar = spaces.Box(0.0, 1.0, (LIDAR_SECTORS,), np.float32)
            else:
                lidar = spaces.Box(LIDAR_RANGE[0], LIDAR_RANGE[1], (LIDAR_BEAMS,), np.float32)
            self.observation_space: spaces.Space = spaces.Dict({"camera": image, "lidar": lidar})
        else:
            self.observation_space = image
        if vehicle.continuous:
            self.action_space: spaces.Space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        else:
            self.action_space = spaces.Discrete(vehicle.n_actions)
        self._actions = [(a.steering_angle, a.speed) for a in vehicle.actions]
        self._episode = 0  # episodes started without an explicit start, for the round robin
        self._state = CarState(0.0, 0.0, 0.0)
        self._top_down: Any = None
        self._trail: list[tuple[float, float]] = []
        self._last_obs: Any = None
        self.params: dict[str, Any] = {}
        self.status = EpisodeStatus.PREPARE
        self._crashed: int | None = None  # the object hit on the last step

    def _make_camera(self, camera: Any) -> Any:
        if camera is not None and hasattr(camera, "render"):
            return camera
        from drx.sim.camera import CameraConfig, CameraRenderer

        if camera is not None and not isinstance(camera, CameraConfig):
            raise DrxError("camera must be a CameraConfig or an object with render(x, y, yaw).")
        return CameraRenderer(self.track, camera or CameraConfig())

    # ----- episode start ------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Start an episode.

        :param options: ``{"start": fraction_of_lap}`` (the car's origin, the middle of the
            wheelbase, on the centre line there, heading along it, as DeepRacer starts a car:
            progress counts from that point, so the first step already shows the reference point's
            0.222 m lead), or ``{"pose": {"x": m, "y": m, "heading": deg}}`` (the reference point;
            progress counts from there). Either may add ``"speed"`` [m/s] and ``"steering"`` [deg]:
            the car starts moving at that speed with its wheels at that angle, as if it had been
            commanded so (default: at rest, wheels straight). Without options: training starts 5%
            of the lap further than the last episode, evaluation at the start line. A ``seed``
            restarts that round robin and the step-time noise.
            ``{"episode": n}`` (an int >= 0) sets that round robin's position: the first training
            reset without a ``start`` or ``pose`` from here on (this one, when it has neither) is
            episode ``n``, ``n * ROUND_ROBIN_STEP`` of the lap from the line, and the ones after it
            go on from ``n + 1``; it wins over a ``seed``'s restart. A trainer resuming a run passes
            the episodes it has driven.
            ``{"resume": True}`` is DeepRacer's evaluation reset after an off-track, reversed or
            immobilized ending: the car restarts at rest at the previous step's progress, its origin
            on the nearer lane (halfway between the centre line and that border), heading along
            the track, keeping steps and progress (deepracer-simapp
            ``markov/agent_ctrl/rollout_agent_ctrl.py`` ``_get_car_reset_model_state``); after a
            crash, ``CRASH_RESET_GAP`` behind the object it hit (progress goes back with it).
            ``"in_place": True`` with ``resume`` stops the car where it stands instead (DeepRacer's
            multi-car crash: ``_judge_action_at_run_phase`` pauses an agent that hit another car at its
            current pose). ``{"next_lap": True}`` goes on over the line without moving the car (a
            multi-car race's continuous laps): progress, steps and the lap clock restart.
            With ``start``, ``"lane": metres`` puts the origin that far left (+) or right (-) of the
            centre line, and ``"line": fraction`` counts progress from that line instead of from the
            start (a car staggered behind the line starts with negative :attr:`distance`).
            ``"pause": seconds`` with ``resume`` marks the penalty the car stands for (the info's
            ``episode_status`` is then ``pause`` with ``pause_duration``, as DeepRacer's trace shows).
            Boxes and bots are placed anew on every reset without a ``pose`` or ``resume`` (boxes
            at random places when the race randomises them and the env is training; bots from the
            episode's start); a ``pose`` keeps them where they are (an evaluation's next lap goes
            on among the same bots). A start that would touch an object moves forward until the
            car is clear of it.
        """
        super().reset(seed=seed)
        if seed is not None:  # a seed restarts the schedule, so equal seeds give equal episodes
            self._episode = 0
            self._noise.reseed(self.np_random)
        options = options or {}
        if "episode" in options:
            self._episode = _episode_option(options["episode"])
        if options.get("next_lap") and self.params:
            return self._next_lap()
        if options.get("resume") and self.params:
            obs, info = self._resume(bool(options.get("in_place")))
            pause = float(options.get("pause", 0.0) or 0.0)
            if pause > 0.0:  # the car stands for the penalty before it goes on (DeepRacer's "pause")
                self.status = info["episode_status"] = EpisodeStatus.PAUSE
                info["pause_duration"] = pause
            return obs, info
        if self.domain_randomization and hasattr(self.camera, "set_scene"):
            from drx.sim.domain_randomization import randomized_scene

            self.camera.set_scene(randomized_scene(self.np_random))  # a new look every episode
        if self._car_randomizer is not None and self.mode == "training":
            self.car = self._car_randomizer.draw(self.np_random)
        track, car = self.track, self.car
        speed, steering = _motion_options(options)
        self._sim_time = 0.0
        if "pose" in options:
            ref_x, ref_y, yaw = _pose_option(options["pose"])
            start_s = track.project(ref_x, ref_y).s
            rx, ry = rear_axle_from_reference(ref_x, ref_y, yaw, car)
        else:
            if "start" in options:
                frac = _start_option(options["start"])
            elif self.mode == "training":
                frac = (self._episode * ROUND_ROBIN_STEP) % 1.0
                self._episode += 1
            else:
                frac = 0.0
            start_s = frac * track.length
            if not track.closed:  # keep the rear wheels on the road and at least 1 m to drive
                start_s = min(max(start_s, car.origin_offset + 0.02), max(track.length - 1.0, 0.0))
            if self.scene is not None:
                self.scene.reset(self.np_random, start_s, self.mode == "training")
                start_s = self.scene.clear_start(start_s)
            origin_x, origin_y = (float(v) for v in track.point_at(start_s))
            yaw = float(track.heading_at(start_s))
            lane = _lane_option(options.get("lane", 0.0))
            origin_x, origin_y = origin_x - lane * math.sin(yaw), origin_y + lane * math.cos(yaw)
            rx, ry = rear_axle_from_origin(origin_x, origin_y, yaw, car)
            if "line" in options:  # progress counts from this line, not from where the car stands
                start_s = _start_option(options["line"]) * track.length
        self._start_s = start_s
        self._lap_length = track.length if track.closed else track.length - start_s
        self._travelled = 0.0  # signed distance along the centre line since the start [m]
        self._steps = 0
        self._trail = []
        return self._place(rx, ry, yaw, speed, steering, from_start="pose" not in options)

    def _next_lap(self) -> tuple[Any, dict]:
        """A new lap for a car that drives on over the line (a multi-car race's continuous laps): the
        car keeps its pose and motion, progress, steps and the lap's clock start again from the line."""
        self._travelled -= self._lap_length
        self._prev_travelled = self._travelled
        self._sim_time = 0.0
        self._steps = 0
        self._trail = []
        self.status = EpisodeStatus.PREPARE
        progress = min(max(100.0 * self._travelled / self._lap_length, 0.0), 100.0)
        self.params = {**self.params, "progress": progress, "steps": 0}
        info = {"params": self.params, "episode_status": self.status, "progress": progress, "steps": 0}
        return self._observe(), info

    @property
    def distance(self) -> float:
        """[m] along the centre line since this lap's line (negative behind it: a staggered start)."""
        return self._travelled

    def _resume(self, in_place: bool = False) -> tuple[Any, dict]:
        """DeepRacer's evaluation reset: at rest, at the previous step's progress, on the nearer lane
        (see :meth:`reset`); after a crash, on the centre line behind the object. Steps and progress
        go on."""
        track, car = self.track, self.car
        if in_place:  # DeepRacer's multi-car crash: the car stops where it is
            st = self._state
            return self._place(st.x, st.y, st.yaw, 0.0, 0.0)
        if self._crashed is not None and self.scene is not None:
            s = self._s
            back = self.scene.behind(self._crashed, CRASH_RESET_GAP)
            self._travelled += self._unwrap(back - s)
            ref_x, ref_y = (float(v) for v in track.point_at(back))
            yaw = float(track.heading_at(back))
            rx, ry = rear_axle_from_reference(ref_x, ref_y, yaw, car)
            return self._place(rx, ry, yaw, 0.0, 0.0)
        # DeepRacer spawns at the previous step's progress (its pose is still on this part of the track).
        travelled = self._prev_travelled
        s = self._start_s + travelled
        s = s % track.length if track.closed else min(max(s, 0.0), track.length)
        cx, cy = (float(v) for v in track.point_at(s))
        yaw = float(track.heading_at(s))
        lane = 0.25 * track.width_at(s)  # halfway between the centre line and a border
        nx, ny = -math.sin(yaw), math.cos(yaw)
        px, py = self._prev_origin
        left = (cx + lane * nx - px) ** 2 + (cy + lane * ny - py) ** 2
        right = (cx - lane * nx - px) ** 2 + (cy - lane * ny - py) ** 2
        side = lane if left < right else -lane
        rx, ry = rear_axle_from_origin(cx + side * nx, cy + side * ny, yaw, car)
        ref_x, ref_y = rx + car.reference_offset * math.cos(yaw), ry + car.reference_offset * math.sin(yaw)
        self._travelled = travelled + self._unwrap(track.project(ref_x, ref_y).s - s)
        return self._place(rx, ry, yaw, 0.0, 0.0)

    def _unwrap(self, ds: float) -> float:
        """A change of centre-line position, unwrapped across the start line of a loop [m]."""
        if self.track.closed:
            half = 0.5 * self.track.length
            return (ds + half) % self.track.length - half
        return ds

    def _place(
        self, rx: float, ry: float, yaw: float, speed: float, steering_deg: float, from_start: bool = False
    ) -> tuple[Any, dict]:
        """Put the car at a rear-axle pose; ``from_start``: progress counts from ``_start_s`` (where
        the car's origin is), so it starts at the reference point's lead."""
        track, car = self.track, self.car
        steer = math.radians(steering_deg)
        self._state = CarState.moving(rx, ry, math.atan2(math.sin(yaw), math.cos(yaw)), speed, steer, car)
        ref_x, ref_y = rx + car.reference_offset * math.cos(yaw), ry + car.reference_offset * math.sin(yaw)
        self._still = 0
        self._backwards = 0
        self._crashed = None
        proj = track.project(ref_x, ref_y)
        self._seg, self._s = proj.segment, proj.s
        if from_start:
            self._travelled = self._unwrap(proj.s - self._start_s)
        self._prev_travelled = self._travelled
        self._prev_origin = (rx + car.origin_offset * math.cos(yaw), ry + car.origin_offset * math.sin(yaw))
        self.status = EpisodeStatus.PREPARE
        self._trail.append((rx, ry))
        progress = min(max(100.0 * self._travelled / self._lap_length, 0.0), 100.0)
        self.params = self._params(ref_x, ref_y, proj, progress, speed, steering_deg)
        obs = self._observe()
        info = {
            "params": self.params,
            "episode_status": self.status,
            "progress": progress,
            "steps": self._steps,
        }
        return obs, info

    # ----- one step -----------------------------------------------------------------------------
    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        """Apply one action for 1/15 s; returns ``(obs, reward, terminated, truncated, info)``.

        :raises RewardFunctionError: when the reward function raises or returns a bad value
            (the episode is over; reset to go on).
        """
        if self._actions:
            steer_deg, speed = self._actions[int(action)]
        else:
            steer_deg, speed = self.vehicle.scale_continuous(action)
        state, car, track = self._state, self.car, self.track
        x0, y0 = state.x, state.y
        ahead = car.origin_offset
        self._prev_origin = (x0 + ahead * math.cos(state.yaw), y0 + ahead * math.sin(state.yaw))
        self._prev_travelled = self._travelled
        dt = self._noise.step_time()
        self._sim_time += dt
        step_car(state, speed, steer_deg * (math.pi / 180.0), car, dt)
        scene = self.scene
        if scene is not None:
            scene.step(dt)
            self._crashed = scene.hit(state.x, state.y, state.yaw)
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        ref_x, ref_y = state.x + car.reference_offset * c, state.y + car.reference_offset * s
        proj = track.project(ref_x, ref_y, self._seg)
        self._seg = proj.segment
        # Progress: unwrap the change of s so that crossing the start line counts.
        ds = proj.s - self._s
        if track.closed:
            half = 0.5 * track.length
            if ds > half:
                ds -= track.length
            elif ds < -half:
                ds += track.length
        self._s = proj.s
        self._travelled += ds
        progress = 100.0 * self._travelled / self._lap_length
        progress = 0.0 if progress < 0.0 else (100.0 if progress > 100.0 else progress)
        self._steps += 1
        self._backwards = self._backwards + 1 if ds < 0.0 else 0
        moved = math.hypot(state.x - x0, state.y - y0)
        self._still = self._still + 1 if moved < IMMOBILIZED_DISTANCE else 0

        params = self._params(ref_x, ref_y, proj, progress, speed, steer_deg, c, s)
        self.params = params
        self.status = status = self._step_status(params, progress)
        terminated, truncated = self._is_terminated(), self._is_truncated()
        try:
            reward = self.reward_fn(params)
        except DrxError:
            self.status = EpisodeStatus.REWARD_ERROR
            raise
        if self.render_mode is not None:
            self._trail.append((state.x, state.y))
        obs = self._observe()
        info = {
            "params": params,
            "episode_status": status,
            "progress": progress,
            "steps": self._steps,
            "start_fraction": self._start_s / track.length,  # where the episode started [0, 1) of the lap
            "step_time": dt,  # [s] this step's simulated length
        }
        if status == EpisodeStatus.LAP_COMPLETE:
            info["lap_time"] = self._sim_time
        elif self._crashed is not None:
            info["crash"] = self.crash_info()
        return obs, reward, terminated, truncated, info

    # ----- how a step ends: decided here and nowhere else ---------------------------------------------
    def _step_status(self, params: dict[str, Any], progress: float) -> EpisodeStatus:
        """The status of the step just driven, the first that holds of: ``crashed`` (the car hit an
        object), ``off_track`` (no wheel on the road: ``params["is_offtrack"]``, the rule of
        :func:`drx.sim.params.compute_params`), ``lap_complete`` (progress 100), ``immobilized``
        (``IMMOBILIZED_STEPS`` steps in a row moving less than ``IMMOBILIZED_DISTANCE``), ``reversed``
        (``REVERSED_STEPS`` steps in a row going back), ``time_up`` (``max_steps`` steps), else
        ``in_progress``. DeepRacer ends the episode on each of these (deepracer-simapp
        ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py`` ``_check_for_episode_termination``; it
        tests ``lap_complete`` before a crash, drx a crash first)."""
        if self._crashed is not None:
            return EpisodeStatus.CRASHED
        if params["is_offtrack"]:
            return EpisodeStatus.OFF_TRACK
        if progress >= 100.0:
            return EpisodeStatus.LAP_COMPLETE
        if self._still >= IMMOBILIZED_STEPS:
            return EpisodeStatus.IMMOBILIZED
        if self._backwards >= REVERSED_STEPS:
            return EpisodeStatus.REVERSED
        if self._steps >= self.max_steps:
            return EpisodeStatus.TIME_UP
        return EpisodeStatus.IN_PROGRESS

    def _is_terminated(self) -> bool:
        """Whether the last step ended the episode by what the car did (every ending but ``time_up``)."""
        return self.status.ends_episode and not self.status.truncates

    def _is_truncated(self) -> bool:
        """Whether the last step ended the episode by the step limit (``time_up``)."""
        return self.status.truncates

    def crash_info(self) -> dict[str, Any] | None:
        """The object hit on the last step, else ``None``: ``index`` (into the ``params`` object lists),
        ``kind`` (``box`` | ``bot``), ``object_distance`` [m along the centre line from the start line],
        ``object_progress`` (the same as a percentage of the track), ``x``, ``y`` [m]."""
        if self._crashed is None or self.scene is None:
            return None
        obj = self.scene.objects[self._crashed]
        return {
            "index": self._crashed,
            "kind": obj.kind,
            "object_distance": obj.s,
            "object_progress": 100.0 * obj.s / self.track.length,
            "x": obj.x,
            "y": obj.y,
        }

    def _params(
        self,
        x: float,
        y: float,
        proj: Any,
        progress: float,
        speed: float,
        steer: float,
        c: float | None = None,
        s: float | None = None,
    ) -> dict[str, Any]:
        state, car, track = self._state, self.car, self.track
        if c is None or s is None:
            c, s = math.cos(state.yaw), math.sin(state.yaw)
        # Four wheels, each looked up in the road raster.
        hw = 0.5 * car.track_width
        lx, ly = -s * hw, c * hw
        rx, ry = state.x, state.y
        fx, fy = rx + c * car.wheelbase, ry + s * car.wheelbase
        wheels = track.on_road_points(
            ((rx + lx, ry + ly), (rx - lx, ry - ly), (fx + lx, fy + ly), (fx - lx, fy - ly))
        )
        params = compute_params(
            track,
            x=x,
            y=y,
            heading=math.degrees(state.yaw),
            speed=speed,
            steering_angle=steer,
            steps=self._steps,
            progress=progress,
            wheels_on_track=wheels,
            projection=proj,
            is_crashed=self._crashed is not None,
            is_reversed=self.reverse,
            objects=self.scene.params(proj.s) if self.scene is not None else None,
        )
        if self.extra_params:
            params.update(self.extra_params)
        return params

    def _observe(self) -> Any:
        st = self._state
        boxes = self.scene.rows() if self.scene is not None else None
        if self._stereo:
            image = self.camera.render_stereo(st.x, st.y, st.yaw, boxes=boxes)
        else:
            image = self.camera.render(st.x, st.y, st.yaw, boxes=boxes)[:, :, None]
        self._last_obs = image
        if self.lidar is not None:
            bodies = self.scene.bodies() if self.scene is not None else ()
            ranges = self.lidar.scan(st.x, st.y, st.yaw, bodies)
            if self.lidar_type == "sector":
                ranges = self.lidar.sectors(ranges)
            return {"camera": image, "lidar": ranges}
        return image

    # ----- people ---------------------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        """``rgb_array``: the track from above with the car, its trail and the camera frame inset."""
        if self.render_mode != "rgb_array":
            return None
        if self._top_down is None:
            from drx.sim.pictures import TopDownRenderer

            self._top_down = TopDownRenderer(self.track)
        st, p = self._state, self.params
        text = [
            f"step {self._steps}  {self.status}",
            f"progress {p.get('progress', 0.0):5.1f}%  speed {st.speed:4.2f} m/s",
        ]
        frame = self._last_obs[:, :, 0] if self._last_obs is not None else None
        if self.scene is not None:
            text.append(self.race.summary())
        rows = self.scene.rows() if self.scene is not None else None
        bots = self.scene is not None and self.scene.moving
        return self._top_down.render(
            st.x, st.y, st.yaw, trail=self._trail, camera_frame=frame, text_lines=text,
            boxes=None if bots else rows, cars=rows if bots else None,
        )  # fmt: skip

    @property
    def start_distance(self) -> float:
        """[m] along the centre line where this episode's car started (its origin's place)."""
        return self._start_s

    @property
    def car_state(self) -> CarState:
        """The car's dynamic state (rear axle, yaw, actual speed and steering)."""
        return self._state


def _pose_option(pose: Any) -> tuple[float, float, float]:
    """``options["pose"]`` as the reference point ``(x, y)`` [m] and yaw [rad]."""
    try:
        x, y, heading = (float(pose[k]) for k in ("x", "y", "heading"))
    except (KeyError, TypeError, ValueError):
        raise DrxError(
            f"reset option pose {pose!r} is invalid; give {{'x': m, 'y': m, 'heading': deg}} with numbers."
        ) from None
    if not all(math.isfinite(v) for v in (x, y, heading)):
        raise DrxError(f"reset option pose {pose!r} has a value that is not finite; give finite numbers.")
    return x, y, math.radians(heading)


def _start_option(start: Any) -> float:
    """``options["start"]``: a fraction of the lap, taken modulo 1."""
    try:
        frac = float(start)
    except (TypeError, ValueError):
        frac = math.nan
    if not math.isfinite(frac):
        raise DrxError(f"reset option start {start!r} is invalid; give a fraction of the lap, e.g. 0.25.")
    return frac % 1.0


def _lane_option(lane: Any) -> float:
    """``options["lane"]``: metres left (+) or right (-) of the centre line, within 1 m."""
    try:
        value = float(lane)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and abs(value) <= 1.0):
        raise DrxError(f"reset option lane {lane!r} is invalid; give metres from the centre line, -1 to 1.")
    return value


def _episode_option(episode: Any) -> int:
    """``options["episode"]``: the round robin's position, an int >= 0."""
    if isinstance(episode, bool) or not isinstance(episode, int | np.integer) or episode < 0:
        raise DrxError(f"reset option episode {episode!r} is invalid; give the episode number, an int >= 0.")
    return int(episode)


def _motion_options(options: dict[str, Any]) -> tuple[float, float]:
    """``options["speed"]`` [m/s] (0-4) and ``options["steering"]`` [deg] (-30..30), default 0."""
    try:
        speed = float(options.get("speed", 0.0))
        steering = float(options.get("steering", 0.0))
    except (TypeError, ValueError):
        raise DrxError("reset options speed and steering must be numbers (m/s and degrees).") from None
    if not (math.isfinite(speed) and 0.0 <= speed <= 4.0):
        raise DrxError(f"reset option speed {speed:g} is out of range; use 0 to 4 m/s.")
    if not (math.isfinite(steering) and -30.0 <= steering <= 30.0):
        raise DrxError(f"reset option steering {steering:g} is out of range; use -30 to 30 degrees.")
    return speed, steering


def _race_config(race: RaceConfig | dict[str, Any] | str | None) -> RaceConfig:
    """The env's ``race`` argument as a :class:`RaceConfig`."""
    if race is None:
        return RaceConfig()
    if isinstance(race, RaceConfig):
        return race
    if isinstance(race, str):
        return RaceConfig(race_type=race)
    if isinstance(race, dict):
        return RaceConfig.from_dict(race)
    raise DrxError(f"race must be a RaceConfig, a dict or a race type name, not {type(race).__name__}.")
