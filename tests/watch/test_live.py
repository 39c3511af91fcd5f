"""The pose files jobs write for ``drx watch``: content, atomic replacement, rate, clean-up."""

from __future__ import annotations

import json
import math
import os
import subprocess
import time
from pathlib import Path

import numpy as np

from drx.sim.env import DeepRacerEnv
from drx.vehicle import Vehicle, default_vehicle
from drx.watch.live import GONE_SECONDS, LivePoseWriter, is_live, latest_pose, live_dir, read_poses


def test_the_pose_file_follows_the_car_and_goes_with_its_env(tmp_path: Path) -> None:
    env = LivePoseWriter(DeepRacerEnv(track="oval", mode="training"), tmp_path, "training", hz=1000.0)
    env.reset(seed=0)
    env.flush()
    first = latest_pose(tmp_path)
    assert first is not None and first["mode"] == "training" and first["track"] == "oval"
    assert first["steps"] == 0 and first["episode"] == 0 and first["status"] == "prepare"
    assert first["stereo"] is False
    for _ in range(10):
        time.sleep(0.002)  # past the 1 ms interval: every step writes
        env.step(np.int64(5))
    env.flush()
    pose = latest_pose(tmp_path)
    assert pose is not None and pose["steps"] == 10 and pose["status"] == "in_progress"
    state = env.unwrapped.car_state
    assert math.isclose(pose["x"], state.x) and math.isclose(pose["yaw"], state.yaw)
    assert pose["progress"] > first["progress"]  # the car drove along the track
    assert is_live(pose)
    files = list(live_dir(tmp_path).iterdir())
    assert [f.name for f in files] == [env.path.name]  # one file, no temporary left behind
    env.close()
    assert not env.path.exists() and latest_pose(tmp_path) is None


def test_writes_are_limited_to_the_rate(tmp_path: Path) -> None:
    env = LivePoseWriter(DeepRacerEnv(track="oval", mode="evaluation"), tmp_path, "evaluation", hz=2.0)
    env.reset(seed=0)
    for _ in range(20):  # well within half a second: no write after the reset's
        env.step(np.int64(5))
    env.flush()
    assert latest_pose(tmp_path)["steps"] == 0
    time.sleep(0.55)
    env.step(np.int64(5))
    env.flush()
    pose = latest_pose(tmp_path)
    assert pose["steps"] == 21
    assert [row[0] for row in pose["path"]] == list(range(22))  # the episode's steps, reset's included
    assert pose["path"][-1][1:] == [round(pose["x"], 4), round(pose["y"], 4)]
    env.close()


def test_readers_take_the_newest_and_skip_broken_or_old_files(tmp_path: Path) -> None:
    folder = live_dir(tmp_path)
    folder.mkdir(parents=True)
    now = time.time()
    (folder / "1-training.json").write_text(json.dumps({"time": now - 1.0, "mode": "training"}))
    (folder / "1-evaluation.json").write_text(json.dumps({"time": now - 0.2, "mode": "evaluation"}))
    (folder / "2-training.json").write_text(json.dumps({"time": now - GONE_SECONDS - 1, "mode": "x"}))
    (folder / "3-training.json").write_text('{"time": ')  # caught half-written by another writer
    poses = read_poses(tmp_path, now)
    assert [p["mode"] for p in poses] == ["evaluation", "training"]
    assert not is_live(poses[1], now + 5.0) and is_live(poses[0], now)
    assert latest_pose(tmp_path / "nothing") is None


def test_a_training_job_s_envs_write_poses() -> None:
    from drx.queue import lifecycle
    from drx.queue.train_job import build_spec
    from drx.services.models import create_model, model_artifacts_dir

    model = create_model("trained", track="oval", network="compact")
    spec = build_spec(lifecycle.enqueue_training("trained"), model)
    for mode in ("training", "evaluation"):
        env = spec.env_factory(mode)
        assert isinstance(env, LivePoseWriter)
        env.reset(seed=0)
        env.flush()
        assert latest_pose(model_artifacts_dir("trained"))["mode"] == mode
        env.close()


def test_an_evaluation_race_writes_poses() -> None:
    from drx.evaluate import service
    from drx.evaluate.scripted import centre_line_driver
    from drx.evaluate.service import EvaluationRequest
    from drx.services.models import model_artifacts_dir
    from tests.evaluate._models import model_with_checkpoint

    model_with_checkpoint("racer")
    prepared = service.prepare(EvaluationRequest(model="racer", laps=1))
    env = service.make_env(prepared)
    folder = model_artifacts_dir("racer")
    seen: list[dict] = []

    def observer(view: object) -> None:
        time.sleep(0.002)  # a lap lasts 0.5 s or more: several of the writer's 15-a-second files
        pose = latest_pose(folder)
        if pose is not None:
            seen.append(pose)

    result = service.run(prepared, policy=centre_line_driver(env, 1.0), observer=observer, env=env)
    assert result.laps_completed == 1
    assert seen and {p["mode"] for p in seen} == {"evaluation"}
    # the race went round: the files followed the car along the lap (how far depends on the writer's
    # thread on a busy machine, so no fixed share of the lap is asked for)
    progress = [p["progress"] for p in seen]
    assert len(set(progress)) >= 2 and max(progress) > progress[0]
    assert latest_pose(folder) is None  # the file went with the race's env


def test_the_picture_sticks_to_one_env_while_it_writes(tmp_path: Path) -> None:
    from drx.watch.frames import FrameSource

    folder = live_dir(tmp_path)
    folder.mkdir(parents=True)
    now = time.time()

    def put(pid: int, mode: str, t: float) -> None:
        pose = {"time": t, "pid": pid, "source": f"{pid}-0-{mode}", "mode": mode, "x": 1.0, "y": 1.0,
                "yaw": 0.0, "path": []}  # fmt: skip
        (folder / f"{pid}-{mode}.json").write_text(json.dumps(pose))

    source = FrameSource(tmp_path, "oval")
    put(1, "training", now - 0.1)
    put(2, "training", now - 0.2)
    assert source.choose(now)["pid"] == 1
    source.poll()
    put(2, "training", now)  # another rollout worker is newer, but the drawn one still writes
    assert source.choose(now)["pid"] == 1
    put(3, "evaluation", now + 0.05)  # the drawn one went quiet (the update, then evaluation): switch
    assert source.choose(now + 1.0)["pid"] == 3


def test_a_stereo_car_s_pose_says_stereo(tmp_path: Path) -> None:
    car = Vehicle(name="s", actions=default_vehicle().actions, sensor="stereo")
    env = LivePoseWriter(DeepRacerEnv(track="oval", vehicle=car, mode="evaluation"), tmp_path, "evaluation")
    env.reset(seed=0)
    env.flush()
    pose = latest_pose(tmp_path)
    assert pose is not None and pose["stereo"] is True
    env.close()


def test_a_new_writer_clears_what_dead_processes_left(tmp_path: Path) -> None:
    """kill -9 leaves a pose file and maybe a half-written temporary; the next writer removes them."""
    dead = subprocess.run(["sh", "-c", "echo $$"], capture_output=True, text=True, check=True)
    pid = int(dead.stdout)  # a process that has ended
    folder = live_dir(tmp_path)
    folder.mkdir(parents=True)
    left = [folder / f"{pid}-0-training.json", folder / f".{pid}-0-training.json.tmp"]
    for path in left:
        path.write_text("{")
    alive = folder / f"{os.getppid()}-0-evaluation.json"  # a live process's file stays
    alive.write_text("{}")
    env = LivePoseWriter(DeepRacerEnv(track="oval", mode="training"), tmp_path, "training")
    try:
        assert not any(p.exists() for p in left)
        assert alive.exists()
    finally:
        env.close()
