"""An action space clustered from the racing line (drx.evaluate.action_space): ranges, count, determinism,
coverage of the line, both turning directions and a straight-ahead action at the top speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drx.errors import DrxError
from drx.evaluate.action_space import LineActionSpace, kmeans_with_fixed, racing_line_actions
from drx.services.tracks import load_track_by_name
from drx.sim.track import Track
from drx.vehicle import Vehicle

from .test_best_lap import ring

TRACK = "reInvent2019_wide_cw"  # A to Z Speedway clockwise: turns mostly right, once left


@pytest.fixture(scope="module")
def track() -> Track:
    return load_track_by_name(TRACK)


@pytest.fixture(scope="module")
def space(track: Track) -> LineActionSpace:
    return racing_line_actions(track, 15)


def test_actions_are_k_distinct_and_within_deepracers_ranges(space: LineActionSpace) -> None:
    assert len(space.actions) == 15 and len(set(space.actions)) == 15
    for a in space.actions:
        assert -30.0 <= a.steering_angle <= 30.0 and 0.1 <= a.speed <= 4.0
    Vehicle(name="liner", actions=space.actions)  # the garage's own checks accept them
    order = [(-a.steering_angle, a.speed) for a in space.actions]
    assert order == sorted(order)  # the console's order: left to right, then slow to fast


def test_the_same_seed_gives_the_same_actions(track: Track, space: LineActionSpace) -> None:
    assert racing_line_actions(track, 15).actions == space.actions


def test_every_point_of_the_line_is_near_an_action(space: LineActionSpace) -> None:
    # 0.12 of the scaled metric: 7 degrees at a 30-degree lock with the speed right, or 0.48 m/s at 4
    assert float(space.distances().max()) < 0.12
    assert float(space.distances().mean()) < 0.05
    steer_miss, speed_miss = space.largest_miss()
    assert steer_miss < 7.0 and speed_miss < 0.5
    assert len(space.steering) == len(space.speeds) == len(space.nearest) == len(space.lap.line.points)


def test_more_actions_cover_the_line_closer(track: Track, space: LineActionSpace) -> None:
    five = racing_line_actions(track, 5)
    assert len(five.actions) == 5
    assert float(five.distances().mean()) > float(space.distances().mean())


def test_straight_ahead_at_top_speed_and_both_directions_as_far_as_the_line(space: LineActionSpace) -> None:
    assert any(a.steering_angle == 0.0 and a.speed == 4.0 for a in space.actions)
    steering = [a.steering_angle for a in space.actions]
    # the line turns right to full lock and left to about 10 degrees: the actions reach both as far
    assert space.steering.min() == pytest.approx(-30.0) and space.steering.max() > 5.0
    assert min(steering) == pytest.approx(float(space.steering.min()), abs=0.1)
    assert max(steering) == pytest.approx(float(space.steering.max()), abs=0.1)


def test_the_steering_is_drx_cars_not_a_bicycles(space: LineActionSpace) -> None:
    bicycle = np.degrees(np.arctan(0.164 * np.abs(space.lap.line.curvature)))
    assert float(space.steering.min()) < -2.0 * float(bicycle.max())  # understeer: about three times more


def test_speed_and_steering_caps(track: Track) -> None:
    capped = racing_line_actions(track, 8, max_steering=25.0, max_speed=2.5)
    assert len(capped.actions) == 8
    assert max(a.speed for a in capped.actions) == 2.5
    assert max(abs(a.steering_angle) for a in capped.actions) <= 25.0
    assert float(capped.speeds.max()) <= 2.5


def test_bad_counts(track: Track) -> None:
    for count in (1, 31):
        with pytest.raises(DrxError, match="2 to 30"):
            racing_line_actions(track, count)
    with pytest.raises(DrxError, match="at least 3"):  # straight ahead, left and right
        racing_line_actions(track, 2)


def test_a_ring_turns_one_way_so_two_actions_do() -> None:
    center, inner, outer = ring(2.0, 1.0)
    two = racing_line_actions(Track("ring", center, inner, outer), 2)  # straight ahead, and left
    assert (two.actions[1].steering_angle, two.actions[1].speed) == (0.0, 4.0)
    assert two.actions[0].steering_angle > 10.0  # counter-clockwise: the ring's bend, to the left


def test_an_open_straight_track_has_too_few_commands_for_many_actions() -> None:
    straight = load_track_by_name("Straight_track")
    assert not straight.closed
    two = racing_line_actions(straight, 2)  # from rest: full throttle, straight ahead
    assert all(a.steering_angle == 0.0 for a in two.actions)
    with pytest.raises(DrxError, match="distinct commands"):
        racing_line_actions(straight, 3)


def test_kmeans_keeps_fixed_centres_and_is_deterministic() -> None:
    rng = np.random.default_rng(3)
    blobs = np.vstack([rng.normal(c, 0.02, size=(40, 2)) for c in ((0.0, 0.0), (1.0, 1.0), (0.0, 1.0))])
    fixed = np.array([[0.5, 0.5]])
    centres = kmeans_with_fixed(blobs, fixed, 4, seed=7)
    assert np.array_equal(centres[0], fixed[0])
    assert np.array_equal(centres, kmeans_with_fixed(blobs, fixed, 4, seed=7))
    found = sorted(tuple(round(float(v), 1) for v in c) for c in centres[1:])
    assert found == [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
    assert math.isclose(float(np.max(np.abs(centres))), 1.0, abs_tol=0.05)
