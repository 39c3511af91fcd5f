"""``drx garage add|list|show|rm``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drx.config import project_root

from .helpers import fails_unchanged, ok, ok_json, write


def test_add_show_list_rm() -> None:
    ok(
        "garage",
        "add",
        "racer",
        "--max-speed",
        "3",
        "--speed-levels",
        "3",
        "--steering-levels",
        "7",
        "--lidar",
    )
    cars = ok_json("garage", "list")
    assert [c["name"] for c in cars] == ["default", "racer"]
    racer = ok_json("garage", "show", "racer")
    assert len(racer["action_space"]) == 21
    assert racer["action_space_type"] == "discrete"
    assert racer["sensor"] == ["FRONT_FACING_CAMERA", "LIDAR"]
    assert racer["neural_network"] == "DRX_COMPACT_NETWORK"  # drx's default network
    assert set(racer["action_space"][0]) >= {"steering_angle", "speed"}
    assert ok_json("garage", "rm", "racer") == {"removed": "racer"}
    assert [c["name"] for c in ok_json("garage", "list")] == ["default"]
    assert ok_json("garage", "add", "again", "--max-speed", "2")["action_space"][1]["speed"] == 2


def test_show_prints_the_action_table_like_deepracer() -> None:
    out = ok("garage", "show", "default").stdout
    assert "action" in out and "steering angle" in out and "speed" in out
    lines = [line for line in out.splitlines() if line.strip().startswith("│")]
    assert len(lines) == 10
    first = [cell.strip() for cell in lines[0].split("│")[1:4]]
    last = [cell.strip() for cell in lines[-1].split("│")[1:4]]
    assert first == ["0", "30", "0.5"] and last == ["9", "-30", "1"]
    default = ok_json("garage", "show", "default")
    assert default["action_space"][0] == {"steering_angle": 30.0, "speed": 0.5, "index": 0}


def test_continuous_stereo_deep() -> None:
    ok("garage", "add", "smooth", "--continuous", "--max-steering", "20", "--min-speed", "1",
       "--max-speed", "3", "--sensor", "stereo", "--network", "deep")  # fmt: skip
    meta = ok_json("garage", "show", "smooth")
    assert meta["action_space"] == {
        "steering_angle": {"low": -20.0, "high": 20.0},
        "speed": {"low": 1.0, "high": 3.0},
    }
    assert meta["action_space_type"] == "continuous"
    assert meta["sensor"] == ["STEREO_CAMERAS"] and meta["neural_network"] == "DEEP_CONVOLUTIONAL_NETWORK"
    assert "continuous" in ok("garage", "show", "smooth").stdout


def test_custom_actions_file(tmp_path: Path) -> None:
    path = write(
        tmp_path / "actions.json", json.dumps([{"steering_angle": a, "speed": 1.5} for a in (-20, 0, 20)])
    )
    ok("garage", "add", "three", "--actions-file", str(path))
    assert [a["steering_angle"] for a in ok_json("garage", "show", "three")["action_space"]] == [-20, 0, 20]


@pytest.mark.parametrize("sample", sorted((project_root() / "garage").glob("*.toml")), ids=lambda p: p.stem)
def test_add_from_every_sample_toml(sample: Path) -> None:
    ok("garage", "add", "sample", "--from", str(sample))
    assert ok_json("garage", "show", "sample")["name"] == "sample"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--max-steering", "45"), ("45", "1 to 30")),
        (("--steering-levels", "4"), ("4", "3, 5 or 7")),
        (("--max-speed", "5"), ("5", "0.1 to 4")),
        (("--speed-levels", "4"), ("4", "1, 2 or 3")),
        (("--sensor", "radar"), ("radar", "camera")),
        (("--network", "resnet"), ("resnet", "shallow")),
        (("--continuous", "--min-speed", "0.1"), ("0.1", "0.5")),
        (("--continuous", "--min-steering", "-40"), ("-40", "30")),
        (("--continuous", "--speed-levels", "2"), ("--continuous", "--speed-levels")),
        (("--from", "nowhere.toml"), ("nowhere.toml",)),
        (("--from", "garage/default.toml", "--lidar"), ("--from", "--lidar")),
    ],
)
def test_bad_add_options_exit_2_and_change_nothing(args: tuple[str, ...], words: tuple[str, ...]) -> None:
    fails_unchanged("garage", "add", "car", *args, contains=words)


def test_bad_names_and_duplicates(tmp_path: Path) -> None:
    ok("garage", "add", "car")
    fails_unchanged("garage", "add", "car", contains="already exists")
    fails_unchanged("garage", "add", "default", contains="built in")
    fails_unchanged("garage", "add", "bad name!", contains="not allowed")
    fails_unchanged("garage", "show", "nope", contains=("nope", "default, car"))
    fails_unchanged("garage", "rm", "nope", contains="nope")
    fails_unchanged("garage", "rm", "default", contains="built in")
    bad = write(tmp_path / "bad.toml", "sensor = [")
    fails_unchanged("garage", "add", "x", "--from", str(bad), contains="bad.toml")
    few = write(tmp_path / "few.csv", "0,1\n")
    fails_unchanged("garage", "add", "x", "--actions-file", str(few), contains=("1 actions", "2 to 30"))
