"""Head-to-head races (``drx race``): DeepRacer's grid, collisions, the end, the stored board, brackets.

Real races on the oval: the cars are models with a checkpoint (``_models``), or scripted drivers
where a test needs a collision to happen (a fast car behind a slow one).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
import pytest

from drx.analysis.data import load_evaluation_trace
from drx.evaluate import race_service, service
from drx.evaluate.bracket import Match, bracket_order, first_round, seeds, tree_diagram
from drx.evaluate.head_to_head import HeadToHeadRules, RaceView, SharedClock, run_head_to_head
from drx.evaluate.race_store import rate
from drx.evaluate.scripted import centre_line_driver
from drx.evaluate.service import EvaluationRequest
from drx.services import models as model_service
from drx.sim.noise import StepNoise
from drx.sim.objects import LaneFrame
from drx.train.trace import TRACE_COLUMNS

from ._cli import drx, drx_json, fails_unchanged
from ._models import model_with_checkpoint


def _scripted_race(
    speeds: list[float], rules: HeadToHeadRules, observer: Any = None
) -> tuple[Any, list[Any]]:
    """A race of models ``m0, m1, ...`` driven by centre-line followers at ``speeds`` [m/s]."""
    names = [f"m{i}" for i in range(len(speeds))]
    for name in names:
        if not model_service.list_models() or name not in {m.name for m in model_service.list_models()}:
            model_with_checkpoint(name)
    prepared = race_service.prepare(names, "oval", rules, seed=1)
    clock = SharedClock(StepNoise(prepared.racers[0].car, np.random.default_rng(1)))
    envs = race_service.make_envs(prepared, clock)
    drivers = [centre_line_driver(env, v) for env, v in zip(envs, speeds, strict=True)]
    result = run_head_to_head(envs, drivers, names, prepared.rules, clock, seed=1, observer=observer)
    return result, envs


def test_the_grid_is_deepracers_alternating_lanes_and_stagger() -> None:
    views: list[RaceView] = []
    _result, envs = _scripted_race([1.0, 1.0, 1.0], HeadToHeadRules(laps=1, time_cap_minutes=0.05),
                                   views.append)  # fmt: skip
    track = envs[0].track
    frame = LaneFrame(track)
    start = views[0].cars  # before the first step
    places = []
    for car in start:
        p = track.project(car.x, car.y)  # the rear axle, on its lane
        side = "inside" if car.index % 2 else "outside"  # racecar_1 inner, racecar_0 and _2 outer
        assert p.left == (frame.lane_of(side, p.s) > 0)
        assert 0.15 * p.width < p.distance < 0.35 * p.width  # halfway between centre line and border
        places.append(p.s)
    gaps = [(places[i] - places[i + 1]) % track.length for i in range(2)]
    assert gaps == pytest.approx([0.75, 0.75], abs=0.03)  # START_POS_OFFSET along the centre line
    assert len(envs[0].params["objects_location"]) == 2  # every car has the others in its params
    last = start[2]  # racecar_2, on racecar_0's lane 1.5 m behind it, sees it from the start
    empty = envs[2].camera.render(last.x, last.y, last.yaw)
    assert np.abs(last.observation[:, :, 0].astype(int) - empty.astype(int)).sum() > 1000


def test_the_lidar_of_a_car_behind_sees_the_car_ahead() -> None:
    from dataclasses import replace

    from drx.services.garage import add_vehicle
    from drx.vehicle import default_vehicle

    add_vehicle(replace(default_vehicle("lidar-car"), sensor="stereo", lidar=True))
    model_with_checkpoint("ahead")
    model_with_checkpoint("behind", car="lidar-car")
    rules = HeadToHeadRules(laps=1, time_cap_minutes=0.01, start_position_offset=1.0)
    prepared = race_service.prepare(["ahead", "behind"], "oval", rules, seed=3)
    views: list[RaceView] = []
    clock = SharedClock(StepNoise(prepared.racers[0].car, np.random.default_rng(3)))
    envs = race_service.make_envs(prepared, clock)
    still = [lambda obs, e=e: _stand(e) for e in envs]
    run_head_to_head(envs, still, ["ahead", "behind"], prepared.rules, clock, seed=3, observer=views.append)
    lidar = views[0].cars[1].observation["lidar"]  # 64 ranges, beam 32 straight ahead
    assert lidar.shape == (64,) and min(lidar[26:39]) < 1.5  # the car ahead, 1 m on, one lane over
    assert lidar[0] == pytest.approx(2.0)  # nothing behind it


def _stand(env: Any) -> Any:
    """The action of the slowest straight command (the cars stay near the grid)."""
    from drx.evaluate.scripted import to_action

    return to_action(env.vehicle, 0.0, 0.0)


def test_a_collision_is_one_for_both_and_costs_the_car_behind() -> None:
    rules = HeadToHeadRules(laps=1, time_cap_minutes=1.5)
    events: list[tuple[int, str]] = []

    def watch(view: RaceView) -> None:
        events.extend((c.index, str(c.event)) for c in view.cars if c.event)

    result, envs = _scripted_race([0.5, 3.0], rules, watch)  # m1 starts behind and drives into m0
    slow, fast = sorted(result.cars, key=lambda c: c.index)
    assert fast.collisions == slow.collisions >= 1
    assert fast.crashes == fast.collisions and slow.crashes == 0  # only the car behind is penalised
    assert fast.penalty_seconds == pytest.approx(5.0 * fast.crashes)
    assert (1, "crashed") in events and (0, "collision") in events
    assert result.winner.name == "m0" and result.ended == "any_finished"
    assert slow.time == pytest.approx(slow.lap_times[0])
    # the slow car's camera saw the fast one (its scene has it, moving)
    assert envs[0].params["objects_speed"][0] >= 0.0 and len(envs[0].scene.rows()) == 1


def test_done_condition_all_waits_for_every_car_and_parks_the_finished() -> None:
    views: list[RaceView] = []
    rules = HeadToHeadRules(laps=1, done_condition="all", collision_penalty=0.0)
    result, _envs = _scripted_race([1.5, 1.0], rules, views.append)
    assert result.ended == "all_finished"
    assert [c.status for c in result.cars] == ["finished", "finished"]
    assert result.cars[0].time is not None and result.cars[1].time is not None
    assert result.cars[0].time < result.cars[1].time == pytest.approx(result.race_time)
    assert any(c.status == "parked" for v in views for c in v.cars)  # the first home left the track
    anyone = _scripted_race([1.5, 1.0], HeadToHeadRules(laps=1, collision_penalty=0.0))[0]
    assert anyone.ended == "any_finished" and [c.status for c in anyone.cars] == ["finished", "racing"]


def test_elo_rating_is_zero_sum_and_rewards_beating_the_stronger() -> None:
    r = rate([["a", "b"]])
    assert r["a"] == pytest.approx(1516.0) and r["b"] == pytest.approx(1484.0)
    r = rate([["a", "b"], ["a", "b"], ["c", "a", "b"]])
    assert sum(r.values()) == pytest.approx(4500.0)
    assert r["c"] - 1500 > r["a"] - rate([["a", "b"], ["a", "b"]])["a"] + 16  # c beat the stronger a
    assert bracket_order(8) == [1, 8, 4, 5, 2, 7, 3, 6]
    matches = first_round(seeds(["x", "y", "z"], {"z": 7.0, "y": 8.0}))
    assert [(m.a, m.b) for m in matches] == [("z", None), ("y", "x")]  # the best seed gets the bye
    matches[0].winner, matches[1].winner = "z", "x"
    tree = tree_diagram([matches, [Match(2, "z", "x", "x", 1)]])
    assert tree == ["z ─┐", "   ├─ z ─┐", "- ─┘     │", "         ├─ x", "y ─┐     │", "   ├─ x ─┘", "x ─┘"]


def test_drx_race_prints_stores_traces_and_ranks(tmp_path: Path) -> None:
    for name in ("fast", "steady"):
        model_with_checkpoint(name)
    video = tmp_path / "race.gif"
    data = drx_json("race", "fast", "steady", "--track", "oval", "--laps", "1", "--seed", "5",
                    "--time-cap-minutes", "1", "--video", video)  # fmt: skip
    assert data["seed"] == 5 and data["rules"]["race_type"] == "head_to_head"
    assert data["rules"]["done_condition"] == "any" and data["rules"]["start_position_offset"] == 0.75
    assert sorted(c["place"] for c in data["cars"]) == [1, 2]
    assert sum(1 for _ in iio.imiter(video)) > 10
    for car in data["cars"]:
        trace = Path(car["trace"]) / "evaluation-simtrace" / "0-iteration.csv"
        with trace.open() as f:
            rows = list(csv.reader(f))
        assert rows[0] == list(TRACE_COLUMNS) and len(rows) > 10
        frame = load_evaluation_trace(model_service.model_artifacts_dir(car["name"]))
        assert len(frame) == len(rows) - 1  # drx analyze's reader takes the race's trace
    again = drx_json("race", "fast", "steady", "--track", "oval", "--laps", "1", "--seed", "5",
                     "--time-cap-minutes", "1")  # fmt: skip
    assert [c["time"] for c in again["cars"]] == [c["time"] for c in data["cars"]]  # the seed repeats it
    board = drx_json("leaderboard", "--race-type", "head-to-head", "--track", "oval")
    assert board["races"] == 2 and [r["races"] for r in board["rows"]] == [2, 2]
    assert sum(r["rating"] for r in board["rows"]) == pytest.approx(3000.0, abs=0.2)
    winner = data["cars"][0]["name"]
    assert board["rows"][0]["model"] == winner and board["rows"][0]["wins"] == 2
    assert board["rows"][0]["last"].startswith("1st of 2 vs ")
    out = drx("race", "fast", "steady", "--track", "oval", "--laps", "1", "--time-cap-minutes", "1").stdout
    assert "Race 3 on oval" in out and "Ended by" in out


def test_a_bracket_seeds_by_time_trial_and_prints_the_tree() -> None:
    for name in ("b1", "b2", "b3"):
        model_with_checkpoint(name)
    prepared = service.prepare(EvaluationRequest(model="b3", laps=1))  # only b3 has a time-trial lap
    env = service.make_env(prepared)
    service.store(prepared, service.run(prepared, policy=centre_line_driver(env, 1.0), env=env))
    data = drx_json("race", "--bracket", "b1", "b2", "b3", "--track", "oval", "--laps", "1",
                    "--time-cap-minutes", "0.5", "--seed", "2")  # fmt: skip
    assert data["seeds"] == ["b3", "b1", "b2"]  # timed first, then as given
    first, final = data["rounds"]
    assert [(m["a"], m["b"]) for m in first] == [("b3", None), ("b1", "b2")]  # the best seed's bye
    assert first[0]["race"] is None and first[0]["winner"] == "b3" and first[1]["race"] is not None
    assert {final[0]["a"], final[0]["b"]} == {"b3", first[1]["winner"]}
    assert data["winner"] == final[0]["winner"] == final[0]["result"]["cars"][0]["name"]
    board = drx_json("leaderboard", "--race-type", "head-to-head", "--track", "oval")
    assert board["races"] == 2
    out = drx("race", "--bracket", "b1", "b2", "--track", "oval", "--laps", "1", "--time-cap-minutes",
              "0.5").stdout  # fmt: skip
    assert "Final" in out and "Winner:" in out and "beat" in out and "├─" in out  # the tree


def test_bad_races_exit_2_and_store_nothing() -> None:
    model_with_checkpoint("one")
    model_with_checkpoint("two")
    model_service.create_model("untrained", network="compact")
    model_service.create_model("elsewhere", network="compact", track="reinvent_base")
    for name in ("x1", "x2", "x3"):
        model_with_checkpoint(name)
    fails_unchanged("race", "one", "one", "--track", "oval", contains="named twice")
    fails_unchanged("race", "one", "--track", "oval", contains="2 to 4 models, not 1")
    fails_unchanged("race", "one", "two", "x1", "x2", "x3", "--track", "oval", contains="not 5")
    fails_unchanged("race", "one", "untrained", "--track", "oval", contains="no checkpoint")
    fails_unchanged("race", "one", "elsewhere", "--track", "oval", contains="trained on 'reinvent_base'")
    fails_unchanged("race", "one", "ghost", "--track", "oval", contains="ghost")
    fails_unchanged("race", "one", "two", contains="--track")
    fails_unchanged("race", "one", "two", "--track", "oval", "--done-condition", "first",
                    contains="any or all")  # fmt: skip
    fails_unchanged("race", "one", "two", "--track", "oval", "--start-position-offset", "2",
                    contains="--start-position-offset")  # fmt: skip
    fails_unchanged("race", "one", "two", "--track", "oval", "--video", "race.avi", contains=".mp4")
    fails_unchanged("race", "--bracket", "one", "--track", "oval", contains="2 to 16")


def test_drx_watch_draws_every_car_of_a_race() -> None:
    """Each car's live pose file (what `drx watch MODEL` reads) carries the other cars, and the watch
    page's picture draws them."""
    import time

    from drx.watch.frames import Scenery
    from drx.watch.live import read_poses

    for name in ("w1", "w2", "w3"):
        model_with_checkpoint(name)
    rules = HeadToHeadRules(laps=1, time_cap_minutes=0.3)
    prepared = race_service.prepare(["w1", "w2", "w3"], "oval", rules, seed=4)
    seen: list[dict[str, Any]] = []

    def watch(view: RaceView) -> None:
        if len(seen) < 3 and view.race_time > 1.0:
            time.sleep(0.15)  # the pose writer's thread writes at most 15 times a second
            seen.extend(read_poses(model_service.model_artifacts_dir("w2"))[:1])

    race_service.run(prepared, observer=watch)
    assert seen, "no live pose file while the race ran"
    pose = seen[-1]
    assert len(pose["bots"]) == 2 and pose["boxes"] == []  # w1 and w3, drawn as cars
    scenery = Scenery("oval")
    top_with_cars, _camera = scenery.draw(pose, [])
    top_alone, _camera = scenery.draw({**pose, "bots": []}, [])
    assert top_with_cars != top_alone


def test_the_envs_multi_car_resets_keep_the_car_where_it_is() -> None:
    """``next_lap`` drives on over the line (same pose and speed, progress from the line again);
    ``resume`` + ``in_place`` stops the car where it stands, its progress kept."""
    from drx.sim.env import DeepRacerEnv

    env = DeepRacerEnv(track="oval", mode="evaluation", deterministic=True)
    driver = centre_line_driver(env, 1.0)
    obs, _info = env.reset(options={"start": 0.0})
    status = ""
    while status != "lap_complete":
        obs, _r, _t, _tr, info = env.step(driver(obs))
        status = str(info["episode_status"])
    before = env.car_state.copy()
    _obs, info = env.reset(options={"next_lap": True})
    after = env.car_state
    assert (after.x, after.y, after.yaw, after.speed) == (before.x, before.y, before.yaw, before.speed)
    assert 0.0 <= env.distance < 0.2 and info["steps"] == 0 and info["progress"] < 1.0
    for _ in range(30):
        obs, _r, _t, _tr, info = env.step(driver(obs))
    progress, here = info["progress"], (env.car_state.x, env.car_state.y)
    _obs, info = env.reset(options={"resume": True, "in_place": True, "pause": 5.0})
    assert (env.car_state.x, env.car_state.y) == here and env.car_state.speed == 0.0
    assert info["episode_status"] == "pause" and info["progress"] == pytest.approx(progress, abs=0.5)
