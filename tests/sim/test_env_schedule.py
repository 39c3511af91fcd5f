"""A model's training env over its tracks and directions (``drx.sim.schedule.ScheduledEnv``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from drx.errors import DrxError
from drx.settings.episodes import EpisodeSettings, TrainingTrack
from drx.sim.env import DeepRacerEnv
from drx.sim.registration import ENV_ID, register_envs
from drx.sim.schedule import ScheduledEnv


def _scheduled(settings: EpisodeSettings, built: list[tuple[int, bool]] | None = None) -> ScheduledEnv:
    register_envs()

    def make(index: int, reverse: bool) -> gym.Env:
        if built is not None:
            built.append((index, reverse))
        name = settings.tracks[index].name
        return gym.make(ENV_ID, track=name, reverse=reverse, mode="training", disable_env_checker=True)

    return ScheduledEnv(settings, make)


def _sim(env: ScheduledEnv) -> DeepRacerEnv:
    """The simulator of the episode in progress."""
    sim = env.current.unwrapped
    assert isinstance(sim, DeepRacerEnv)
    return sim


def _drive(env: ScheduledEnv, steps: int = 3) -> dict:
    info: dict = {}
    for _ in range(steps):
        _obs, _reward, _terminated, _truncated, info = env.step(env.action_space.sample())
    return info


def test_episodes_take_the_tracks_in_turn_from_their_own_round_robin() -> None:
    built: list[tuple[int, bool]] = []
    settings = EpisodeSettings((TrainingTrack("oval", "ccw"), TrainingTrack("kidney", "ccw")),
                               round_robin_advance=0.1, start_position_offset=0.2)  # fmt: skip
    env = _scheduled(settings, built)
    assert built == [(0, False)]  # the first track's env gives the spaces; the others wait for their turn
    seen = []
    for g in range(4):
        _obs, info = env.reset(options={"episode": g})
        assert info["track"] == ("oval", "kidney")[g % 2]
        assert _sim(env).track.name == ("oval", "kidney")[g % 2]
        info = _drive(env)
        assert info["start_fraction"] == pytest.approx(settings.start(g).fraction, abs=1e-6)
        seen.append(info["track"])  # every step says its route too
    assert seen == ["oval", "kidney", "oval", "kidney"]
    assert built == [(0, False), (1, False)]
    assert [round(settings.start(g).fraction, 6) for g in range(4)] == [0.2, 0.2, 0.3, 0.3]
    env.close()


def test_alternate_direction_drives_every_other_episode_reversed() -> None:
    settings = EpisodeSettings((TrainingTrack("oval", "ccw"),), alternate_direction=True)
    env = _scheduled(settings)
    reversed_ = []
    for _ in range(4):  # no episode option: the next one (SB3's own resets, as SAC's collection does)
        _obs, info = env.reset()
        reversed_.append(_sim(env).reverse)
        assert _drive(env)["params"]["is_reversed"] is _sim(env).reverse
    assert reversed_ == [False, True, False, True]
    env.reset(seed=3)  # a seed restarts the count, as the simulator's own round robin does
    assert env.episode == 0 and not _sim(env).reverse
    env.close()


def test_a_track_driven_against_its_route() -> None:
    settings = EpisodeSettings((TrainingTrack("oval", "cw", reverse=True),))
    env = _scheduled(settings)
    env.reset(options={"episode": 0})
    assert _sim(env).reverse and _sim(env).track.direction == "cw"
    env.close()


def test_placing_options_go_to_the_current_track_and_bad_episodes_are_refused() -> None:
    env = _scheduled(EpisodeSettings((TrainingTrack("oval", "ccw"), TrainingTrack("kidney", "ccw"))))
    env.reset(options={"episode": 1})
    env.reset(options={"start": 0.5})
    info = _drive(env, 1)
    assert info["track"] == "kidney" and info["start_fraction"] == pytest.approx(0.5, abs=1e-6)
    for bad in (-1, 1.5, True, "2"):
        with pytest.raises(DrxError, match="reset option episode"):
            env.reset(options={"episode": bad})
    env.close()


def test_seeded_schedules_repeat_on_every_track() -> None:
    settings = EpisodeSettings((TrainingTrack("oval", "ccw"), TrainingTrack("kidney", "ccw")))

    def run() -> list[float]:
        env = _scheduled(settings)
        env.reset(seed=7)
        times = []
        for _ in range(3):
            times.append(float(_drive(env, 5)["step_time"]))
            env.reset()
        env.close()
        return times

    assert np.allclose(run(), run())
