"""The first hour's bad inputs: each exits 2 with one sentence naming the value and the fix,
and stores nothing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from .helpers import fails, fails_unchanged, ok, ok_json, write

RAISES = "def reward_function(params):\n    raise ValueError('boom')\n"
RETURNS_TEXT = (
    "def reward_function(params):\n"
    "    speed = params['speed']\n"
    "    if speed > 100:\n"
    "        return 1.0\n"
    "    return 'fast'\n"
)
MISSPELT = "def reward_function(params):\n    d = params['distance_from_centre']\n    return 1.0 - d\n"


def test_model_create_refuses_a_reward_that_fails_validation(tmp_path: Path) -> None:
    reward = write(tmp_path / "raises.py", RAISES)
    fails("reward", "validate", str(reward), contains="5 of 5")
    err = fails_unchanged(
        "model", "create", "m1", "--reward", str(reward),
        contains=("5 of 5", "raises.py, line 2", "ValueError: boom", "--force", "drx reward validate"),
    )  # fmt: skip
    assert "on oval" in err
    # --force keeps the old behaviour: the model is made (and training would fail on it)
    assert ok_json("model", "create", "m1", "--reward", str(reward), "--force")["reward_file"] == "raises.py"


def test_model_clone_checks_a_new_reward_on_the_clones_track(tmp_path: Path) -> None:
    ok("model", "create", "parent")
    reward = write(tmp_path / "raises.py", RAISES)
    fails_unchanged(
        "model", "clone", "parent", "kid", "--reward", str(reward), "--track", "kidney",
        contains=("on kidney", "--force"),
    )  # fmt: skip
    ok("model", "clone", "parent", "kid", "--reward", str(reward), "--force")
    ok("model", "clone", "parent", "kid2")  # the parent's reward is not run again


def test_a_bad_return_value_is_reported_at_its_return_line(tmp_path: Path) -> None:
    reward = write(tmp_path / "text.py", RETURNS_TEXT)
    err = fails("reward", "validate", str(reward), contains=("text.py, line 5", "returned 'fast'"))
    assert "line 1" not in err


def test_a_misspelt_params_key_suggests_the_right_one(tmp_path: Path) -> None:
    reward = write(tmp_path / "centre.py", MISSPELT)
    fails(
        "reward", "validate", str(reward),
        contains=("KeyError: 'distance_from_centre'", "did you mean 'distance_from_center'?"),
    )  # fmt: skip
    nothing_close = write(tmp_path / "far.py", "def reward_function(params):\n    return params['zzz']\n")
    assert "did you mean" not in fails("reward", "validate", str(nothing_close), contains="'zzz'")


def test_model_names_follow_the_same_rule_as_car_names() -> None:
    ok("garage", "add", "my_car")
    assert ok_json("model", "create", "my_model", "--car", "my_car")["name"] == "my_model"
    for bad in ("bad.name", "_lead", "x" * 65):
        car_err = fails_unchanged("garage", "add", bad, contains=repr(bad))
        model_err = fails_unchanged("model", "create", bad, contains=repr(bad))
        assert car_err.split("; ", 1)[1] == model_err.split("; ", 1)[1]  # the same rule, word for word


def test_a_folder_given_as_a_file_is_called_a_folder(tmp_path: Path) -> None:
    folder = tmp_path / "thing.py"
    folder.mkdir()
    for args in (
        ("reward", "validate", folder),
        ("model", "create", "m", "--reward", folder),
        ("track", "import", folder),
        ("garage", "add", "c", "--from", folder),
        ("garage", "add", "c", "--actions-file", folder),
    ):
        fails_unchanged(*map(str, args), contains=(str(folder), "is a folder, not a file"))
    # `drx model import` takes DeepRacer's model folder: a folder that is none says so
    fails_unchanged("model", "import", str(folder), contains=(str(folder), "is not a DeepRacer model folder"))
    fails_unchanged("track", "import", str(tmp_path / "absent.npy"), contains="does not exist")


def test_an_actions_file_that_is_not_an_action_list(tmp_path: Path) -> None:
    py = write(tmp_path / "x.py", "x = 1\n")
    fails_unchanged("garage", "add", "c", "--actions-file", str(py), contains=("x.py", "not an action list"))
    csv = write(tmp_path / "x.csv", "x = 1\n")
    err = fails_unchanged("garage", "add", "c", "--actions-file", str(csv), contains=("x.csv", "malformed"))
    assert "{{" not in err


def test_drx_home_pointing_at_a_file(tmp_path: Path) -> None:
    """Through the console script, as a user meets it: one sentence, no traceback."""
    home = write(tmp_path / "home", "not a folder\n")
    env = {**os.environ, "DRX_HOME": str(home)}
    env.pop("DRX_DATABASE_URL", None)
    for args in (["info"], ["model", "list"], ["model", "create", "m"]):
        command = [sys.executable, "-m", "drx.cli.main", *args]
        proc = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.startswith(f"Error: DRX_HOME {home} is not a folder"), proc.stderr
        assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert home.read_text() == "not a folder\n"


@pytest.mark.parametrize("below", ["sub", "sub/deeper"])
def test_drx_home_below_a_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, below: str) -> None:
    write(tmp_path / "file", "x")
    monkeypatch.setenv("DRX_HOME", str(tmp_path / "file" / below))
    fails("model", "list", contains=(f"{tmp_path / 'file'} is a file", "point DRX_HOME at a folder"))
