"""Trial videos decode, with one frame per step and reset plus the final hold."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from drx.errors import DrxError
from drx.evaluate.scripted import centre_line_driver
from drx.evaluate.time_trial import RaceRules, max_steps_for, run_time_trial
from drx.evaluate.video import TrialVideo, frames_expected
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track
from drx.vehicle import Vehicle

CAR = Vehicle(name="scripted", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_video_decodes_with_the_right_frame_count(tmp_path: Path, suffix: str) -> None:
    rules = RaceRules(laps=1, time_cap_minutes=0.05)  # 3 s of driving: 45 steps
    track = load_track("oval")
    env = DeepRacerEnv(track=track, vehicle=CAR, mode="evaluation", max_steps=max_steps_for(rules))
    path = tmp_path / f"trial{suffix}"
    with TrialVideo(
        path, track, title="test", racing_line=track.center, best_lap=5.0, laps=1, size=(320, 240)
    ) as v:
        result = run_time_trial(env, centre_line_driver(env, 2.0), rules, observer=v)
    expected = frames_expected(result.steps, result.resets, gif=suffix == ".gif")
    assert v.frames_written == expected
    frames = list(iio.imiter(path))
    assert len(frames) == expected
    assert frames[0].ndim == 3 and frames[0].shape[2] == 3
    assert not np.array_equal(frames[0], frames[len(frames) // 2])  # the car moved


def test_video_refuses_other_formats(tmp_path: Path) -> None:
    with pytest.raises(DrxError, match=".mp4 or .gif"):
        TrialVideo(tmp_path / "x.avi", load_track("oval"))


def test_banner_goes_where_the_car_is_not() -> None:
    """Issue 14: the final banner covered the car."""
    from drx.evaluate.video import _banner

    img = np.zeros((480, 640, 3), np.uint8)
    top, bottom = _banner(img.copy(), "LAP 1  27.126 s", (30, 150, 40))
    assert top < 240 < bottom  # nothing in the way: the middle (usually the infield)
    for car_row in (240, 345, 130):
        top, bottom = _banner(img.copy(), "LAP 1  27.126 s", (30, 150, 40), car=(320.0, car_row), reach=12)
        assert not top - 12 <= car_row <= bottom + 12, (car_row, top, bottom)


def test_video_names_its_lines_and_scales_its_gauges_to_the_car(tmp_path: Path) -> None:
    track = load_track("oval")
    video = TrialVideo(tmp_path / "x.mp4", track, racing_line=track.center, top_speed=1.0, max_steering=30)
    img = video.renderer.background.copy()
    video._draw_legend(img)
    h, w = img.shape[:2]
    strip = img[h - 30 :, w // 3 : 2 * w // 3]
    assert np.any(np.all(strip == np.array([120, 220, 255]), axis=2)), "no racing-line swatch"
    view = type("View", (), {"speed": 1.0, "steering": 0.0})()
    gauges = video.renderer.background.copy()
    video._draw_gauges(gauges, view)  # type: ignore[arg-type]
    row = gauges[h - 10 - 6]
    green = np.all(row == np.array([60, 200, 90]), axis=1)
    assert green[10 + w // 3 - 2], "1 m/s fills a 1 m/s car's speed bar"
