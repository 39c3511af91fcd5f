"""Training episodes over a model's tracks and directions: which track, which way, where each starts.

:class:`ScheduledEnv` is the training environment of a model (``drx.queue.train_job.build_spec``):
it holds one simulator per track and direction driven (built when first needed) and starts each
episode where :meth:`drx.settings.episodes.EpisodeSettings.start` puts it: episode ``g`` on track
``g mod n``, from that track's round-robin start, reversed when the track or DeepRacer's
alternation says so (deepracer-simapp ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``,
``finish_episode``: the start advances and the direction flips after each training episode;
deepracer-for-cloud's ``DR_TRAIN_MULTI_CONFIG``: one world per rollout worker). Its ``info`` says
which route each step is on (``info["track"]``), so the episode records keep the tracks apart.

Its reset options are the simulator's (``docs/CONTRACTS.md``, "The env's reset options"):
``{"episode": g}`` is the model's running episode number (the rollout workers pass it for every
episode); a reset without it is the next episode (SB3's own resets, SAC); ``start``, ``pose`` and
``resume`` go to the simulator of the episode in progress.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from drx.errors import DrxError
from drx.settings.episodes import EpisodeSettings

# (track index, reversed) -> a training env on that track, driven that way
TrackEnvFactory = Callable[[int, bool], gym.Env]
PLACING = ("start", "pose", "resume")  # options that place the car on the current track themselves


class ScheduledEnv(gym.Env):
    """The training episodes of a model over its tracks and directions.

    :param settings: the model's tracks and starts (at least one track).
    :param make: builds the env of track ``i`` driven reversed or not (``drx/DeepRacer-v0`` in
        training mode, possibly wrapped); every one must have the same spaces.
    """

    def __init__(self, settings: EpisodeSettings, make: TrackEnvFactory) -> None:
        if not settings.tracks:
            raise DrxError("A training schedule needs at least one track.")
        self.settings = settings
        self._make = make
        self._envs: dict[tuple[int, bool], gym.Env] = {}
        self._seeded: set[tuple[int, bool]] = set()
        self._seed_root: int | None = None
        self._next = 0  # the episode a reset without an "episode" option starts
        first = settings.tracks[0]
        env = self._select((0, first.reverse))
        self.observation_space = env.observation_space
        self.action_space = env.action_space
        self.metadata = dict(env.metadata)
        self.render_mode = env.render_mode
        self.episode = -1  # the episode in progress (-1 before the first reset)

    def _env(self, key: tuple[int, bool]) -> gym.Env:
        env = self._envs.get(key)
        if env is None:
            env = self._envs[key] = self._make(*key)
            if env.observation_space != getattr(self, "observation_space", env.observation_space):
                raise DrxError(
                    f"Track {self.settings.tracks[key[0]].name!r} gives another observation space than the "
                    "model's first track; the tracks cannot train one model."
                )
        return env

    def _select(self, key: tuple[int, bool]) -> gym.Env:
        """Make ``key``'s env the one in progress. Its env and route id are kept at hand: ``step``
        runs every simulator step and does no look-up."""
        self._key = key
        self._current = self._env(key)
        self._track_name = self.settings.tracks[key[0]].name
        return self._current

    @property
    def current(self) -> gym.Env:
        """The env of the episode in progress (the first track's before any reset)."""
        return self._current

    @property
    def track_name(self) -> str:
        """The route id of the episode in progress."""
        return self._track_name

    # What a reader of the simulator's public attributes sees (drx.watch.live.LivePoseWriter wraps
    # this env once: one pose file for the job's training, whichever track is being driven).
    @property
    def car_state(self) -> Any:
        """The car's state in the episode in progress (:attr:`drx.sim.env.DeepRacerEnv.car_state`)."""
        return self.current.unwrapped.car_state  # type: ignore[attr-defined]

    @property
    def track(self) -> Any:
        """The track of the episode in progress, as driven (a reversed route is named ``*_reversed``)."""
        return self.current.unwrapped.track  # type: ignore[attr-defined]

    @property
    def scene(self) -> Any:
        """The boxes and bots of the episode in progress (``None`` in a time trial)."""
        return getattr(self.current.unwrapped, "scene", None)

    @property
    def vehicle(self) -> Any:
        """The car (the same on every track)."""
        return self.current.unwrapped.vehicle  # type: ignore[attr-defined]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Start a training episode (see the module docstring for the options).

        A ``seed`` seeds the env of this episode and, derived from it, each other track's and
        direction's env when it first drives; without an ``episode`` option it also restarts the
        count at episode 0, as the simulator's own round robin does.
        """
        options = dict(options or {})
        if seed is not None:
            super().reset(seed=seed)
            self._seed_root = int(seed)
            self._seeded.clear()
            self._next = 0
        if any(options.get(k) for k in PLACING):  # placed by the caller: the current track
            obs, info = self.current.reset(seed=seed, options=options)
            return obs, self._label(info)
        episode = options.pop("episode", None)
        episode = self._next if episode is None else _episode_number(episode)
        plan = self.settings.start(episode)
        env = self._select((plan.track, plan.reverse))
        env_seed = seed
        if env_seed is None and self._seed_root is not None and self._key not in self._seeded:
            slot = 2 * plan.track + int(plan.reverse)  # each track and direction its own stream
            env_seed = int(np.random.SeedSequence([self._seed_root, slot]).generate_state(1)[0])
        if env_seed is not None:
            self._seeded.add(self._key)
        obs, info = env.reset(seed=env_seed, options={**options, "start": plan.fraction})
        self.episode = episode
        self._next = episode + 1
        return obs, self._label(info)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        """Step the env of the episode in progress."""
        obs, reward, terminated, truncated, info = self._current.step(action)
        info["track"] = self._track_name
        return obs, float(reward), terminated, truncated, info

    def _label(self, info: dict[str, Any]) -> dict[str, Any]:
        info["track"] = self._track_name
        return info

    def render(self) -> Any:
        """The picture of the episode in progress."""
        return self.current.render()

    def close(self) -> None:
        """Close every env built."""
        for env in self._envs.values():
            env.close()
        self._envs.clear()


def _episode_number(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise DrxError(f"reset option episode {value!r} is invalid; give the episode number, an int >= 0.")
    return int(value)
