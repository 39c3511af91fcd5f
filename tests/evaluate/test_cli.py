"""``drx evaluate``, ``drx eval list|show``, ``drx leaderboard``, ``drx track best-lap`` end to end."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import imageio.v3 as iio
import pytest

from drx.evaluate import service
from drx.evaluate.scripted import centre_line_driver
from drx.evaluate.service import EvaluationRequest
from drx.queue.dispatch import run_job
from drx.queue.evaluate_job import enqueue_evaluation
from drx.registry import Job, session_scope
from drx.services import models as model_service
from drx.sim.dynamics import CarParams

from ._cli import drx, drx_json, fails_unchanged, invoke, snapshot
from ._models import model_with_checkpoint


def test_evaluate_stores_and_shows_a_trial(tmp_path: Path) -> None:
    model_with_checkpoint("racer")
    video = tmp_path / "trial.mp4"
    data = drx_json("evaluate", "racer", "--laps", "2", "--max-resets", "1", "--checkpoint", "last",
                    "--video", video)  # fmt: skip
    assert data["model"] == "racer" and data["track"] == "oval" and data["checkpoint_iteration"] == 3
    assert data["rules"] == {"race_type": "time_trial", "laps": 2, "off_track_penalty": 2.0, "max_resets": 1,
                             "time_cap_minutes": 20.0, "collision_penalty": 5.0,
                             "min_laps": None}  # fmt: skip
    assert data["race"] == "time-trial" and data["crash_count"] == 0
    assert data["best_lap"] > 0 and data["laps"], data
    lap = data["laps"][0]
    assert set(lap) >= {"time", "progress", "status", "off_track_count", "penalty_seconds", "resets"}
    assert data["off_track_count"] == sum(x["off_track_count"] for x in data["laps"])
    frames = sum(1 for _ in iio.imiter(video))
    assert frames > 15 and data["video"] == str(video)
    # the trial's step trace, laid out as deepracer-for-cloud lays out an evaluation
    folder = model_service.model_artifacts_dir("racer")
    traces = list(folder.glob("evaluation-*/evaluation-simtrace/0-iteration.csv"))
    assert len(traces) == 1
    rows = traces[0].read_text().splitlines()
    assert rows[0].startswith("episode,steps,X,Y,yaw") and len(rows) > 15
    assert {r.split(",")[0] for r in rows[1:]} == {str(i) for i in range(len(data["laps"]))}
    # stored: list and show agree with what evaluate printed
    listed = drx_json("eval", "list")
    assert [e["id"] for e in listed] == [data["id"]]
    shown = drx_json("eval", "show", data["id"])
    assert shown["laps"] == data["laps"] and shown["total_time"] == data["total_time"]
    assert "Laps" in drx("eval", "show", data["id"]).stdout
    assert "racer" in drx("eval", "list", "--model", "racer").stdout


def test_direction_reverses_the_loop() -> None:
    model_with_checkpoint("racer")
    data = drx_json("evaluate", "racer", "--direction", "cw", "--laps", "1", "--max-resets", "0")
    assert data["direction"] == "reverse"
    same = drx_json("evaluate", "racer", "--direction", "ccw", "--laps", "1", "--max-resets", "0")
    assert same["direction"] == "default"  # the oval already runs counter-clockwise
    assert [r["evaluation"] for r in drx_json("leaderboard", "--track", "oval", "--reverse")["rows"]] == [
        data["id"]
    ]


def test_a_deepracer_track_by_its_display_name() -> None:
    """--track takes the console's name; the evaluation, the list and the leaderboard use the route id."""
    model_with_checkpoint("racer")
    args = ("--laps", "1", "--max-resets", "0", "--time-cap-minutes", "0.3")
    data = drx_json("evaluate", "racer", "--track", "Oval Track", *args)
    assert data["track"] == "Oval_track"
    assert [e["id"] for e in drx_json("eval", "list", "--track", "oval track")] == [data["id"]]
    assert drx_json("leaderboard", "--track", "Oval Track")["track"] == "Oval_track"


def test_a_seed_repeats_a_trial_and_is_stored(monkeypatch: pytest.MonkeyPatch) -> None:
    """Steps vary in length as DeepRacer's do; --seed (or DRX_EVALUATION_SEED) repeats a trial."""
    model_with_checkpoint("racer")
    args = ("evaluate", "racer", "--laps", "2", "--max-resets", "2", "--time-cap-minutes", "0.5")
    first = drx_json(*args, "--seed", "5")
    again = drx_json(*args, "--seed", "5")
    assert first["laps"] == again["laps"] and first["total_time"] == again["total_time"]
    shown = drx_json("eval", "show", first["id"])
    assert shown["seed"] == 5
    monkeypatch.delenv("DRX_EVALUATION_SEED")
    fresh = drx_json(*args)
    assert isinstance(drx_json("eval", "show", fresh["id"])["seed"], int)
    monkeypatch.setenv("DRX_EVALUATION_SEED", "soon")
    fails_unchanged(*args, contains="DRX_EVALUATION_SEED='soon' is not a whole number")


def test_bad_input_exits_2_and_stores_nothing(tmp_path: Path) -> None:
    model_with_checkpoint("racer")
    model_service.create_model("untrained")
    fails_unchanged("evaluate", "nobody", contains="No model named 'nobody'")
    fails_unchanged("evaluate", "untrained", contains="has no checkpoint")
    fails_unchanged("evaluate", "racer", "--track", "atlantis", contains="No track named 'atlantis'")
    fails_unchanged("evaluate", "racer", "--laps", "0", contains="--laps 0")
    fails_unchanged("evaluate", "racer", "--laps", "101", contains="--laps 101")
    fails_unchanged("evaluate", "racer", "--off-track-penalty", "-1", contains="--off-track-penalty")
    fails_unchanged("evaluate", "racer", "--checkpoint", "7", contains="iteration 7")
    fails_unchanged("evaluate", "racer", "--direction", "up", contains="--direction")
    fails_unchanged("evaluate", "racer", "--seed", "-1", contains="--seed -1 is out of range")
    fails_unchanged("evaluate", "racer", "--video", tmp_path / "x.avi", contains=".mp4 or .gif")
    fails_unchanged("eval", "show", "42", contains="No evaluation 42")
    fails_unchanged("leaderboard", "--rank", "fastest", contains="--rank")
    fails_unchanged("leaderboard", "--track", "nosuch", contains="No track named 'nosuch'")


def test_a_track_the_car_cannot_steer_round_races_without_a_best_lap() -> None:
    """The best lap is a reference beside the result: a car too stiff for it still races (as in
    DeepRacer's simulator), and the result says why it has no best lap."""
    drx("garage", "add", "stiff", "--max-steering", "1")
    model_with_checkpoint("stiff-racer", car="stiff")
    result = drx_json("evaluate", "stiff-racer", "--track", "hairpin", "--laps", "1", "--max-resets", "0")
    assert result["best_lap"] is None and "cannot drive track hairpin" in result["best_lap_missing"]


def test_ctrl_c_stores_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    model_with_checkpoint("racer")
    calls = {"n": 0}

    def interrupted(*args: Any, **kwargs: Any) -> None:
        observer = args[3] if len(args) > 3 else kwargs.get("observer")
        if observer is not None:
            calls["n"] += 1
        raise KeyboardInterrupt

    monkeypatch.setattr(service, "run_time_trial", interrupted)
    before = snapshot()
    video = tmp_path / "cut.mp4"
    result = invoke("evaluate", "racer", "--video", video)
    assert result.exit_code == 130
    assert "nothing was stored" in result.output
    assert snapshot() == before
    assert not video.exists()


def _scripted(model: str, speed: float, laps: int = 3, penalty: float = 2.0) -> int:
    prepared = service.prepare(EvaluationRequest(model=model, laps=laps, off_track_penalty=penalty))
    env = service.make_env(prepared)
    result = service.run(prepared, policy=centre_line_driver(env, speed), env=env)
    return service.store(prepared, result)


def test_leaderboard_ranks_stored_results() -> None:
    model_with_checkpoint("slow")
    model_with_checkpoint("fast")
    slow, fast = _scripted("slow", 0.6), _scripted("fast", 1.0)
    for mode in ("best-lap", "average-lap", "total-time"):
        board = drx_json("leaderboard", "--track", "oval", "--rank", mode)
        assert [r["model"] for r in board["rows"]] == ["fast", "slow"], mode
        assert [r["evaluation"] for r in board["rows"]] == [fast, slow]
        top = board["rows"][0]
        assert top["laps"] == "3/3" and top["car"] == "default" and top["best_lap_ratio"] >= 1.0
        assert top["action_space"].startswith("10 actions")
    assert drx_json("leaderboard")["track"] == "oval"
    assert "fast" in drx("leaderboard", "--track", "oval").stdout


def test_detached_evaluation_runs_as_a_job() -> None:
    model_with_checkpoint("racer")
    job = enqueue_evaluation(EvaluationRequest(model="racer", laps=1, max_resets=0))
    assert (job.kind, job.status) == ("evaluate", "queued")
    outcome = run_job(job.id)
    assert outcome.status == "succeeded" and outcome.evaluation_id is not None
    evaluation = outcome.evaluation_id
    with session_scope() as session:
        row = session.get(Job, job.id)
        assert row is not None and row.status == "succeeded"
    assert service.get_evaluation(evaluation)["laps"][0]["resets"] == 0


def test_best_lap_command(tmp_path: Path) -> None:
    drx("garage", "add", "quick", "--max-speed", "4")
    png = tmp_path / "best.png"
    data = drx_json("track", "best-lap", "oval", "--car", "quick", "--png", png)
    car = CarParams.for_simulator("6")  # the command's car: simulator 6's, where DeepRacer races now
    assert data["simulator"] == "6"
    assert 4.0 < data["flying_lap_time"] < data["lap_time"]  # the timed lap starts from rest
    assert data["limits"]["top_speed"] == pytest.approx(car.steady_speed(4.0))
    assert png.read_bytes()[:4] == b"\x89PNG"
    slow = drx_json("track", "best-lap", "oval")  # DeepRacer's default car: 1 m/s, top-speed bound
    assert slow["flying_lap_time"] == pytest.approx(slow["line_length"] / car.steady_speed(1.0), rel=1e-3)
    text = tmp_path / "best.txt"
    fails_unchanged("track", "best-lap", "oval", "--png", text, contains=f"--png {text} must end in .png")
    assert not text.exists()


def test_detached_evaluation_runs_under_a_worker_and_job_run() -> None:
    from drx.queue.worker import Worker

    model_with_checkpoint("racer")
    status = model_service.get_model("racer").status
    first = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0", "--detach")["job"]
    Worker(poll_seconds=0.2, exit_when_idle=True, on_event=lambda line: None).run()
    second = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0", "--detach")["job"]
    assert "succeeded" in drx("job", "run", str(second)).stdout
    with session_scope() as session:
        rows = [session.get_one(Job, job_id) for job_id in (first, second)]
        assert [(r.status, r.stop_reason[:11]) for r in rows] == [("succeeded", "evaluation ")] * 2
    assert model_service.get_model("racer").status == status


def test_leaderboard_and_eval_list_fit_80_columns(monkeypatch: pytest.MonkeyPatch) -> None:
    """Whole model names, the columns that fit, and --wide for the rest (issue 14)."""
    monkeypatch.setenv("COLUMNS", "80")
    names = ("demo-20261122-173900-long-name", "another_model_name_2026")
    for name in names:
        model_with_checkpoint(name)
        _scripted(name, 1.0)
    for command in (("leaderboard", "--track", "oval"), ("eval", "list")):
        out = drx(*command).stdout
        assert max(len(line) for line in out.splitlines()) <= 80, out
        assert all(name in out for name in names), out
        assert "…" not in out and "--wide shows every column" in out, out
        wide = drx(*command, "--wide").stdout
        assert "date" in wide and "hidden" not in wide, wide
