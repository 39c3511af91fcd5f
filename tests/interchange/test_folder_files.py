"""The small files of DeepRacer's model folder: the track's name and direction, metrics, checkpoints."""

from __future__ import annotations

from pathlib import Path

import pytest

from drx.interchange.deepracer import folder_files as files
from drx.settings.race import RaceConfig


@pytest.mark.parametrize(
    ("route", "world", "clockwise"),
    [
        ("reInvent2019_wide_cw", "reInvent2019_wide", True),  # a direction variant: the key says which
        ("2022_april_open_ccw", "2022_april_open", False),
        ("reinvent_base", "reinvent_base", None),  # one-way: a key would send simapp to reinvent_base_ccw
        ("reInvent2019_wide", "reInvent2019_wide", None),  # the console's own route: its file as it is
        ("oval", "oval", None),
    ],
)
def test_world_name_and_direction(route: str, world: str, clockwise: bool | None) -> None:
    assert files.world_and_direction(route) == (world, clockwise)
    params = files.training_params("m", route, RaceConfig())
    assert params["WORLD_NAME"] == world and params.get("TRACK_DIRECTION_CLOCKWISE") == clockwise
    text = files.to_yaml(params)
    assert files.read_yaml(text, "t.yaml") == params
    if clockwise is not None:  # an unquoted YAML boolean: DeepRacer on AWS tests it with `=== true`
        assert f"TRACK_DIRECTION_CLOCKWISE: {str(clockwise).lower()}" in text


def test_race_settings_in_deepracers_names() -> None:
    boxes = files.training_params("m", "reinvent_base", RaceConfig("object-avoidance", objects=4))
    assert (boxes["RACE_TYPE"], boxes["NUMBER_OF_OBSTACLES"], boxes["OBSTACLE_TYPE"]) == (
        "OBJECT_AVOIDANCE", 4, "BOX_OBSTACLE"
    )  # fmt: skip
    bots = files.training_params("m", "reinvent_base", RaceConfig("head-to-bot", bots=2, bot_speed=0.8))
    assert (bots["RACE_TYPE"], bots["NUMBER_OF_BOT_CARS"], bots["BOT_CAR_SPEED"]) == ("HEAD_TO_BOT", 2, 0.8)


def test_metrics_number_episodes_and_trials_as_the_simulator() -> None:
    """simapp's s3_metrics.py: ``episode`` counts training episodes, ``trial`` restarts with each
    iteration's training, evaluation entries repeat the last training numbers; times in ms, one clock."""
    E = files.EpisodeMetric
    episodes = [
        E("training", 10.4, 50.0, "off_track", 2.0), E("training", 20.0, 100.0, "lap_complete", 10.0),
        E("evaluation", 30.0, 100.0, "lap_complete", 9.5),
        E("training", 5.0, 20.0, "reversed", 1.0),
    ]  # fmt: skip
    metrics = files.training_metrics(episodes)
    rows = metrics["metrics"]
    assert [(r["episode"], r["trial"], r["phase"]) for r in rows] == [
        (1, 1, "training"), (2, 2, "training"), (2, 2, "evaluation"), (3, 1, "training")
    ]  # fmt: skip
    assert [r["episode_status"] for r in rows] == ["Off track", "Lap complete", "Lap complete", "Reversed"]
    assert [r["start_time"] for r in rows] == [0, 2000, 12000, 21500]
    assert rows[1]["elapsed_time_in_milliseconds"] == 10000 and rows[0]["reward_score"] == 10
    assert metrics["version"] == 2.0 and metrics["best_model_metric"] == "progress"


def test_checkpoint_names() -> None:
    name = files.checkpoint_name(146, 139684)
    assert name == "146_Step-139684.ckpt" and files.CHECKPOINT_NAME.match(name)
    index = files.deepracer_checkpoints(name, 100.0, 10962.4)
    assert index["best_checkpoint"] == index["last_checkpoint"] == {
        "name": name, "avg_eval_metric": 100.0, "time_stamp": 10962.4
    }  # fmt: skip
    assert files.yaml_bool("false") is False and files.yaml_bool(True) and files.yaml_bool("True")


def test_start_options_in_deepracers_names() -> None:
    """ALTERNATE_DRIVING_DIRECTION, CHANGE_START_POSITION, ROUND_ROBIN_ADVANCE_DIST and
    START_POSITION_OFFSET as simapp's rollout_worker.py reads them, DeepRacer's defaults unless given;
    a route driven against its waypoints is REVERSE_DIR (simapp's track_data.py)."""
    plain = files.training_params("m", "reinvent_base", RaceConfig())
    assert (plain["CHANGE_START_POSITION"], plain["ALTERNATE_DRIVING_DIRECTION"]) == (True, False)
    assert (plain["ROUND_ROBIN_ADVANCE_DIST"], plain["START_POSITION_OFFSET"]) == (0.05, 0.0)
    assert "REVERSE_DIR" not in plain
    given = files.training_params("m", "reinvent_base", RaceConfig(), change_start=False,
                                  alternate_direction=True, round_robin_advance=0.1,
                                  start_position_offset=0.25, reverse=True)  # fmt: skip
    assert (given["CHANGE_START_POSITION"], given["ALTERNATE_DRIVING_DIRECTION"]) == (False, True)
    assert (given["ROUND_ROBIN_ADVANCE_DIST"], given["START_POSITION_OFFSET"], given["REVERSE_DIR"]) == (
        0.1, 0.25, True
    )  # fmt: skip
    text = files.to_yaml(given)
    assert "ROUND_ROBIN_ADVANCE_DIST: 0.1\n" in text and "REVERSE_DIR: true\n" in text
    assert files.read_yaml(text, "t.yaml") == given


def test_the_export_writes_the_models_options(tmp_path: Path) -> None:
    """``export._write_folder`` passes a model's options; a two-track model's WORLD_NAME is its first."""
    import numpy as np

    from drx.interchange.deepracer.export import _write_folder
    from drx.services.models import create_model
    from drx.vehicle import default_vehicle

    model = create_model("m", track=["A to Z Speedway", "oval"], direction="cw",
                         episodes={"round_robin_advance": 0.1, "start_position_offset": 0.5})  # fmt: skip
    reward = "def reward_function(params):\n    return 1.0\n"
    tensors = {"w": np.zeros(1, np.float32)}
    _write_folder(tmp_path / "out", model, default_vehicle(), "0_Step-0.ckpt", tensors, {}, reward)
    params = files.read_yaml((tmp_path / "out" / files.TRAINING_PARAMS).read_text(), "t.yaml")
    assert (params["WORLD_NAME"], params["TRACK_DIRECTION_CLOCKWISE"]) == ("reInvent2019_wide", True)
    assert (params["ROUND_ROBIN_ADVANCE_DIST"], params["START_POSITION_OFFSET"]) == (0.1, 0.5)
    assert (params["CHANGE_START_POSITION"], params["ALTERNATE_DRIVING_DIRECTION"]) == (True, False)
    assert "REVERSE_DIR" not in params


@pytest.mark.parametrize(
    ("version", "says"),
    [
        ("5", None),
        ("5.0", None),  # the console's spelling: version 5's car, nothing to say
        ("6", None),  # DeepRacer on AWS: simulator 6's car
        ("6.0", None),
        ("4.0", "names simulator version 4.0; drx has cars for 5 and 6 only, so it drives version 5's."),
        ("three", "names simulator version three; drx has cars for 5 and 6 only, so it drives version 5's."),
    ],
)
def test_an_import_says_which_car_stands_in_for_the_folders_simulator(version: str, says: str | None) -> None:
    from drx.interchange.deepracer.folder_import import _simulator_note

    note = _simulator_note(version)
    if says is None:
        assert note is None
    else:
        assert note is not None and says in note and note.count(".") >= 1
