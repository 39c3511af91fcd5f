"""Boxes and bots in the env: params object keys, lidar, crashes, bots, a lap round the boxes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drx.evaluate.scripted import lane_changing_steer
from drx.settings.race import RaceConfig
from drx.sim.dynamics import CarParams
from drx.sim.lidar import Lidar
from drx.sim.objects import BOX_CRASH_SIZE, BOX_SIZE, Rect, make_rect, rects_overlap
from drx.sim.race_scene import RaceScene
from drx.vehicle import Vehicle

from ._drive import CONTINUOUS, action, make, pursuit_steering
from ._tracks import shared_track

STEREO_LIDAR = Vehicle(
    name="sl",
    continuous=True,
    steering_range=(-30.0, 30.0),
    speed_range=(0.5, 4.0),
    sensor="stereo",
    lidar=True,
)
PLACES = ((0.25, "inside"), (0.5, "outside"), (0.75, "inside"))
BOXES = RaceConfig("object-avoidance", object_positions=PLACES)


def _pose_at(env: gym.Env, frac: float, offset: float = 0.0, turn: float = 0.0) -> dict[str, float]:
    """Reference-point pose ``offset`` m left of the centre line at ``frac`` of the lap."""
    track = env.unwrapped.track
    s = frac * track.length
    x, y = track.point_at(s)
    h = track.heading_at(s)
    return {"x": x - offset * math.sin(h), "y": y + offset * math.cos(h), "heading": math.degrees(h + turn)}


@pytest.mark.parametrize("reverse", [False, True])
def test_params_object_keys_on_hand_placed_boxes(reverse: bool) -> None:
    track = shared_track("reinvent_base")  # counter-clockwise; reversed it is driven clockwise
    env = make(track, race=BOXES, reverse=reverse, mode="evaluation")
    length = env.unwrapped.track.length
    _, info = env.reset(options={"pose": _pose_at(env, 0.4)})
    p = info["params"]
    assert p["closest_objects"] == [0, 1]
    assert p["objects_distance"] == pytest.approx([0.25 * length, 0.5 * length, 0.75 * length], abs=0.02)
    inside_left = not reverse  # the inside of a counter-clockwise lap is on the left
    assert p["objects_left_of_center"] == [inside_left, not inside_left, inside_left]
    assert p["objects_speed"] == [0.0, 0.0, 0.0] and p["objects_heading"] == [0.0, 0.0, 0.0]
    assert p["is_crashed"] is False
    for (bx, by), d in zip(p["objects_location"], p["objects_distance"], strict=True):
        proj = env.unwrapped.track.project(bx, by)
        assert proj.s == pytest.approx(d, abs=0.02)
        assert proj.distance == pytest.approx(proj.width / 4, abs=0.02)
    # before the first box the one behind is the last; past the last the one ahead is the first
    assert env.reset(options={"pose": _pose_at(env, 0.1)})[1]["params"]["closest_objects"] == [2, 0]
    assert env.reset(options={"pose": _pose_at(env, 0.8)})[1]["params"]["closest_objects"] == [2, 0]
    assert env.reset(options={"pose": _pose_at(env, 0.6)})[1]["params"]["closest_objects"] == [1, 2]
    # a reward function sees the same lists, and may change them without harm
    _, _, _, _, info = env.step(action(0.0, 1.0))
    info["params"]["objects_location"].clear()
    _, _, _, _, info = env.step(action(0.0, 1.0))
    assert len(info["params"]["objects_location"]) == 3


def test_time_trial_has_no_objects() -> None:
    env = make(shared_track("reinvent_base"))
    p = env.reset()[1]["params"]
    assert p["closest_objects"] == [0, 0] and p["objects_location"] == [] and p["is_crashed"] is False


def test_lidar_reads_the_distance_to_a_box() -> None:
    lidar = Lidar()
    box = make_rect(1.08, 0.0, 0.0, 0.4, 0.4)  # centre 1.0 m ahead of the sensor (0.08 m ahead of the axle)
    ranges = lidar.scan(0.0, 0.0, 0.0, [box])
    assert ranges.shape == (64,) and ranges.dtype == np.float32
    assert ranges[32] == pytest.approx(0.8, abs=1e-5), "beam 32 looks straight ahead: 1.0 m - half the box"
    assert ranges[0] == 2.0 and ranges[16] == 2.0 and ranges[48] == 2.0
    # the box covers +-atan(0.2 / 0.8) = +-14 deg: beams 30..34 (5.6 deg apart) see it, 29 and 35 do not
    assert (ranges[30:35] < 2.0).all() and ranges[29] == 2.0 and ranges[35] == 2.0
    assert ranges[31] == pytest.approx(0.8 / math.cos(lidar.step), abs=1e-5)
    # to the left (beam 48), turned 90 degrees; behind (beam 0); out of range; too close
    left = lidar.scan(0.0, 0.0, 0.0, [make_rect(0.08, 1.5, 0.3, 0.2, 0.2)])
    assert left[48] == pytest.approx(1.5 - 0.1 / math.cos(0.3), abs=0.03) and left[32] == 2.0
    assert lidar.scan(0.0, 0.0, 0.0, [make_rect(-0.92, 0.0, 0.0, 0.2, 0.2)])[0] == pytest.approx(
        0.9, abs=1e-5
    )
    assert (lidar.scan(0.0, 0.0, 0.0, [make_rect(3.0, 0.0, 0.0, 0.4, 0.4)]) == 2.0).all()
    assert lidar.scan(0.0, 0.0, 0.0, [make_rect(0.25, 0.0, 0.0, 0.2, 0.2)])[32] == pytest.approx(0.15)
    assert (lidar.scan(0.0, 0.0, 0.0, [make_rect(0.08, 0.0, 0.0, 0.4, 0.4)]) == 0.15).all()
    # turned car: the box stays where it is in the world
    turned = lidar.scan(0.0, 0.0, math.pi / 2, [box])
    assert turned[16] == pytest.approx(1.08 - 0.2, abs=1e-5) and turned[32] == 2.0  # beam 16: to the right
    sectors = lidar.sectors(lidar.scan(0.0, 0.0, 0.0, [make_rect(0.5, 0.0, 0.0, 0.2, 0.2)]))
    assert sectors.tolist() == [0, 0, 0, 1, 1, 0, 0, 0]  # beams 31-33: sectors 24-31 and 32-39
    far = lidar.sectors(lidar.scan(0.0, 0.0, 0.0, [make_rect(0.8, 0.0, 0.0, 0.2, 0.2)]))
    assert far.tolist() == [0.0] * 8  # nearer than 0.5 m only


def test_stereo_lidar_observation_sees_the_box_ahead() -> None:
    track = shared_track("reinvent_base")
    race = RaceConfig("object-avoidance", object_positions=((0.1, "inside"),))  # on the start straight
    env = make(track, vehicle=STEREO_LIDAR, race=race, mode="evaluation")
    plain = make(track, vehicle=STEREO_LIDAR, mode="evaluation")
    assert env.observation_space["camera"].shape == (120, 160, 2)
    assert env.observation_space["lidar"].shape == (64,)
    lane = env.unwrapped.scene.objects[0].offset
    pose = _pose_at(env, 0.1 - 1.0 / track.length, offset=lane)  # 1 m before the box, in its lane
    obs, _ = env.reset(options={"pose": pose})
    ref, _ = plain.reset(options={"pose": pose})
    ref_ahead = CarParams().reference_offset  # params (x, y) ahead of the rear axle; the lidar 0.08 m
    assert obs["lidar"][32] == pytest.approx(1.0 - 0.08 + ref_ahead - BOX_SIZE[0] / 2, abs=0.05)
    assert (ref["lidar"] == 2.0).all(), "the lidar sees no borders"
    for eye in (0, 1):
        changed = np.abs(obs["camera"][:, :, eye].astype(int) - ref["camera"][:, :, eye]) > 20
        assert changed.sum() > 300, "the box shows in both cameras"
    assert not np.array_equal(obs["camera"][:, :, 0], obs["camera"][:, :, 1])
    sector = make(track, vehicle=STEREO_LIDAR, race=race, lidar_type="sector", mode="evaluation")
    assert sector.observation_space["lidar"].shape == (8,)
    # a top-down frame shows the boxes
    top = make(track, race=race, render_mode="rgb_array")
    top.reset(options={"pose": pose})
    with_boxes = top.render()
    bare = make(track, render_mode="rgb_array")
    bare.reset(options={"pose": pose})
    assert (np.abs(with_boxes.astype(int) - bare.render()).sum(axis=2) > 60).sum() > 50


def test_object_envs_pass_gymnasiums_checker() -> None:
    track = shared_track("reinvent_base")
    check_env(make(track, vehicle=STEREO_LIDAR, race=BOXES).unwrapped, skip_render_check=True)
    check_env(make(track, vehicle=STEREO_LIDAR, race="head-to-bot").unwrapped, skip_render_check=True)


def test_driving_into_a_box_ends_the_episode_crashed_and_resumes_behind_it() -> None:
    track = shared_track("reinvent_base")
    seen: list[bool] = []

    def reward(params: dict) -> float:
        seen.append(params["is_crashed"])
        return 1.0

    env = make(track, race=BOXES, mode="evaluation", reward_function=reward)
    lane = env.unwrapped.scene.objects[1].offset
    env.reset(options={"pose": _pose_at(env, 0.5 - 1.0 / track.length, offset=lane)})
    for _ in range(60):
        _, _, terminated, _, info = env.step(action(pursuit_steering(env), 1.0))
        if terminated:
            break
    assert info["episode_status"] == "crashed" and info["params"]["is_crashed"] and seen[-1] is True
    crash = info["crash"]
    assert crash["index"] == 1 and crash["kind"] == "box"
    assert crash["object_distance"] == pytest.approx(0.5 * track.length, abs=0.02)
    assert crash["object_progress"] == pytest.approx(50.0, abs=0.2)
    progress = info["progress"]
    # evaluation goes on behind the box (the evaluator adds the penalty)
    _, info = env.reset(options={"resume": True})
    assert info["steps"] == len(seen) and info["progress"] < progress
    x, y = info["params"]["x"], info["params"]["y"]
    s = track.project(x, y).s
    assert 0.5 * track.length - s == pytest.approx(BOX_CRASH_SIZE[0] / 2 + 0.5, abs=0.03)
    assert track.project(x, y).distance < 0.01 and not info["params"]["is_crashed"]


def test_crash_test_is_the_car_body_against_the_grown_box() -> None:
    box = make_rect(0.0, 0.0, 0.0, *BOX_CRASH_SIZE)
    car = Rect(-0.45, 0.0, 1.0, 0.0, 0.15, 0.1)
    assert not rects_overlap(box, car)
    assert rects_overlap(box, car._replace(x=-0.34))
    diagonal = make_rect(0.35, 0.35, math.pi / 4, 0.3, 0.2)
    assert not rects_overlap(box, diagonal)  # bounding circles overlap, the rectangles do not
    assert rects_overlap(box, diagonal._replace(x=0.3, y=0.3))


def test_training_starts_clear_of_boxes_on_a_narrow_track() -> None:
    track = shared_track("Oval_track")  # 0.61 m: a car on the centre line touches a lane's box
    places = tuple((f, lane) for f, lane in ((0.10, "inside"), (0.30, "outside"), (0.50, "inside")))
    env = make(track, race=RaceConfig("object-avoidance", object_positions=places))
    for _ in range(20):
        _, info = env.reset()
        assert not info["params"]["is_crashed"]
        st = env.unwrapped.car_state
        assert env.unwrapped.scene.hit(st.x, st.y, st.yaw) is None


@pytest.mark.parametrize("reverse", [False, True])
def test_bots_keep_their_lane_and_speed(reverse: bool) -> None:
    base = shared_track("reinvent_base")
    track = base.reversed() if reverse else base
    scene = RaceScene(track, RaceConfig("head-to-bot", bots=3, bot_speed=1.5))
    scene.reset(np.random.default_rng(0), 0.0, training=False)
    start = [o.s for o in scene.objects]
    assert start == pytest.approx([2.0, 2.0 + (track.length - 3.0) / 2, track.length - 1.0])
    sides = [o.offset > 0 for o in scene.objects]
    assert sides == [track.direction == "ccw", track.direction != "ccw", track.direction == "ccw"]
    for _ in range(150):  # 10 s, more than half a lap
        scene.step(1 / 15)
        for obj, left in zip(scene.objects, sides, strict=True):
            proj = track.project(obj.x, obj.y)
            assert proj.left == left
            assert proj.distance == pytest.approx(proj.width / 4, abs=0.03)
            assert obj.speed == pytest.approx(1.5)
    travelled = [(o.s - s0) % track.length for o, s0 in zip(scene.objects, start, strict=True)]
    assert travelled == pytest.approx([15.0] * 3, abs=0.01)
    p = scene.params(0.0)
    assert p["objects_speed"] == [1.5] * 3
    for obj, heading in zip(scene.objects, p["objects_heading"], strict=True):
        assert abs(np.angle(np.exp(1j * (heading - track.heading_at(obj.s))))) < 0.15  # radians


def test_bots_change_lanes_smoothly_without_touching() -> None:
    track = shared_track("reInvent2019_track")
    scene = RaceScene(track, RaceConfig("head-to-bot", bots=4, bot_speed=2.0, bot_lane_change=True))
    scene.reset(np.random.default_rng(3), 0.0, training=True)
    changes = [0] * 4
    last = [o.offset > 0 for o in scene.objects]
    prev = [(o.x, o.y) for o in scene.objects]
    for _ in range(15 * 20):
        scene.step(1 / 15)
        for i, obj in enumerate(scene.objects):
            side = obj.offset > 0
            changes[i] += side != last[i]
            last[i] = side
            assert math.hypot(obj.x - prev[i][0], obj.y - prev[i][1]) < 3.0 / 15, "no jumps"
            prev[i] = (obj.x, obj.y)
        rects = [o.crash_rect for o in scene.objects]
        assert not any(rects_overlap(a, b) for i, a in enumerate(rects) for b in rects[i + 1 :])
    assert all(3 <= c <= 7 for c in changes), changes  # one change every 3-5 s (+ 0.5 s to cross)


def test_a_bot_behind_a_stopped_car_crashes_into_it() -> None:
    env = make(shared_track("reinvent_base"), race=RaceConfig("head-to-bot", bots=1, bot_speed=2.0))
    env.reset(options={"start": 0.0})
    bot = env.unwrapped.scene.bots.bots[0]
    bot.s, bot.lateral, bot.lane = -1.0, 0.0, 1.0  # 1 m behind the car, on the centre line
    for _ in range(30):
        _, _, terminated, _, info = env.step(action(0.0, 0.5))
        if terminated:
            break
    assert info["episode_status"] == "crashed" and info["crash"]["kind"] == "bot"


def _lane_changing_policy(env: gym.Env) -> float:
    """Pure pursuit towards the side of the road away from the nearest box that is ahead or
    still alongside, from the params keys a reward function sees."""
    return max(-30.0, min(30.0, lane_changing_steer(env)))


@pytest.mark.parametrize("name", ["reinvent_base", "reInvent2019_wide_cw"])
def test_a_lane_changing_policy_finishes_a_lap_round_the_boxes(name: str) -> None:
    race = RaceConfig("object-avoidance", objects=6)
    env = make(shared_track(name), race=race, mode="evaluation", vehicle=CONTINUOUS)
    env.reset()
    straight = make(shared_track(name), race=race, mode="evaluation", vehicle=CONTINUOUS)
    straight.reset()
    for _ in range(3000):
        _, _, terminated, truncated, info = env.step(action(_lane_changing_policy(env), 1.0))
        if terminated or truncated:
            break
    assert info["episode_status"] == "lap_complete", info["episode_status"]
    # following the centre line instead hits a box (they reach over the centre line)
    for _ in range(3000):
        _, _, terminated, _, info = straight.step(action(pursuit_steering(straight), 1.0))
        if terminated:
            break
    assert info["episode_status"] == "crashed"


def test_validation_samples_carry_the_objects() -> None:
    from drx.sim.params import sample_params_cases

    track = shared_track("reinvent_base")
    plain = sample_params_cases(track)
    assert "crashed" not in plain and plain["start"]["objects_location"] == []
    cases = sample_params_cases(track, race=BOXES)
    assert set(cases) == set(plain) | {"crashed"}
    assert all(len(c["objects_location"]) == 3 for c in cases.values())
    assert cases["crashed"]["is_crashed"] and not cases["start"]["is_crashed"]
    assert cases["start"]["closest_objects"] == [2, 0]
    bots = sample_params_cases(track, race={"race_type": "head-to-bot", "bots": 2, "bot_speed": 1.0})
    assert bots["start"]["objects_speed"] == [1.0, 1.0] and bots["crashed"]["is_crashed"]


def test_a_pose_reset_keeps_the_bots_where_they_are() -> None:
    env = make(shared_track("reinvent_base"), race=RaceConfig("head-to-bot", bots=2, bot_speed=1.0),
               mode="evaluation")  # fmt: skip
    env.reset()
    for _ in range(30):
        env.step(action(pursuit_steering(env), 0.5))
    before = [(o.x, o.y) for o in env.unwrapped.scene.objects]
    env.reset(options={"pose": _pose_at(env, 0.5)})  # an evaluation's next lap goes on among them
    assert [(o.x, o.y) for o in env.unwrapped.scene.objects] == before
    env.reset(options={"start": 0.0})
    assert env.unwrapped.scene.objects[0].s == pytest.approx(2.0)
