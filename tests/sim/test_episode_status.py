"""The episode-status vocabulary and the one place that decides how a step ends (the env)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from drx.calibration.logs import read_trace
from drx.errors import DrxError
from drx.sim.env import DeepRacerEnv
from drx.sim.episode_status import EpisodeStatus
from drx.vehicle import Vehicle
from tests.conftest import SHARED_LOGS

# deepracer-simapp bundle/markov/metrics/constants.py EpisodeStatus, and drx's reward_error.
DEEPRACER_WORDS = {
    "prepare", "in_progress", "off_track", "crashed", "reversed", "immobilized", "lap_complete",
    "time_up", "pause", "park",
}  # fmt: skip
CAR = Vehicle(name="scripted", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


def test_the_values_are_deepracers_words_and_store_as_them() -> None:
    assert {s.value for s in EpisodeStatus} == DEEPRACER_WORDS | {"reward_error"}
    for status in EpisodeStatus:
        out = io.StringIO()
        csv.writer(out).writerow([status])
        assert out.getvalue().strip() == str(status) == f"{status}" == status.value
        assert json.dumps(status) == json.dumps(status.value) and type(str(status)) is str
        assert EpisodeStatus(status.value) is status and status == status.value


def test_every_status_in_deepracers_traces_is_in_the_vocabulary() -> None:
    """Every trace the shared logs hold, read as drx reads a user's logs: sim-trace CSVs (the
    continuous ones write their ``[steer, speed]`` action unquoted, one comma too many for a
    plain CSV read) and robomaker logs alike."""
    if not SHARED_LOGS.is_dir():
        pytest.skip(
            f"{SHARED_LOGS} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo"
        )
    files = sorted(SHARED_LOGS.rglob("*-iteration.csv")) + sorted(SHARED_LOGS.rglob("*_robomaker.*.log"))
    seen: set[str] = set()
    for path in files:
        for episode in read_trace(path):
            seen |= set(episode.status)
    assert files and seen and seen <= {s.value for s in EpisodeStatus}
    assert {"prepare", "in_progress", "off_track", "lap_complete"} <= seen


def test_a_continuous_traces_unquoted_action_does_not_shift_the_status(tmp_path: Path) -> None:
    row = "0,2.0,0.32,2.69,-84.0,-9.95,1.5,[-9.95, 1.5],1.3,False,True,0.60,1,23.118,20.778,in_progress,0.0"
    header = (
        "episode,steps,X,Y,yaw,steer,throttle,action,reward,done,all_wheels_on_track,progress,"
        "closest_waypoint,track_len,tstamp,episode_status,pause_duration"
    )
    assert len(next(csv.reader([row]))) == len(header.split(",")) + 1  # the field a plain read shifts
    path = tmp_path / "0-iteration.csv"
    path.write_text(header + "\n" + row + "\n")
    (episode,) = read_trace(path)
    assert episode.status == ("in_progress",)
    assert episode.steer[0] == pytest.approx(-9.95) and episode.throttle[0] == pytest.approx(1.5)
    assert episode.progress[0] == pytest.approx(0.60) and episode.tstamp[0] == pytest.approx(20.778)


def _drive(
    env: DeepRacerEnv, steer: float, speed: float, steps: int
) -> list[tuple[EpisodeStatus, bool, bool]]:
    """(status, terminated, truncated) of every step until the episode ends."""
    out = []
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step([steer, speed])
        assert info["episode_status"] is env.status
        out.append((env.status, terminated, truncated))
        if terminated or truncated:
            break
    return out


def test_the_env_ends_a_step_by_its_status() -> None:
    env = DeepRacerEnv(track="oval", vehicle=CAR, mode="evaluation", deterministic=True)
    _, info = env.reset(seed=0)
    assert info["episode_status"] is EpisodeStatus.PREPARE
    steps = _drive(env, 1.0, 1.0, 400)  # full left lock: off the road within a few metres
    assert [s for s, _, _ in steps[:-1]] == [EpisodeStatus.IN_PROGRESS] * (len(steps) - 1)
    assert steps[-1] == (EpisodeStatus.OFF_TRACK, True, False)
    for status, terminated, truncated in steps:
        assert terminated == (status.ends_episode and not status.truncates) and truncated == status.truncates

    short = DeepRacerEnv(track="oval", vehicle=CAR, mode="evaluation", deterministic=True, max_steps=5)
    short.reset(seed=0)
    assert _drive(short, 0.0, -1.0, 10)[-1] == (EpisodeStatus.TIME_UP, False, True)  # the step limit


def test_a_penalised_resume_is_a_pause() -> None:
    env = DeepRacerEnv(track="oval", vehicle=CAR, mode="evaluation", deterministic=True)
    env.reset(seed=0)
    assert _drive(env, 1.0, 1.0, 400)[-1][0] is EpisodeStatus.OFF_TRACK
    _, info = env.reset(options={"resume": True, "pause": 2.0})
    assert info["episode_status"] is EpisodeStatus.PAUSE is env.status and info["pause_duration"] == 2.0
    assert not EpisodeStatus.PAUSE.ends_episode and not EpisodeStatus.PREPARE.ends_episode


def _start(env: DeepRacerEnv, **reset: object) -> float:
    env.reset(**reset)  # type: ignore[arg-type]
    _, _, _, _, info = env.step([0.0, -1.0])
    return float(info["start_fraction"])


def test_reset_option_episode_sets_the_round_robin() -> None:
    env = DeepRacerEnv(track="oval", vehicle=CAR, mode="training", deterministic=True)
    assert _start(env, seed=0) == pytest.approx(0.0, abs=1e-9)
    assert _start(env, options={"episode": 7}) == pytest.approx(0.35, abs=1e-3)
    assert _start(env) == pytest.approx(0.40, abs=1e-3)  # the resets after it go on
    assert _start(env, seed=1, options={"episode": 3}) == pytest.approx(0.15, abs=1e-3)  # wins over the seed
    assert _start(env, options={"episode": 30, "start": 0.5}) == pytest.approx(0.5, abs=1e-3)
    assert _start(env) == pytest.approx(0.5, abs=1e-3)  # a start does not use up episode 30
    assert _start(env) == pytest.approx(0.55, abs=1e-3)


@pytest.mark.parametrize("bad", [-1, 1.5, True, "3", None])
def test_reset_option_episode_must_be_a_count(bad: object) -> None:
    env = DeepRacerEnv(track="oval", vehicle=CAR, mode="training", deterministic=True)
    with pytest.raises(DrxError, match=r"reset option episode .* int >= 0"):
        env.reset(options={"episode": bad})


def test_reward_validate_cases_are_named_by_status() -> None:
    from drx.sim.params import sample_params_cases
    from drx.sim.track import load_track

    cases = sample_params_cases(load_track("oval"))
    assert cases[EpisodeStatus.OFF_TRACK]["is_offtrack"] and "off_track" in cases
    assert cases["lap_complete"]["progress"] == 100.0


@pytest.mark.parametrize("bad", ["half", None, float("nan"), float("inf")])
def test_reset_option_start_must_be_a_fraction(bad: object) -> None:
    env = DeepRacerEnv(track="oval", vehicle=CAR, mode="training", deterministic=True)
    with pytest.raises(DrxError, match=r"reset option start .* fraction of the lap"):
        env.reset(options={"start": bad})
