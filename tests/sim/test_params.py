"""The params dict: every DeepRacer key, and the sample cases ``drx reward validate`` runs."""

from __future__ import annotations

import math

import pytest

from drx.sim.params import PARAM_KEYS, params_at_pose, sample_params_cases

from ._tracks import NAMES, shared_track

TYPES = {
    "all_wheels_on_track": bool, "x": float, "y": float, "heading": float, "distance_from_center": float,
    "is_left_of_center": bool, "is_offtrack": bool, "is_crashed": bool, "is_reversed": bool,
    "progress": float, "speed": float, "steering_angle": float, "steps": int, "track_length": float,
    "track_width": float, "waypoints": list, "closest_waypoints": list, "closest_objects": list,
    "objects_location": list, "objects_left_of_center": list, "objects_speed": list,
    "objects_heading": list, "objects_distance": list,
}  # fmt: skip


@pytest.mark.parametrize("name", NAMES)
def test_sample_cases_describe_their_situation(name: str) -> None:
    track = shared_track(name)
    cases = sample_params_cases(track)
    assert set(cases) == {"start", "mid_lap_left", "mid_lap_right", "off_track", "lap_complete"}
    for case in cases.values():
        assert set(case) == set(PARAM_KEYS)
        for key, kind in TYPES.items():
            assert type(case[key]) is kind, key
        assert case["closest_objects"] == [0, 0] and case["objects_location"] == []
        assert case["track_length"] == pytest.approx(track.length)
    start = cases["start"]
    assert start["steps"] == 1 and start["progress"] == 0.0
    assert start["closest_waypoints"] == [0, 1]
    assert start["distance_from_center"] == pytest.approx(0.0, abs=1e-9)
    assert start["all_wheels_on_track"] and not start["is_offtrack"]
    left, right = cases["mid_lap_left"], cases["mid_lap_right"]
    assert left["is_left_of_center"] and not right["is_left_of_center"]
    for case in (left, right):
        assert case["all_wheels_on_track"]
        assert case["distance_from_center"] > 0.25 * case["track_width"]
    off = cases["off_track"]
    assert off["is_offtrack"] and not off["all_wheels_on_track"]
    assert off["distance_from_center"] > off["track_width"] / 2
    assert cases["lap_complete"]["progress"] == 100.0
    assert cases["start"]["waypoints"][0] == tuple(track.center[0])


def test_wheels_are_checked_one_by_one() -> None:
    track = shared_track("reinvent_base")
    s = 3.0
    cx, cy = track.point_at(s)
    h = float(track.heading_at(s))
    half = track.width_at(s) / 2
    nx, ny = -math.sin(h), math.cos(h)
    # Reference point just inside the left border: the left wheels are off, the right ones on.
    x, y = cx + nx * (half - 0.02), cy + ny * (half - 0.02)
    p = params_at_pose(track, x, y, math.degrees(h))
    assert not p["all_wheels_on_track"] and not p["is_offtrack"]
    assert p["is_left_of_center"]
    assert p["distance_from_center"] == pytest.approx(half - 0.02, abs=2e-3)
