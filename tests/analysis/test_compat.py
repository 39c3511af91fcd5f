"""deepracer-utils (the community's log-analysis library, a test-only dependency) reads drx's model folders.

Install it with ``pip install deepracer-utils``; these tests are skipped without it.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from drx.analysis.data import load_evaluation_trace, load_run, model_folder
from drx.analysis.eval_trace import EvaluationTraceWriter
from drx.evaluate.time_trial import RaceRules, max_steps_for, run_time_trial
from drx.interchange.package.onnx_policy import load_policy
from drx.sim.env import DeepRacerEnv

from ._cli import ok_json

logs = pytest.importorskip(
    "deepracer.logs", reason="deepracer-utils is not installed (pip install deepracer-utils)"
)


def _training_agg(folder: Path) -> pd.DataFrame:
    log = logs.DeepRacerLog(model_folder=str(folder))
    log.load_training_trace()
    df = log.dataframe()
    df["new_reward"] = df["reward"]  # the library fills it itself, printing a note
    return logs.AnalysisUtils.simulation_agg(df)


def test_model_path_is_a_deepracer_for_cloud_folder(trained: str) -> None:
    folder = Path(ok_json("model", "path", trained)["path"])
    assert folder == model_folder(trained)
    log = logs.DeepRacerLog(model_folder=str(folder))
    assert log.fh.type == logs.LogFolderType.DRFC_MODEL_SINGLE_WORKERS
    log.load_training_trace()
    assert log.hyperparameters()["num_episodes_between_training"] == 5
    assert len(log.action_space()) == 10
    assert log.agent_and_network()["sensor_list"] == ["FRONT_FACING_CAMERA"]


def test_simulation_agg_steps_match_registry(trained: str) -> None:
    agg = _training_agg(model_folder(trained)).sort_values(["iteration", "episode"]).reset_index(drop=True)
    train = load_run(trained).phase("training")
    assert len(agg) == len(train) == 15
    assert list(agg["iteration"]) == list(train["iteration"])
    assert list(agg["steps"]) == list(train["steps"])


def test_simulation_agg_progress_matches_registry(trained: str) -> None:
    agg = _training_agg(model_folder(trained)).sort_values(["iteration", "episode"]).reset_index(drop=True)
    train = load_run(trained).phase("training")
    assert abs(agg["progress"].to_numpy() - train["progress"].to_numpy()).max() < 1e-3  # trace: 4 decimals


def test_training_starts_step_by_five_percent(trained: str) -> None:
    starts = load_run(trained).phase("training").sort_values(["iteration", "episode"])["start_fraction"]
    assert list(starts.round(6)) == [round((0.05 * i) % 1.0, 6) for i in range(len(starts))]


def test_evaluation_trace_read_by_deepracer_utils(trained: str, tmp_path: Path) -> None:
    run = load_run(trained)
    vehicle = run.model.vehicle()
    policy = load_policy(Path(run.checkpoints[run.checkpoints["is_best"]]["path"].iloc[0]), vehicle)
    rules = RaceRules(laps=2, max_resets=3, time_cap_minutes=0.5)
    env = DeepRacerEnv(
        track=run.model.track_name, vehicle=vehicle, mode="evaluation", max_steps=max_steps_for(rules)
    )
    folder = tmp_path / "model-folder"
    (folder / "model").mkdir(parents=True)  # an uploaded DRfC model folder: model/ and evaluations
    with EvaluationTraceWriter(env, folder, vehicle.continuous) as traced:
        result = run_time_trial(traced, lambda obs: policy.predict(obs, deterministic=True)[0], rules)
    assert traced.path.is_file() and traced.folder.name.startswith("evaluation-")

    log = logs.DeepRacerLog(model_folder=str(folder))
    log.load_evaluation_trace()
    df = log.dataframe()
    agg = logs.AnalysisUtils.simulation_agg(df, firstgroup="stream", is_eval=True).sort_values("episode")
    assert list(agg["episode"]) == [lap.lap - 1 for lap in result.laps]
    assert list(agg["steps"]) == [lap.steps for lap in result.laps]
    assert list(agg["progress"].round(2)) == [round(lap.progress, 2) for lap in result.laps]
    assert int(agg["off_track"].sum()) == result.off_track_count
    ours = load_evaluation_trace(folder)
    # one "pause" row per penalised reset (the car standing for its penalty), as DeepRacer logs it
    pauses = int((df["episode_status"] == "pause").sum())
    assert min(result.off_track_count, result.resets) <= pauses <= result.resets
    assert len(ours) == len(df) == result.steps + pauses
