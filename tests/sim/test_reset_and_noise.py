"""Reset options (pose, speed, steering), DeepRacer's start offset and the seeded step-time noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drx.errors import DrxError
from drx.sim.dynamics import CarParams
from drx.sim.noise import StepNoise

from ._drive import action, make
from ._tracks import shared_track

P = CarParams()


def _straight_drive(env, steps: int, speed: float = 2.0) -> list[dict]:  # type: ignore[no-untyped-def]
    return [env.step(action(0.0, speed))[4] for _ in range(steps)]


def test_reset_pose_speed_and_steering_start_the_car_moving() -> None:
    track = shared_track("reinvent_base")
    env = make(track, deterministic=True)
    x, y = (float(v) for v in track.point_at(2.0))
    heading = math.degrees(float(track.heading_at(2.0)))
    pose = {"x": x, "y": y, "heading": heading}
    _, info = env.reset(options={"pose": pose, "speed": 2.0, "steering": 10.0})
    st = env.unwrapped.car_state
    assert info["params"]["x"] == pytest.approx(x) and info["params"]["y"] == pytest.approx(y)
    assert info["params"]["heading"] == pytest.approx(heading)
    assert st.speed == pytest.approx(2.0) and math.degrees(st.steering) == pytest.approx(10.0)
    assert info["params"]["speed"] == 2.0 and info["params"]["steering_angle"] == 10.0
    assert info["progress"] == 0.0  # a pose: progress counts from there
    # It is already moving: the first step covers about 2 m/s * 1/15 s (a car at rest barely moves).
    before = env.unwrapped.car_state.copy()
    env.step(action(10.0, (2.0 - P.speed_offset) / P.speed_gain))
    moved = math.hypot(env.unwrapped.car_state.x - before.x, env.unwrapped.car_state.y - before.y)
    assert moved == pytest.approx(2.0 / 15, rel=0.05)
    env.reset(options={"pose": {"x": x, "y": y, "heading": heading}})
    assert env.unwrapped.car_state.speed == 0.0 and env.unwrapped.car_state.steering == 0.0


@pytest.mark.parametrize(
    "options, fragment",
    [
        ({"pose": {"x": 0.0, "y": 0.0}}, "pose"),
        ({"pose": {"x": "a", "y": 0.0, "heading": 0.0}}, "pose"),
        ({"pose": {"x": math.nan, "y": 0.0, "heading": 0.0}}, "finite"),
        ({"start": 0.0, "speed": 9.0}, "speed 9 is out of range"),
        ({"start": 0.0, "steering": -45.0}, "steering -45 is out of range"),
        ({"start": 0.0, "speed": "fast"}, "numbers"),
    ],
)
def test_bad_reset_options_are_refused_with_one_sentence(options: dict, fragment: str) -> None:
    env = make(shared_track("reinvent_base"))
    with pytest.raises(DrxError, match=fragment):
        env.reset(options=options)


def test_start_puts_the_origin_on_the_start_point() -> None:
    """DeepRacer: at the start line the car's origin sits on waypoint 0 (DEEPRACER.md section 3)."""
    track = shared_track("reinvent_base")
    env = make(track, mode="evaluation")
    _, info = env.reset()
    st = env.unwrapped.car_state
    ox, oy = st.x + P.origin_offset * math.cos(st.yaw), st.y + P.origin_offset * math.sin(st.yaw)
    assert (ox, oy) == pytest.approx(tuple(track.center[0]), abs=1e-9)
    assert info["progress"] == pytest.approx(0.7913, abs=0.01)  # DeepRacer's own first row: 0.7913
    assert info["params"]["closest_waypoints"] == [0, 1]


def _lap_steps(env, seed: int | None, steps: int = 45) -> np.ndarray:  # type: ignore[no-untyped-def]
    env.reset(seed=seed)
    infos = _straight_drive(env, steps, speed=1.0)
    return np.array([[i["params"]["x"], i["params"]["y"], i["step_time"]] for i in infos])


def test_noise_is_seeded_varied_and_off_when_deterministic() -> None:
    track = shared_track("Straight_track")
    noisy = make(track, mode="evaluation", deterministic=False)
    a, b, c = _lap_steps(noisy, 7), _lap_steps(noisy, 7), _lap_steps(noisy, 8)
    assert np.array_equal(a, b)  # the same seed: the same steps
    assert not np.array_equal(a, c)  # another seed: other step lengths, other positions
    dts = a[:, 2]
    assert dts.std() > 0.3 * P.step_time_jitter and dts.mean() == pytest.approx(P.step_time, rel=0.1)
    assert np.abs(a[-1, :2] - c[-1, :2]).max() > 1e-3  # the car ends somewhere else
    exact = make(track, mode="evaluation", deterministic=True)
    d, e = _lap_steps(exact, 7), _lap_steps(exact, 8)
    assert np.array_equal(d, e)  # seeds do not matter
    assert np.all(d[:, 2] == 1 / 15)


def test_step_lengths_jitter_around_a_steady_beat() -> None:
    """As in DeepRacer's logs (drx.sim.noise): a step's length varies by ``step_time_jitter``, a long
    step is followed by a short one (correlation -0.5), and the beat itself does not drift."""
    noise = StepNoise(P, np.random.default_rng(5))
    dts = np.array([noise.step_time() for _ in range(20000)])
    assert dts.std() == pytest.approx(P.step_time_jitter, rel=0.05)
    assert np.corrcoef(dts[:-1], dts[1:])[0, 1] == pytest.approx(-0.5, abs=0.05)
    # 20000 steps end within a few readings' jitter of 20000 beats
    assert abs(dts.sum() - 20000 * P.step_time) < 5 * P.step_time_jitter


def test_lap_time_is_simulated_time() -> None:
    track = shared_track("Straight_track")
    env = make(track, mode="evaluation", deterministic=False)
    env.reset(seed=3)
    total, info = 0.0, {}
    for _ in range(400):
        *_, terminated, truncated, info = env.step(action(0.0, 2.0))
        total += info["step_time"]
        if terminated or truncated:
            break
    assert info["episode_status"] == "lap_complete"
    assert info["lap_time"] == pytest.approx(total)
    assert info["lap_time"] != pytest.approx(info["steps"] / 15, abs=1e-9)
