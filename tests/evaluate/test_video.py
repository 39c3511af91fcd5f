"""Trial videos decode, with one frame per step and reset plus the final hold."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from drx.errors import DrxError
from drx.evaluate.scripted import centre_line_driver
from drx.evaluate.trial import RaceRules, max_steps_for, run_time_trial
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
