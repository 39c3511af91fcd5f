"""Evaluation races with boxes: the collision penalty, crash counts, resets and the trace's counter."""

from __future__ import annotations

from typing import Any

import pytest

from drx.errors import SettingError
from drx.evaluate.scripted import LaneChangingDriver, centre_line_driver
from drx.evaluate.time_trial import RaceRules, StepView, max_steps_for, run_time_trial
from drx.settings.race import RaceConfig
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track
from drx.vehicle import Vehicle

CAR = Vehicle(name="scripted", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))
ONE_BOX = RaceConfig("object-avoidance", object_positions=((0.3, "inside"),))


def make_env(rules: RaceRules) -> DeepRacerEnv:
    steps = max_steps_for(rules)
    track = load_track("oval")
    return DeepRacerEnv(
        track=track, vehicle=CAR, mode="evaluation", race=rules.race, max_steps=steps, deterministic=True
    )


class CrashOnce:
    """Follows the centre line (straight into the box that reaches over it) until the first
    crash, then passes boxes in the other lane."""

    def __init__(self, env: DeepRacerEnv) -> None:
        self.into = centre_line_driver(env, 1.2)
        self.past = LaneChangingDriver(env, 1.2)
        self.crashed = False
        self.crashes: list[dict[str, Any]] = []

    def __call__(self, obs: Any) -> Any:
        return (self.past if self.crashed else self.into)(obs)

    def observe(self, view: StepView) -> None:
        if view.event == "crashed":
            self.crashed = True


def test_driving_into_a_box_costs_exactly_the_collision_penalty() -> None:
    rules = RaceRules(laps=1, race=ONE_BOX, collision_penalty=5.0, off_track_penalty=2.0)
    env = make_env(rules)
    driver = CrashOnce(env)
    events: list[str] = []

    def observe(view: StepView) -> None:
        events.append(view.event)
        driver.observe(view)

    result = run_time_trial(env, driver, rules, observer=observe)
    lap = result.laps[0]
    assert result.ended == "laps_done" and lap.status == "lap_complete"
    assert lap.crashes == 1 and result.crashes == 1 and events.count("crashed") == 1
    assert lap.off_track_count == 0
    assert lap.resets == 1 and events.count("reset") == 1
    assert lap.penalty_seconds == pytest.approx(5.0)
    assert lap.time == pytest.approx(lap.steps / 15.0 + 5.0)
    assert result.total_time == pytest.approx(result.steps / 15.0 + 5.0)


def test_collision_penalty_zero_counts_the_crash_but_adds_no_time() -> None:
    rules = RaceRules(laps=1, race=ONE_BOX, collision_penalty=0.0)
    env = make_env(rules)
    driver = CrashOnce(env)
    result = run_time_trial(env, driver, rules, observer=driver.observe)
    assert result.laps[0].crashes == 1 and result.laps[0].penalty_seconds == 0.0
    assert result.laps[0].time == pytest.approx(result.steps / 15.0)


def test_a_lane_changing_driver_finishes_an_object_avoidance_trial_without_crashes() -> None:
    rules = RaceRules(laps=2, race=RaceConfig("object-avoidance", objects=3))
    env = make_env(rules)
    result = run_time_trial(env, LaneChangingDriver(env, 1.2), rules)
    assert result.ended == "laps_done"
    assert [lap.status for lap in result.laps] == ["lap_complete"] * 2
    assert result.crashes == 0 and result.penalty_seconds == 0.0 and result.resets == 0


def test_crashes_count_against_max_resets() -> None:
    """Straight into the box every time: each crash is a reset, until they run out."""
    rules = RaceRules(laps=1, race=ONE_BOX, max_resets=2)
    env = make_env(rules)
    result = run_time_trial(env, centre_line_driver(env, 1.2), rules)
    lap = result.laps[0]
    assert result.ended == "max_resets" and lap.status == "crashed"
    assert lap.crashes == 3 and lap.resets == 2
    assert lap.penalty_seconds == pytest.approx(15.0)


def test_rules_round_trip_with_the_race() -> None:
    rules = RaceRules(laps=2, race=ONE_BOX, collision_penalty=3.0)
    stored = rules.to_dict()
    assert stored["race_type"] == "object_avoidance" and stored["collision_penalty"] == 3.0
    assert stored["race"]["object_positions"] == [[0.3, "inside"]]
    assert RaceRules.from_dict(stored) == rules
    assert RaceRules.from_dict({"laps": 1}).race.race_type == "time-trial"


@pytest.mark.parametrize("penalty", [-1.0, float("nan")])
def test_bad_collision_penalty(penalty: float) -> None:
    with pytest.raises(SettingError, match="^collision_penalty .* is invalid; use 0 or more seconds"):
        RaceRules(collision_penalty=penalty)
