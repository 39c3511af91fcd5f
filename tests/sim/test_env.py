"""The Gymnasium env on real DeepRacer tracks: episodes end as DeepRacer's do."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drx.sim.dynamics import CarParams, steady_curvature
from drx.sim.params import PARAM_KEYS
from drx.sim.reward_loader import RewardFunctionError
from drx.vehicle import default_vehicle

from ._drive import action, drive, make, pursuit_steering
from ._tracks import NAMES, TRACKS, shared_path, shared_track


@pytest.mark.parametrize("name", NAMES)
def test_centre_line_lap_completes_with_rising_progress(name: str) -> None:
    env = make(shared_track(name), mode="evaluation")
    _, info0 = env.reset(seed=1)
    # DeepRacer's start: the car's origin on waypoint 0, so progress already shows the reference
    # point's 0.14 m lead (0.79% on reinvent_base in DeepRacer's own trace)
    lead = 100 * 0.14 / TRACKS[name][3]
    assert info0["progress"] == pytest.approx(lead, rel=0.05) and info0["episode_status"] == "prepare"
    infos, _ = drive(env, speed=1.0)
    progress = [i["progress"] for i in infos]
    assert infos[-1]["episode_status"] == "lap_complete"
    assert progress[-1] == 100.0
    assert all(b >= a - 1e-9 for a, b in zip(progress, progress[1:], strict=False))
    assert progress[len(progress) // 2] == pytest.approx(50.0, abs=8.0)
    # (On the open track the front wheels roll past the far end on the last steps.)
    assert all(i["params"]["all_wheels_on_track"] for i in infos[: -2 if name == "Straight_track" else None])
    # Near the centre line, but the car cannot bend tighter than its full-lock turn at 1 m/s (about
    # 0.7 m, as DeepRacer's own logs on 2022_reinvent_champ show): where the centre line bends tighter
    # (0.47 m there), it runs wide by the difference.
    tightest = 1.0 / steady_curvature(math.radians(30.0), 1.0, CarParams())
    wide = max(0.0, tightest - _tightest_radius(shared_track(name)))
    assert max(i["params"]["distance_from_center"] for i in infos) < TRACKS[name][4] / 3 + wide
    # About the time a 1 m/s car needs for the lap (it starts from rest).
    lap_length = TRACKS[name][3] - (0.16 if name == "Straight_track" else 0.0)
    assert infos[-1]["lap_time"] == pytest.approx(lap_length / 1.0, rel=0.08)
    assert [i["steps"] for i in infos[:3]] == [1, 2, 3]


@pytest.mark.parametrize("name", ["reinvent_base", "reInvent2019_wide_cw", "Straight_track"])
def test_steered_off_the_road_ends_off_track(name: str) -> None:
    track = shared_track(name)
    env = make(track)
    s = 1.0
    x, y = track.point_at(s)
    heading = math.degrees(track.heading_at(s)) + 50.0  # pointed at the left border
    env.reset(options={"pose": {"x": x, "y": y, "heading": heading}})
    infos, _ = drive(env, speed=1.0, steer=0.0, max_steps=200)
    last = infos[-1]
    assert last["episode_status"] == "off_track"
    assert last["params"]["is_offtrack"] and not last["params"]["all_wheels_on_track"]
    assert infos[-2]["params"]["is_offtrack"] is False  # ends on the first step with no wheel on the road
    assert last["params"]["is_left_of_center"]


def test_a_stopped_car_is_immobilized() -> None:
    env = make(shared_track("reinvent_base"), car=CarParams(max_speed=0.0))  # a dead motor
    env.reset()
    infos, _ = drive(env, speed=1.0, steer=0.0, max_steps=100)
    assert [i["episode_status"] for i in infos[:14]] == ["in_progress"] * 14
    assert infos[-1]["episode_status"] == "immobilized" and len(infos) == 15


@pytest.mark.parametrize("name", ["reinvent_base", "Spain_track"])
def test_driving_backwards_ends_reversed(name: str) -> None:
    track = shared_track(name)
    env = make(track)
    s = track.length / 2
    x, y = track.point_at(s)
    env.reset(options={"pose": {"x": x, "y": y, "heading": math.degrees(track.heading_at(s)) + 180.0}})
    infos, _ = drive(env, speed=1.0, backwards=True, max_steps=100)
    assert infos[-1]["episode_status"] == "reversed"
    # 15 steps of going backwards, after the steps the command takes to act from rest
    assert 15 <= len(infos) <= 15 + math.ceil(CarParams().command_delay)
    assert all(i["progress"] == 0.0 for i in infos)  # progress never pays for driving backwards


@pytest.mark.parametrize("name", ["reinvent_base", "2022_reinvent_champ", "reInvent2019_wide_cw"])
def test_tightest_corner_too_fast_slides_off(name: str) -> None:
    track = shared_track(name)
    corner = min(track.corners(), key=lambda c: c.radius)
    run_up = 2.5  # [m] before the corner: enough to reach 4 m/s
    start = (corner.start_s - run_up) % track.length / track.length
    beyond = run_up + corner.end_s - corner.start_s + 0.5  # [m] from the start to just past the corner
    outcomes = {}
    for speed in (1.0, 4.0):
        env = make(track)
        env.reset(options={"start": start})
        status, slid, steers, dist = "in_progress", False, [], 0.0
        for _ in range(int(15 * beyond / speed) + 15):
            steers.append(pursuit_steering(env))
            _, _, terminated, _, info = env.step(action(steers[-1], speed))
            slid |= env.unwrapped.car_state.sliding
            status, dist = info["episode_status"], info["progress"] / 100 * track.length
            if terminated or dist > beyond:
                break
        outcomes[speed] = (status, dist, slid, max(abs(v) for v in steers))
    status, dist, _, _ = outcomes[1.0]
    assert status == "in_progress" and dist > beyond  # the tyres may saturate a little, but it holds on
    status, dist, slid, _ = outcomes[4.0]
    assert status == "off_track" and dist < beyond
    assert slid  # the driver asked for the turn and the tyres let go


def test_training_starts_round_robin_and_evaluation_at_the_line() -> None:
    track = shared_track("reinvent_base")
    train = make(track, mode="training")
    starts = []
    origin_ahead = CarParams().reference_ahead  # the params point is 0.14 m ahead of the origin
    for _ in range(3):
        _, info = train.reset()
        p = info["params"]
        h = math.radians(p["heading"])
        ox, oy = p["x"] - origin_ahead * math.cos(h), p["y"] - origin_ahead * math.sin(h)
        starts.append(track.project(ox, oy).s / track.length)
    assert starts == pytest.approx([0.0, 0.05, 0.10], abs=1e-4)
    evaluation = make(track, mode="evaluation")
    for _ in range(2):
        _, info = evaluation.reset()
        assert info["params"]["closest_waypoints"] == [0, 1]
        assert info["params"]["distance_from_center"] == pytest.approx(0.0, abs=1e-9)
    _, info = evaluation.reset(options={"start": 0.5})
    ref_s = track.project(info["params"]["x"], info["params"]["y"]).s
    assert ref_s == pytest.approx(track.length / 2 + 0.14, abs=0.01)


@pytest.mark.parametrize("reverse", [False, True])
@pytest.mark.parametrize("name", NAMES)
def test_params_at_a_pose_in_both_directions(name: str, reverse: bool) -> None:
    base = shared_track(name)
    env = make(base, reverse=reverse)
    seglen = np.linalg.norm(np.diff(base.center, axis=0), axis=1)
    i = next(k for k in range(len(seglen) // 3, len(seglen)) if seglen[k] > 0.05)
    seg = base.center[i + 1] - base.center[i]
    left = np.array([-seg[1], seg[0]]) / np.linalg.norm(seg)
    x, y = base.center[i] + 0.5 * seg + 0.2 * left  # 20 cm left of the centre, driving forwards
    heading = math.degrees(math.atan2(seg[1], seg[0])) + (180.0 if reverse else 0.0)
    _, info = env.reset(options={"pose": {"x": x, "y": y, "heading": heading}})
    p = info["params"]
    assert p["is_left_of_center"] is (not reverse)
    assert p["is_reversed"] is reverse
    assert p["distance_from_center"] == pytest.approx(0.2, abs=1e-6)
    n = len(base.center)
    assert p["closest_waypoints"] == ([i, i + 1] if not reverse else [n - 2 - i, n - 1 - i])
    assert p["x"] == pytest.approx(x) and p["y"] == pytest.approx(y)
    assert p["heading"] == pytest.approx((heading + 180) % 360 - 180)
    _, _, _, length, width = TRACKS[name]
    assert p["track_width"] == pytest.approx(width, abs=0.05)
    assert p["track_length"] == pytest.approx(base.length) and len(p["waypoints"]) == n
    if name != "China_eval_track":  # drx closes its 0.09 m gap
        assert p["track_length"] == pytest.approx(length, abs=1e-3)


def test_info_params_equals_the_dict_the_reward_saw() -> None:
    seen: list[dict] = []

    def reward_function(params: dict) -> float:
        seen.append(params)
        return 0.5

    env = make(shared_track("reinvent_base"), reward_function=reward_function)
    env.reset()
    _, reward, _, _, info = env.step(action(10.0, 2.0))
    # Equal, not the same dict: the reward gets its own copy (drx.sim.reward_guard.ParamsCopier).
    assert reward == 0.5 and info["params"] == seen[-1] and info["params"] is not seen[-1]
    p = seen[-1]
    assert set(p) == set(PARAM_KEYS)
    assert p["steps"] == 1 and p["speed"] == pytest.approx(2.0) and p["steering_angle"] == pytest.approx(10.0)
    assert p["closest_objects"] == [0, 0] and p["objects_location"] == []
    assert p["waypoints"][0] == p["waypoints"][-1] and len(p["waypoints"]) == 119
    p["waypoints"].reverse()  # a reward function mutating its params does not corrupt the track
    _, _, _, _, info = env.step(action(0.0, 2.0))
    assert info["params"]["waypoints"][1] == tuple(env.unwrapped.track.center[1])


def test_raising_reward_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "my_reward.py"
    path.write_text(
        "def reward_function(params):\n    if params['steps'] > 2:\n        return 1 / 0\n    return 1.0\n"
    )
    env = make(shared_track("reinvent_base"), reward_function=str(path))
    env.reset()
    env.step(action(0.0, 1.0))
    env.step(action(0.0, 1.0))
    with pytest.raises(RewardFunctionError, match=r"my_reward\.py, line 3.*ZeroDivisionError") as err:
        env.step(action(0.0, 1.0))
    assert err.value.params["steps"] == 3
    assert env.unwrapped.status == "reward_error"


def test_check_env_passes_for_discrete_continuous_stereo_and_lidar() -> None:
    path = shared_path("reinvent_base")
    check_env(gym.make("drx/DeepRacer-v0", track=str(path)).unwrapped, skip_render_check=True)
    check_env(make(str(path)).unwrapped, skip_render_check=True)
    stereo = default_vehicle().to_dict() | {"sensor": "stereo", "lidar": True}
    env = gym.make("drx/DeepRacer-v0", track=str(path), vehicle=stereo)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset()
    assert obs["camera"].shape == (120, 160, 2) and obs["lidar"].shape == (64,)


def test_seeding_makes_episodes_reproducible() -> None:
    track = shared_track("reinvent_base")

    def run(seed: int) -> tuple[list[float], np.ndarray]:
        env = gym.make("drx/DeepRacer-v0", track=track)
        env.reset(seed=seed)
        env.action_space.seed(seed)
        rewards, obs = [], None
        for _ in range(120):
            obs, r, term, trunc, _ = env.step(env.action_space.sample())
            rewards.append(r)
            if term or trunc:
                env.reset()
        return rewards, obs

    a, b, c = run(3), run(3), run(4)
    assert a[0] == b[0] and np.array_equal(a[1], b[1])
    assert a[0] != c[0] or not np.array_equal(a[1], c[1])


def test_observation_is_the_camera_and_rgb_render_shows_the_track() -> None:
    env = gym.make("drx/DeepRacer-v0", track=shared_track("reinvent_base"), render_mode="rgb_array")
    obs, _ = env.reset()
    assert obs.dtype == np.uint8 and obs.shape == (120, 160, 1)
    assert obs.std() > 5
    frame = env.render()
    assert frame.shape[2] == 3 and frame.dtype == np.uint8 and frame.std() > 10
    for _ in range(3):  # a command acts after DeepRacer's delay
        obs2, *_ = env.step(5)
    assert not np.array_equal(obs, obs2)  # the car moved


def test_truncation_reports_time_up() -> None:
    env = make(shared_track("Oval_track"), max_steps=5)
    env.reset()
    infos, _ = drive(env, speed=1.0)
    assert len(infos) == 5 and infos[-1]["episode_status"] == "time_up"


def test_resume_after_off_track_keeps_the_lap_going() -> None:
    track = shared_track("reinvent_base")
    env = make(track, mode="evaluation")
    env.reset()
    drive(env, speed=1.0, max_steps=40)  # along the centre line
    infos, _ = drive(env, speed=1.0, steer=-12.0, max_steps=100)  # then off to the right
    assert infos[-1]["episode_status"] == "off_track"
    before = infos[-2]  # DeepRacer resets at the previous step's progress
    _, info = env.reset(options={"resume": True, "pause": 2.0})
    p = info["params"]
    assert info["episode_status"] == "pause" and info["pause_duration"] == 2.0
    assert info["steps"] == infos[-1]["steps"]
    # the origin at the previous progress; the params point 0.14 m further on
    assert info["progress"] == pytest.approx(before["progress"] + 100 * 0.14 / track.length, abs=0.3)
    # on the nearer lane: halfway between the centre line and the right border it left by
    assert p["distance_from_center"] == pytest.approx(p["track_width"] / 4, abs=0.03)
    assert not p["is_left_of_center"] and p["all_wheels_on_track"]
    assert env.unwrapped.car_state.speed == 0.0
    infos, _ = drive(env, speed=1.0)
    assert infos[-1]["episode_status"] == "lap_complete"


def test_extra_params_reach_the_reward_without_shadowing_deepracer_keys() -> None:
    from drx.errors import DrxError

    line = [(0.0, 0.0), (1.0, 1.0)]
    env = make(shared_track("reinvent_base"), extra_params={"racing_line": line})
    _, info = env.reset()
    assert info["params"]["racing_line"] == line
    _, _, _, _, info = env.step(action(0.0, 1.0))
    assert info["params"]["racing_line"] == line and info["params"]["steps"] == 1
    with pytest.raises(DrxError, match="progress"):
        make(shared_track("reinvent_base"), extra_params={"progress": 5})


@pytest.mark.parametrize("name", ["oval", "kidney-cw", "hairpin"])
def test_project_tracks_by_name(name: str) -> None:
    env = make(name, mode="evaluation")
    env.reset()
    infos, _ = drive(env, speed=1.5)
    assert infos[-1]["episode_status"] == "lap_complete"
    default = gym.make("drx/DeepRacer-v0")
    assert default.unwrapped.track.name == "oval"


def _tightest_radius(track: Any) -> float:
    """The centre line's tightest bend [m]: circumradius of points 0.3 m apart along it."""
    c = np.asarray(track.center, dtype=float)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(c, axis=0).T))])
    s = np.arange(0.0, along[-1], 0.05)
    p = np.column_stack([np.interp(s, along, c[:, 0]), np.interp(s, along, c[:, 1])])
    a, b, d = p[:-12], p[6:-6], p[12:]
    area = np.abs((b - a)[:, 0] * (d - a)[:, 1] - (b - a)[:, 1] * (d - a)[:, 0]) / 2
    sides = np.hypot(*(b - a).T) * np.hypot(*(d - b).T) * np.hypot(*(d - a).T)
    return float(np.min(sides / np.maximum(4 * area, 1e-12)))
