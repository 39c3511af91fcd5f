"""Race settings and box placements: DeepRacer's ranges, spacing and lanes; bad input refused."""

from __future__ import annotations

import numpy as np
import pytest

from drx.errors import DrxError
from drx.settings.race import OBJECT_MIN_GAP, RaceConfig, parse_object_at, sensor_warnings
from drx.sim.objects import BOX_SIZE, box_places
from drx.sim.race_scene import RaceScene
from tests.sim._tracks import shared_track


def _check_layout(places: list[tuple[float, str]], n: int) -> None:
    fracs = [f for f, _ in places]
    assert len(places) == n
    assert all(0.07 - 1e-9 <= f <= 0.90 + 1e-9 for f in fracs)
    assert fracs == sorted(fracs)
    assert all(b - a >= OBJECT_MIN_GAP - 1e-9 for a, b in zip(fracs, fracs[1:], strict=False))
    assert {lane for _, lane in places} <= {"inside", "outside"}


@pytest.mark.parametrize("n", range(1, 7))
def test_fixed_layout_spreads_boxes_and_alternates_lanes(n: int) -> None:
    places = box_places(RaceConfig("object-avoidance", objects=n))
    _check_layout(places, n)
    assert [lane for _, lane in places] == [("inside", "outside")[i % 2] for i in range(n)]


@pytest.mark.parametrize("n", [1, 3, 6])
def test_random_layouts_keep_range_and_spacing(n: int) -> None:
    race = RaceConfig("object-avoidance", objects=n, randomize_objects=True)
    rng = np.random.default_rng(7)
    layouts = [box_places(race, rng) for _ in range(200)]
    for places in layouts:
        _check_layout(places, n)
    firsts = [p[0][0] for p in layouts]
    assert max(firsts) - min(firsts) > 0.01, "places change between episodes"
    assert {lane for p in layouts for _, lane in p} == {"inside", "outside"}
    # without an rng (evaluation) the layout is the fixed one
    assert box_places(race) == box_places(RaceConfig("object-avoidance", objects=n))


@pytest.mark.parametrize("name,reverse", [("reinvent_base", False), ("reinvent_base", True),
                                          ("reInvent2019_wide_cw", False)])  # fmt: skip
def test_boxes_sit_on_lane_centres_inside_or_outside(name: str, reverse: bool) -> None:
    base = shared_track(name)
    track = base.reversed() if reverse else base
    race = RaceConfig("object-avoidance", object_positions=((0.2, "inside"), (0.5, "outside")))
    scene = RaceScene(track, race)
    scene.reset(np.random.default_rng(0), 0.0, training=False)
    # the inside is left when the car drives counter-clockwise
    inside_is_left = track.direction == "ccw"
    for obj, (frac, lane) in zip(scene.objects, race.object_positions, strict=True):
        proj = track.project(obj.x, obj.y)
        assert proj.s == pytest.approx(frac * track.length, abs=0.02)
        assert proj.distance == pytest.approx(track.width_at(proj.s) / 4, abs=0.02)
        assert proj.left == ((lane == "inside") == inside_is_left)
        assert obj.size == BOX_SIZE
        heading = track.heading_at(proj.s)
        assert abs(np.angle(np.exp(1j * (obj.yaw - heading)))) < 0.2, "boxes line up with the lane"


def test_settings_round_trip_and_defaults() -> None:
    race = RaceConfig("object-avoidance", objects=2, object_positions=((0.6, "outer"), (0.2, "1")))
    assert race.object_positions == ((0.2, "inside"), (0.6, "outside"))
    assert RaceConfig.from_dict(race.to_dict()) == race
    assert RaceConfig("object-avoidance").objects == 3
    bots = RaceConfig("HEAD_TO_BOT", bots=2, bot_speed=1.5, bot_lane_change=True)
    assert bots.race_type == "head-to-bot" and RaceConfig.from_dict(bots.to_dict()) == bots
    assert RaceConfig("head-to-bot").bot_speed == 0.2 and RaceConfig("head-to-bot").bots == 3
    assert RaceConfig.from_dict(None) == RaceConfig() and RaceConfig().to_dict()["objects"] == 0
    assert parse_object_at("25:inside") == (0.25, "inside")
    assert parse_object_at("0.5,-1") == (0.5, "outside")


@pytest.mark.parametrize(
    "kwargs,words",
    [
        ({"race_type": "drag-race"}, "unknown"),
        ({"race_type": "object-avoidance", "objects": 0}, "out of range"),
        ({"race_type": "object-avoidance", "objects": 7}, "out of range"),
        ({"race_type": "object-avoidance", "object_positions": ((0.05, "inside"),)}, "between 7% and 90%"),
        ({"race_type": "object-avoidance", "object_positions": ((0.95, "inside"),)}, "between 7% and 90%"),
        ({"race_type": "object-avoidance", "object_positions": ((0.3, "inside"), (0.4, "out"))}, "overlap"),
        ({"race_type": "object-avoidance", "object_positions": ((0.3, "middle"),)}, "inside or outside"),
        ({"race_type": "object-avoidance", "objects": 3, "object_positions": ((0.3, "inside"),)}, "match"),
        ({"race_type": "object-avoidance", "object_positions": ((0.3, "inside"),), "randomize_objects": True},
         "randomize"),
        ({"race_type": "time-trial", "objects": 2}, "object-avoidance"),
        ({"race_type": "time-trial", "bots": 2}, "head-to-bot"),
        ({"race_type": "object-avoidance", "bot_speed": 1.0}, "head-to-bot"),
        ({"race_type": "head-to-bot", "bots": 5}, "out of range"),
        ({"race_type": "head-to-bot", "bots": 0}, "out of range"),
        ({"race_type": "head-to-bot", "bot_speed": 0.1}, "0.2-6 m/s"),
        ({"race_type": "head-to-bot", "bot_speed": 7.0}, "0.2-6 m/s"),
    ],
)  # fmt: skip
def test_bad_settings_are_one_sentence(kwargs: dict, words: str) -> None:
    with pytest.raises(DrxError) as err:
        RaceConfig(**kwargs)
    text = str(err.value)
    assert words in text and text.count(". ") == 0 and text.endswith(".")


def test_bad_object_at_and_unknown_keys() -> None:
    for text in ("25", "x:inside", "25:inside:extra"):
        with pytest.raises(DrxError):
            parse_object_at(text)
    with pytest.raises(DrxError, match="Unknown race setting"):
        RaceConfig.from_dict({"race_type": "head-to-bot", "speed": 2})


def test_sensor_warnings() -> None:
    h2b, oa = RaceConfig("head-to-bot"), RaceConfig("object-avoidance")
    assert sensor_warnings(h2b, "stereo", lidar=True) == []
    assert "no lidar" in sensor_warnings(h2b, "stereo", lidar=False)[0]
    assert sensor_warnings(oa, "camera", lidar=False) and not sensor_warnings(oa, "stereo", lidar=False)
    assert sensor_warnings(RaceConfig(), "camera", lidar=False) == []
