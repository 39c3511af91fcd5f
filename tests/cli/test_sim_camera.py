"""``drx sim camera``: the camera frame at a place on a track, as a PNG for people."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from drx.sim.camera import CameraRenderer
from drx.sim.track import load_track

from .helpers import fails, ok, ok_json


def test_mono_frame_is_the_observation_enlarged(tmp_path: Path) -> None:
    png = tmp_path / "start.png"
    data = ok_json("sim", "camera", "oval", "--png", str(png))
    assert data["frame_shape"] == [120, 160] and data["cameras"] == 1 and data["png"] == str(png)
    picture = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    assert picture.shape == (480, 640) and picture.dtype == np.uint8
    # the picture is the env's observation at that pose, 4x enlarged
    track = load_track("oval")
    yaw = np.radians(data["heading"])
    rear = (data["x"] - 0.082 * np.cos(yaw), data["y"] - 0.082 * np.sin(yaw))
    frame = CameraRenderer(track).render(rear[0], rear[1], yaw)
    assert np.abs(picture[::4, ::4].astype(int) - frame).mean() < 1.0
    assert (
        "Wrote the camera frame" in ok("sim", "camera", "oval", "--png", str(tmp_path / "again.png")).stdout
    )


def test_stereo_panels_offset_and_scale(tmp_path: Path) -> None:
    png = tmp_path / "stereo.png"
    data = ok_json("sim", "camera", "oval", "--progress", "30", "--offset", "-0.2", "--heading", "10",
                   "--stereo", "--scale", "2", "--png", str(png))  # fmt: skip
    assert data["cameras"] == 2 and data["frame_shape"] == [120, 160, 2]
    picture = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    assert picture.shape == (240, 2 * 320 + 8)
    left, right = picture[:, :320], picture[:, 328:]
    assert (picture[:, 320:328] == 255).all()
    assert not np.array_equal(left, right), "the two lenses see from 6 cm apart"


def test_domain_randomization_is_seeded(tmp_path: Path) -> None:
    paths = [tmp_path / f"{name}.png" for name in ("a", "b", "c", "plain")]
    for path, seed in zip(paths[:3], ("1", "1", "2"), strict=True):
        data = ok_json("sim", "camera", "oval", "--domain-randomization", "--seed", seed, "--png", str(path))
        assert data["domain_randomization"]["seed"] == int(seed)
    ok("sim", "camera", "oval", "--png", str(paths[3]))
    a, b, c, plain = (cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in paths)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c) and not np.array_equal(a, plain)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--progress", "120"), ("--progress 120", "0-100")),
        (("--offset", "9"), ("--offset 9", "outside the walls")),
        (("--heading", "200"), ("--heading 200",)),
        (("--scale", "0"), ("--scale 0", "1-8")),
    ],
)
def test_bad_input_exits_2_and_writes_nothing(
    tmp_path: Path, args: tuple[str, ...], words: tuple[str, ...]
) -> None:
    png = tmp_path / "x.png"
    fails("sim", "camera", "oval", "--png", str(png), *args, contains=words)
    assert not png.exists()


def test_bad_track_and_file_name(tmp_path: Path) -> None:
    fails("sim", "camera", "nosuch", "--png", str(tmp_path / "x.png"), contains=("nosuch",))
    fails("sim", "camera", "oval", "--png", str(tmp_path / "x.jpg"), contains=(".png",))
    assert not list(tmp_path.glob("x.*"))
