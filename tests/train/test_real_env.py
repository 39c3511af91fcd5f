"""A short real run on drx's simulator: DeepRacer's trace format, loadable by deepracer-utils."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.train.trace import TRACE_COLUMNS
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import compact_car, real_env_factory


@pytest.fixture(scope="module")
def trained_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A model folder after two iterations of 5 episodes on the built-in oval."""
    folder = tmp_path_factory.mktemp("real") / "model"
    car = compact_car()
    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters(episodes_per_iteration=5),
        stop=StopConditions(max_minutes=None, max_episodes=10),
        folder=folder,
        env_factory=real_env_factory(Path("oval"), car),
        eval_episodes=1,
        seed=0,
        threads=1,
    )
    result = Trainer(spec).run()
    assert result.stop_reason == "max_episodes" and result.last_iteration == 1
    return folder


def test_trace_has_deepracer_columns(trained_folder: Path) -> None:
    with (trained_folder / "training-simtrace" / "0-iteration.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == TRACE_COLUMNS
    assert sorted({int(r["episode"]) for r in rows}) == list(range(5))
    assert {r["done"] for r in rows} == {"True", "False"}
    assert float(rows[0]["track_len"]) > 0 and rows[-1]["episode_status"] != "in_progress"
    assert all(0 <= int(r["action"]) < 10 for r in rows)


def test_deepracer_utils_loads_the_model_folder(trained_folder: Path) -> None:
    logs = pytest.importorskip("deepracer.logs")
    log = logs.DeepRacerLog(model_folder=str(trained_folder))
    log.load_training_trace()
    df = log.dataframe()
    assert set(df["iteration"]) == {0, 1}
    assert df["unique_episode"].nunique() == 10
    assert log.hyperparameters()["num_episodes_between_training"] == 5
    assert log.action_space()[0]["steering_angle"] == 30.0
