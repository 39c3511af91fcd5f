"""Training against models: a head-to-model model's opponents drive the other cars of its episodes.

``drx model create NAME --race-type head-to-model --opponent M`` (1-3 opponents, checked by
:mod:`drx.services.opponents`) trains NAME's episodes with each opponent's best checkpoint driving a
car of its own, frozen, on the CPU, deterministically (:class:`OpponentDrivers`). The machinery is
``drx race``'s (:mod:`drx.evaluate.head_to_head`): each car is a ``drx/DeepRacer-v0`` env with its own
network, sensors and car constants; the other cars are objects in its scene
(:class:`drx.sim.race_cars.OtherCars`): its camera and lidar see them, its crash test hits them and
its reward ``params`` list them as deepracer-simapp gives an agent the other agents
(``objects_location``, ``objects_speed``, ``objects_heading``, ``objects_left_of_center``,
``objects_distance``, ``closest_objects``: ``set_reward_and_metrics`` in
``bundle/markov/agent_ctrl/utils.py`` fills them from every object pose but the agent's own, and
other racecars are such objects). Every car steps by one shared step length (:class:`TrainingClock`).

A training episode (:class:`HeadToModelEnv`):

* **Grid.** The model's car starts where its schedule puts it (its round-robin start); the cars form
  ``drx race``'s grid around it (:func:`drx.evaluate.head_to_head.start_places`: ``START_POS_OFFSET``
  0.75 m apart, lanes alternating outer / inner, simapp's ``get_start_positions`` and
  ``_start_lane_``), the model's car in a random place of it each episode, so it learns both to
  pass and to hold a lead.
* **Who a crash costs** (simapp ``RolloutCtrl.judge_action`` / ``_check_for_episode_termination``):
  the car behind (less progress along the track). The model's car hitting a car ahead of it has
  crashed (``is_crashed``, the episode ends, as any training crash); a car hitting it from behind
  costs it nothing (its ``params`` say ``is_crashed`` false, as simapp resets the flag for the car
  ahead) and that opponent stands ``COLLISION_PENALTY`` where it is.
* **Opponents go on** until the model's episode ends: a lap completed drives on (``next_lap``); an
  off-track, reversed or immobilized car is put back and stands its penalty (``RolloutCtrl
  ._penalties``, :class:`~drx.evaluate.head_to_head.HeadToHeadRules`' defaults); a standing car is
  seen, never hit.
* **Order within a step.** The opponents act on what they saw, then step; the model's car steps
  among them where they now are (its crash test, ``params`` and camera are of this step); the
  opponents see it at its new place on their next step (one step later, as every car of a
  ``drx race`` sees the others).

Opponent inference is one forward per opponent per step, of policies loaded once when the env is
built (``torch.no_grad``); ``benchmarks/head_to_model.py`` measures what it costs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from drx.errors import DrxError
from drx.evaluate.head_to_head import HeadToHeadRules, SharedClock, start_places
from drx.settings.race import RaceConfig
from drx.sim.dynamics import CarParams
from drx.sim.episode_status import EpisodeStatus
from drx.vehicle import Vehicle

PENALISED = (EpisodeStatus.OFF_TRACK, EpisodeStatus.REVERSED, EpisodeStatus.IMMOBILIZED)
OPPONENT_MAX_STEPS = 10**9  # an opponent's env never ends on steps: its laps go on (next_lap)


class TrainingClock(SharedClock):
    """The shared step length of a head-to-model episode; a seeded reset of the model's env reseeds it."""

    def reseed(self, rng: np.random.Generator) -> None:
        """Draw from ``rng`` from now on (the model's env's ``reset(seed=...)``)."""
        self._noise.reseed(rng)


class _Follower:
    """An opponent env's view of the clock: this step's length; its resets reseed nothing."""

    def __init__(self, clock: SharedClock) -> None:
        self._clock = clock

    def step_time(self) -> float:
        return self._clock.step_time()

    def reseed(self, rng: np.random.Generator) -> None:
        """Nothing: the model's env seeds the clock."""


@dataclass(frozen=True)
class Opponent:
    """A model that drives another car.

    :param name: its name.
    :param vehicle: its car (action space, sensors, network).
    :param checkpoint: the checkpoint that drives (its best).
    :param car: its physical constants.
    """

    name: str
    vehicle: Vehicle
    checkpoint: Path
    car: CarParams = CarParams()


class OpponentDrivers:
    """The opponents' policies, loaded once (on the CPU, evaluation mode) and frozen.

    :meth:`act` gives every opponent's deterministic action for its observation: one forward per
    opponent (their networks and sensors may differ), no gradients, no reload.
    """

    def __init__(self, opponents: Sequence[Opponent]) -> None:
        from drx.evaluate.policy import ModelPolicy

        self.policies = [ModelPolicy(o.checkpoint, o.vehicle) for o in opponents]
        for policy in self.policies:
            net = getattr(policy, "policy", None)
            if net is not None:
                net.requires_grad_(False)

    def act(self, observations: Sequence[Any]) -> list[Any]:
        """Each opponent's most probable action for its observation."""
        import torch

        with torch.no_grad():
            return [policy(obs) for policy, obs in zip(self.policies, observations, strict=True)]


class HeadToModelEnv(gym.Wrapper):
    """A model's training env with its opponents driving the other cars (see the module docstring).

    :param env: the model's ``drx/DeepRacer-v0`` training env (possibly wrapped), made with ``clock``.
    :param opponents: the 1-3 opponents, in race order after the model's car (``racecar_1``, ...).
    :param clock: the clock ``env`` was made with.
    :param drivers: their policies (default: loaded from their checkpoints).
    :param rules: penalties and the grid's stagger (``drx race``'s defaults).
    """

    def __init__(
        self,
        env: gym.Env,
        opponents: Sequence[Opponent],
        clock: TrainingClock,
        drivers: OpponentDrivers | None = None,
        rules: HeadToHeadRules | None = None,
    ) -> None:
        from drx.sim.env import DeepRacerEnv
        from drx.sim.objects import LaneFrame
        from drx.sim.race_cars import OtherCars

        super().__init__(env)
        base = env.unwrapped
        assert isinstance(base, DeepRacerEnv)
        self.base = base
        self.clock = clock
        self.rules = rules or HeadToHeadRules()
        self.opponents = list(opponents)
        self.drivers = drivers or OpponentDrivers(self.opponents)
        track = base.track
        self.track = track
        self.frame = LaneFrame(track)
        cars = [base.car] + [o.car for o in self.opponents]
        base.scene = OtherCars(track, base.car, cars[1:])
        follower = _Follower(clock)
        self.opponent_envs: list[DeepRacerEnv] = []
        for k, opp in enumerate(self.opponents):
            oe = DeepRacerEnv(track=track, vehicle=opp.vehicle, mode="evaluation", car=opp.car,
                              max_steps=OPPONENT_MAX_STEPS, clock=follower)  # fmt: skip
            oe.scene = OtherCars(track, opp.car, [c for j, c in enumerate(cars) if j != k + 1])
            self.opponent_envs.append(oe)
        n = len(self.opponents)
        self._obs: list[Any] = [None] * n
        self._pause = [0.0] * n
        self._s = [0.0] * (n + 1)  # each car's centre-line place [m]: the model's car first
        self._rng = np.random.default_rng()
        self.opponent_steps = 0  # steps the opponents drove (not standing), for tests and benchmarks
        self.opponent_collisions = 0  # opponents penalised for hitting another car from behind

    # ----- episodes ---------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Start an episode: the model's car where its schedule says, the opponents on the grid around it.

        Options that continue an episode (``resume``, ``next_lap``) go to the model's car alone.
        """
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        options = dict(options or {})
        if options.get("resume") or options.get("next_lap"):
            return self.env.reset(seed=seed, options=options)
        self.env.reset(seed=seed, options=options)
        base, track, frame = self.base, self.track, self.frame
        start = base.start_distance
        places = start_places(len(self.opponents) + 1, self.rules.start_position_offset, track.length)
        mine = int(self._rng.integers(len(places)))  # the model's car's place on the grid
        head = start + mine * self.rules.start_position_offset  # the front of the grid
        slots = [(frame.wrap(head + frac * track.length), lane) for frac, lane in places]
        others = [slot for j, slot in enumerate(slots) if j != mine]
        for k, (oe, (s, lane)) in enumerate(zip(self.opponent_envs, others, strict=True)):
            offset = frame.lane_offset(s, frame.lane_of(lane, s))
            self._obs[k], _ = oe.reset(options={"start": s / track.length, "lane": offset})
            self._pause[k] = 0.0
        self._place_opponents()
        s, lane = slots[mine]
        lane_offset = frame.lane_offset(s, frame.lane_of(lane, s))
        obs, info = self.env.reset(options={"start": start / track.length, "lane": lane_offset})
        self._place_agent()
        for k, oe in enumerate(self.opponent_envs):  # their first view has the model's car in it
            self._obs[k], _ = oe.reset(options={"resume": True, "in_place": True})
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        """One step of every car (see the module docstring for the order)."""
        dt = self.clock.tick()
        driving = [k for k in range(len(self.opponents)) if self._pause[k] <= 0.0]
        actions = self.drivers.act([self._obs[k] for k in driving]) if driving else []
        for k, act in zip(driving, actions, strict=True):
            self._drive(k, act)
        for k in range(len(self.opponents)):
            if k not in driving:
                self._stand(k, dt)
        self._place_opponents()
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._place_agent()
        return obs, float(reward), terminated, truncated, info

    # ----- the opponents -----------------------------------------------------------------------------
    def _drive(self, k: int, action: Any) -> None:
        """Opponent ``k`` drives one step; a lap drives on, an ending is put back and stands its penalty."""
        oe = self.opponent_envs[k]
        self._obs[k], _r, _t, _tr, info = oe.step(action)
        self.opponent_steps += 1
        status = info.get("episode_status")
        if status == EpisodeStatus.LAP_COMPLETE:
            self._obs[k], _ = oe.reset(options={"next_lap": True})
        elif status == EpisodeStatus.CRASHED:  # it hit a car ahead of it: it stands where it is
            self.opponent_collisions += 1
            self._penalise(k, self.rules.collision_penalty, in_place=True)
        elif status in PENALISED:
            self._penalise(k, self.rules.penalty(str(status)))
        elif status == EpisodeStatus.TIME_UP:
            self._obs[k], _ = oe.reset(options={"resume": True})

    def _penalise(self, k: int, seconds: float, in_place: bool = False) -> None:
        options: dict[str, Any] = {"resume": True, "in_place": in_place, "pause": seconds}
        self._obs[k], _ = self.opponent_envs[k].reset(options=options)
        self._pause[k] = seconds

    def _stand(self, k: int, dt: float) -> None:
        """Opponent ``k`` stands out its penalty; when it ends, it looks again before it drives."""
        self._pause[k] -= dt
        if self._pause[k] <= 0.0:
            self._obs[k], _ = self.opponent_envs[k].reset(options={"resume": True, "in_place": True})

    # ----- who sees whom ---------------------------------------------------------------------------
    def _where(self, env: Any) -> float:
        st = env.car_state
        return self.frame.wrap(self.track.project(st.x, st.y).s)

    def _ahead(self, s_other: float, s_me: float) -> bool:
        """Whether a car at ``s_other`` is ahead of one at ``s_me`` (the nearer way round the loop)."""
        half = 0.5 * self.track.length
        return (s_other - s_me + half) % self.track.length - half > 0.0

    def _place_opponents(self) -> None:
        """Move the opponents in the model's car's scene: one it is ahead of cannot be hit by it."""
        scene = self.base.scene
        s_me = self._s[0] = self._where(self.base)
        for k, oe in enumerate(self.opponent_envs):
            st = oe.car_state
            s = self._s[k + 1] = self._where(oe)
            ghost = self._pause[k] > 0.0 or not self._ahead(s, s_me)
            scene.move(k, st.x, st.y, st.yaw, st.speed, s, ghost=ghost)
        scene.refresh()

    def _place_agent(self) -> None:
        """Move every car in each opponent's scene (the model's car at its new place)."""
        envs = [self.base, *self.opponent_envs]
        self._s[0] = self._where(self.base)
        paused = [0.0, *self._pause]
        for j in range(1, len(envs)):
            scene, s_me = envs[j].scene, self._s[j]
            for i, other in enumerate(envs):
                if i == j:
                    continue
                st = other.car_state
                ghost = paused[i] > 0.0 or not self._ahead(self._s[i], s_me)
                scene.move(i if i < j else i - 1, st.x, st.y, st.yaw, st.speed, self._s[i], ghost=ghost)
            scene.refresh()

    def close(self) -> None:
        """Close the model's env and every opponent's."""
        for oe in self.opponent_envs:
            oe.close()
        super().close()


def load_opponents(race: RaceConfig) -> list[Opponent]:
    """A head-to-model race's opponents with their best checkpoints (``[]`` for other race types).

    :raises DrxError: an opponent removed since, or without a checkpoint now (one sentence).
    """
    from drx.evaluate.race_service import car_params_for
    from drx.registry import Model, session_scope
    from drx.services.checkpoints import choose_checkpoint

    if race.race_type != "head-to-model":
        return []
    found = []
    for ident in race.opponents:
        with session_scope() as session:
            model = session.get(Model, ident)
        if model is None:
            raise DrxError(
                f"Opponent model #{ident} no longer exists; clone this model with other opponents."
            )
        chosen = choose_checkpoint(model, "best")
        found.append(Opponent(model.name, model.vehicle(), chosen.path, car_params_for(model)))
    return found


def with_opponents(make: Callable[[Any], gym.Env], opponents: Sequence[Opponent], seed: int = 0) -> gym.Env:
    """The env ``make(clock)`` builds, with ``opponents`` driving the other cars (none: as it is).

    :param make: builds the model's training env with a clock (``None``: its own step noise).
    """
    if not opponents:
        return make(None)
    from drx.sim.noise import StepNoise

    clock = TrainingClock(StepNoise(CarParams(), np.random.default_rng(seed)))
    return HeadToModelEnv(make(clock), opponents, clock)
