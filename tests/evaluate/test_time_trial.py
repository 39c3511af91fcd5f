"""The time-trial rules engine against the real env, with scripted drivers."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from drx.errors import SettingError
from drx.evaluate.scripted import ConstantDriver, centre_line_driver
from drx.evaluate.time_trial import RaceRules, StepView, max_steps_for, run_time_trial
from drx.sim.env import DeepRacerEnv
from drx.sim.track import Track, load_track
from drx.vehicle import Vehicle

CAR = Vehicle(name="scripted", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


def make_env(rules: RaceRules, track: str = "oval", deterministic: bool = True) -> DeepRacerEnv:
    return DeepRacerEnv(
        track=load_track(track), vehicle=CAR, mode="evaluation", max_steps=max_steps_for(rules),
        deterministic=deterministic,
    )  # fmt: skip


def test_centre_line_driver_completes_three_laps_with_plausible_times() -> None:
    rules = RaceRules(laps=3)
    env = make_env(rules)
    result = run_time_trial(env, centre_line_driver(env, 1.5), rules)
    length = env.track.length
    assert result.ended == "laps_done"
    assert [lap.status for lap in result.laps] == ["lap_complete"] * 3
    assert result.off_track_count == 0 and result.resets == 0
    times = [lap.time for lap in result.laps]
    # every lap starts from rest at the line (as DeepRacer's): the same lap three times without noise,
    # a little over the centre line at the car's steady speed
    assert times[0] == times[1] == times[2]
    steady = env.car.steady_speed(1.5)
    assert length / steady < times[0] < length / steady * 1.08
    assert result.fastest_lap == min(times)
    assert result.average_lap == pytest.approx(sum(times) / 3)
    assert result.total_time == pytest.approx(result.steps / 15.0)
    assert sum(lap.steps for lap in result.laps) == result.steps


def test_driving_off_counts_penalties_and_resets_exactly() -> None:
    """Straight on at every bend: each off-track costs the penalty and a reset, until resets run out."""
    rules = RaceRules(laps=3, off_track_penalty=5.0, max_resets=3)
    env = make_env(rules)
    events: list[str] = []
    result = run_time_trial(
        env, ConstantDriver(env, 0.0, 1.0), rules, observer=lambda v: events.append(v.event)
    )
    lap = result.laps[0]
    assert result.ended == "max_resets"
    assert len(result.laps) == 1
    assert lap.status == "off_track" and lap.time is None
    assert lap.off_track_count == 4 and events.count("off_track") == 4
    assert lap.resets == 3 and events.count("reset") == 3
    assert lap.penalty_seconds == pytest.approx(4 * 5.0)
    assert 0.0 < lap.progress < 100.0
    assert events.count("pause") == 0  # the pause is the reset's status, not an event
    assert result.total_time == pytest.approx(result.steps / 15.0 + 20.0)


class OffOnceDriver:
    """Steers gently left (off the road) until the first reset, then follows the centre line."""

    def __init__(self, env: DeepRacerEnv) -> None:
        self.env = env
        self.follow = centre_line_driver(env, 1.5)
        self.left = ConstantDriver(env, 12.0, 1.5)
        self.resets = 0
        self.reset_progress: list[float] = []
        self.last_progress: list[float] = [0.0]

    def observe(self, view: StepView) -> None:
        self.resets += view.event == "reset"
        if view.event == "reset":
            self.reset_progress.append(view.progress)
            assert view.status == "pause"  # the car stands for the penalty
        elif not self.resets:
            self.last_progress[:] = [view.progress]

    def __call__(self, obs: Any) -> Any:
        return self.follow(obs) if self.resets else self.left(obs)


def test_an_off_track_adds_its_penalty_to_the_lap_and_the_lap_goes_on() -> None:
    rules = RaceRules(laps=2, off_track_penalty=2.0)
    env = make_env(rules)
    driver = OffOnceDriver(env)
    result = run_time_trial(env, driver, rules, observer=driver.observe)
    first, second = result.laps
    assert result.ended == "laps_done"
    assert first.status == second.status == "lap_complete"
    assert (first.off_track_count, first.resets, first.penalty_seconds) == (1, 1, 2.0)
    assert first.time == pytest.approx(first.steps / 15.0 + 2.0)
    assert driver.reset_progress[0] == pytest.approx(driver.last_progress[0], abs=2.0)  # where it left
    assert (second.off_track_count, second.penalty_seconds) == (0, 0.0)
    assert second.time == pytest.approx(second.steps / 15.0)


def test_time_cap_ends_the_trial_mid_lap() -> None:
    rules = RaceRules(laps=3, time_cap_minutes=0.1)  # 6 s
    env = make_env(rules)
    result = run_time_trial(env, centre_line_driver(env, 1.0), rules)
    assert result.ended == "time_cap"
    assert result.laps[-1].status == "time_up" and result.laps[-1].time is None
    assert result.total_time == pytest.approx(6.0, abs=1 / 15 + 1e-9)
    assert 0 < result.laps[-1].progress < 100


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"laps": 0}, "^laps 0 is out of range; use 1 to"),
        ({"laps": 101}, "^laps 101 is out of range; use 1 to"),
        ({"off_track_penalty": -1.0}, "^off_track_penalty -1 is invalid; use 0 or more seconds"),
        ({"max_resets": -2}, "^max_resets -2 is invalid; use 0 or more"),
        ({"time_cap_minutes": 0.0}, "^time_cap_minutes 0 is invalid; use more than 0, up to 1440"),
    ],
)
def test_bad_rules_are_refused(kwargs: dict[str, Any], words: str) -> None:
    with pytest.raises(SettingError, match=words) as info:  # the field; the CLI says its flag
        RaceRules(**kwargs)
    assert info.value.field == next(iter(kwargs))


def test_rules_round_trip() -> None:
    rules = RaceRules(laps=5, off_track_penalty=5.0, max_resets=10, time_cap_minutes=3.0)
    d = rules.to_dict()
    assert d["race_type"] == "time_trial"
    assert RaceRules.from_dict(d) == rules


def test_discrete_car_follows_the_centre_line_too() -> None:
    from drx.vehicle import default_vehicle

    rules = RaceRules(laps=1)
    env = DeepRacerEnv(track=load_track("oval"), vehicle=default_vehicle(), mode="evaluation")
    result = run_time_trial(env, centre_line_driver(env, 1.0), rules)
    assert result.laps_completed == 1
    assert result.laps[0].time == pytest.approx(env.track.length / 1.0, rel=0.15)
    assert np.isfinite(result.total_time)


def test_open_track_laps_restart_from_the_start_line() -> None:
    x = np.linspace(0.0, 6.0, 31)
    center = np.column_stack([x, np.zeros_like(x)])
    track = Track("strip", center, center + (0.0, 0.4), center - (0.0, 0.4), closed=False)
    rules = RaceRules(laps=2)
    env = DeepRacerEnv(
        track=track, vehicle=CAR, mode="evaluation", max_steps=max_steps_for(rules), deterministic=True
    )
    result = run_time_trial(env, centre_line_driver(env, 2.0), rules)
    assert result.ended == "laps_done" and result.laps_completed == 2
    first, second = (lap.time for lap in result.laps)
    assert first == pytest.approx(second)  # both from rest, the same run


def test_laps_differ_as_deepracers_do_and_a_seed_repeats_them() -> None:
    """DeepRacer's steps vary in length, so its three laps differ; drx's do too, and a seed repeats them."""
    rules = RaceRules(laps=3)

    def laps(seed: int) -> list[float]:
        env = make_env(rules, deterministic=False)
        result = run_time_trial(env, centre_line_driver(env, 1.5), rules, seed=seed)
        assert result.laps_completed == 3
        return [lap.time for lap in result.laps]

    a, b, c = laps(11), laps(11), laps(12)
    assert len(set(a)) == 3  # not all equal
    assert a == b  # the same seed, the same three laps
    assert a != c
    assert max(a) - min(a) < 0.1 * min(a)  # the same driver: close laps


def test_scripted_drivers_steer_between_a_discrete_cars_actions_on_average() -> None:
    """Error diffusion: -7 deg wanted of actions at -15, 0 and +15 deg is -7 deg on average, not 0."""
    from drx.evaluate.scripted import ActionChooser
    from drx.vehicle import Action

    actions = tuple(Action(float(s), 1.0) for s in (-15, 0, 15))
    car = Vehicle(name="three", continuous=False, actions=actions)
    choose = ActionChooser(car)
    given = [actions[choose(-7.0, 1.0)].steering_angle for _ in range(30)]
    assert set(given) == {-15.0, 0.0}
    assert np.mean(given) == pytest.approx(-7.0, abs=0.6)
    assert all(actions[choose(40.0, 1.0)].steering_angle == 15.0 for _ in range(5))  # at the lock ...
    assert actions[choose(0.0, 1.0)].steering_angle == 0.0  # ... nothing more is owed
