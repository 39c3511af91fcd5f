"""``drx evaluate`` in object-avoidance and head-to-bot races, the crash counter and per-race leaderboards."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import imageio.v3 as iio
from sqlalchemy import update

from drx.evaluate import service
from drx.evaluate.scripted import LaneChangingDriver, centre_line_driver
from drx.evaluate.service import EvaluationRequest
from drx.registry import Model, session_scope
from drx.services import models as model_service
from drx.settings.race import RaceConfig

from ._cli import drx, drx_json, fails_unchanged
from ._models import model_with_checkpoint

BOXES = RaceConfig("object-avoidance", object_positions=((0.3, "inside"), (0.6, "outside")))


def _set_race(name: str, race: RaceConfig) -> None:
    with session_scope() as session:
        session.execute(update(Model).where(Model.name == name).values(race=race.to_dict()))


def test_evaluate_races_the_models_race_and_stores_it(tmp_path: Path) -> None:
    model_with_checkpoint("boxer")
    _set_race("boxer", BOXES)
    video = tmp_path / "boxes.gif"
    data = drx_json("evaluate", "boxer", "--laps", "1", "--max-resets", "0", "--collision-penalty", "3",
                    "--video", video)  # fmt: skip
    assert sum(1 for _ in iio.imiter(video)) > 1
    assert data["race"] == "object-avoidance, 2 boxes (placed)"
    assert data["race_settings"]["object_positions"] == [[0.3, "inside"], [0.6, "outside"]]
    assert data["rules"]["race_type"] == "object_avoidance" and data["rules"]["collision_penalty"] == 3.0
    assert {"crashes"} <= set(data["laps"][0]) and "crash_count" in data
    out = drx("eval", "show", data["id"]).stdout
    assert "object-avoidance, 2 boxes" in out and "crashes" in out


def test_race_options_override_the_models_race() -> None:
    model_with_checkpoint("racer")
    bots = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0", "--race-type", "head-to-bot",
                    "--bots", "2", "--bot-speed", "1.5", "--bot-lane-change")  # fmt: skip
    assert bots["race"] == "head-to-bot, 2 bots at 1.5 m/s, lane changes"
    boxes = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0",
                     "--race-type", "object-avoidance", "--object-at", "20:outside")  # fmt: skip
    assert boxes["race_settings"]["object_positions"] == [[0.2, "outside"]]
    _set_race("racer", BOXES)
    fewer = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0", "--objects", "4")
    assert fewer["race"] == "object-avoidance, 4 boxes (fixed)"
    plain = drx_json("evaluate", "racer", "--laps", "1", "--max-resets", "0", "--race-type", "time-trial")
    assert plain["race"] == "time-trial" and plain["rules"]["race_type"] == "time_trial"


def test_bad_race_input_exits_2_and_stores_nothing() -> None:
    model_with_checkpoint("racer")
    oa = ("--race-type", "object-avoidance")
    fails_unchanged("evaluate", "racer", *oa, "--objects", "7", contains="--objects 7")
    fails_unchanged("evaluate", "racer", *oa, "--objects", "0", contains="--objects 0")
    fails_unchanged("evaluate", "racer", *oa, "--object-at", "95:inside", contains="95%")
    fails_unchanged("evaluate", "racer", *oa, "--object-at", "25:middle", contains="middle")
    h2b = ("--race-type", "head-to-bot")
    fails_unchanged("evaluate", "racer", *h2b, "--bots", "5", contains="--bots 5")
    fails_unchanged("evaluate", "racer", *h2b, "--bot-speed", "9", contains="--bot-speed 9")
    fails_unchanged("evaluate", "racer", "--bots", "2", contains="need --race-type head-to-bot")
    fails_unchanged("evaluate", "racer", "--race-type", "drag", contains="--race-type drag")
    fails_unchanged("evaluate", "racer", *oa, "--collision-penalty", "-1", contains="--collision-penalty")
    fails_unchanged("evaluate", "racer", "--collision-penalty", "-0.5", contains="--collision-penalty")
    fails_unchanged("leaderboard", "--race-type", "drag", contains="--race-type drag")


def _scripted(model: str, driver: Any, race: dict[str, Any] | None = None) -> int:
    prepared = service.prepare(EvaluationRequest(model=model, laps=1, race=race))
    env = service.make_env(prepared)
    result = service.run(prepared, policy=driver(env), env=env)
    return service.store(prepared, result)


def _crash_once(env: Any) -> Any:
    into, past = centre_line_driver(env, 1.2), LaneChangingDriver(env, 1.2)
    base = env.unwrapped

    def drive(obs: Any) -> Any:
        return (past if base.crashed_once else into)(obs)

    base.crashed_once = False
    original = base.step

    def step(action: Any) -> Any:
        out = original(action)
        base.crashed_once |= out[4].get("episode_status") == "crashed"
        return out

    base.step = step
    return drive


def test_stored_crashes_and_the_traces_crash_counter() -> None:
    model_with_checkpoint("boxer")
    _set_race("boxer", BOXES)
    evaluation = _scripted("boxer", _crash_once)
    data = drx_json("eval", "show", evaluation)
    lap = data["laps"][0]
    assert data["crash_count"] == 1 and lap["crashes"] == 1 and lap["penalty_seconds"] == 5.0
    assert lap["status"] == "lap_complete" and data["off_track_count"] == 0
    folder = model_service.model_artifacts_dir("boxer")
    (trace,) = folder.glob("evaluation-*/evaluation-simtrace/0-iteration.csv")
    rows = list(csv.DictReader(trace.open()))
    counter = [int(r["obstacle_crash_counter"]) for r in rows]
    first = next(i for i, r in enumerate(rows) if r["episode_status"] == "crashed")
    assert set(counter[:first]) == {0} and set(counter[first:]) == {1}
    assert {r["episode"] for r in rows} == {"0"}  # the crash does not start a new episode


def test_each_race_type_has_its_own_leaderboard() -> None:
    model_with_checkpoint("plain")
    model_with_checkpoint("boxer")
    model_with_checkpoint("bold")
    _set_race("boxer", BOXES)
    _set_race("bold", BOXES)
    tt = _scripted("plain", lambda env: centre_line_driver(env, 1.0))
    clean = _scripted("boxer", lambda env: LaneChangingDriver(env, 1.0))
    crashed = _scripted("bold", _crash_once)
    board = drx_json("leaderboard", "--track", "oval", "--race-type", "time-trial")
    assert board["race_type"] == "time-trial" and [r["evaluation"] for r in board["rows"]] == [tt]
    boxes = drx_json("leaderboard", "--track", "oval", "--race-type", "object-avoidance")
    assert drx_json("leaderboard") == boxes  # by default the rules of the latest evaluation
    assert [r["evaluation"] for r in boxes["rows"]] == [clean, crashed]  # the crash's 5 s rank it second
    assert [r["crash_count"] for r in boxes["rows"]] == [0, 1]
    assert boxes["rows"][0]["race"] == "object-avoidance, 2 boxes (placed)"
    assert drx_json("leaderboard", "--race-type", "head_to_bot")["rows"] == []
    out = drx("leaderboard", "--track", "oval", "--race-type", "object-avoidance").stdout
    assert "boxer" in out and "plain" not in out
