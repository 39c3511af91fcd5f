"""Training against a model (``--race-type head-to-model --opponent M``): the settings, bad input, and
real training episodes in which the opponent's checkpoint drives the other car."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from drx.evaluate.head_to_model import HeadToModelEnv, load_opponents, with_opponents
from drx.services import models as model_service
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track

from ._cli import drx, drx_json, fails_unchanged
from ._models import model_with_checkpoint


def _env(name: str, max_steps: int = 2000) -> HeadToModelEnv:
    """Model ``name``'s training env as ``drx train`` builds it (``drx.queue.train_job``)."""
    model = model_service.get_model(name)
    opponents = load_opponents(model.race_config())

    def make(clock: Any) -> DeepRacerEnv:
        return DeepRacerEnv(track=load_track(model.track_name), vehicle=model.vehicle(), mode="training",
                            max_steps=max_steps, clock=clock)  # fmt: skip

    env = with_opponents(make, opponents)
    assert isinstance(env, HeadToModelEnv)
    return env


def test_create_stores_the_opponents_and_show_and_clone_keep_them() -> None:
    model_with_checkpoint("rival")
    model_with_checkpoint("second")
    drx(
        "model", "create", "me", "--race-type", "head-to-model", "--opponent", "rival", "--opponent", "second"
    )
    shown = drx_json("model", "show", "me")
    ids = [model_service.get_model(n).id for n in ("rival", "second")]
    assert shown["race"]["race_type"] == "head-to-model" and shown["race"]["opponents"] == ids
    assert shown["opponents"] == ["rival", "second"]
    table = drx("model", "show", "me").stdout
    assert "head-to-model, 2 opponents" in table and "rival, second" in table
    drx("model", "clone", "me", "me2")
    assert drx_json("model", "show", "me2")["opponents"] == ["rival", "second"]
    drx("model", "clone", "me", "me3", "--race-type", "head-to-model", "--opponent", "rival")
    assert drx_json("model", "show", "me3")["opponents"] == ["rival"]
    drx("model", "clone", "me", "alone", "--race-type", "time-trial")
    assert "opponents" not in drx_json("model", "show", "alone")
    assert drx_json("model", "show", "rival")["race"]["race_type"] == "time-trial"


@pytest.mark.parametrize(
    ("args", "contains"),
    [
        (("--opponent", "rival"), "--opponent needs --race-type head-to-model"),
        (("--race-type", "head-to-model"), "takes 1 to 3 --opponent, not 0"),
        (("--race-type", "head-to-model", "--opponent", "ghost"), "No model named 'ghost'"),
        (("--race-type", "head-to-model", "--opponent", "untrained"), "'untrained' has no checkpoint"),
        (("--race-type", "head-to-model", "--opponent", "me"), "cannot be its own opponent"),
        (("--race-type", "head-to-model", "--opponent", "elsewhere"), "on 'reinvent_base', not 'oval'"),
        (("--race-type", "head-to-model", "--opponent", "clockwise"), "drives 'oval' cw, the model ccw"),
        (("--race-type", "head-to-model", "--opponent", "rival", "--direction", "cw"), "the model cw"),
        (("--race-type", "head-to-model", "--opponent", "rival", "--opponent", "rival"), "named twice"),
        (("--race-type", "head-to-model", *["--opponent", "rival"] * 2, *["--opponent", "x"] * 2), "not 4"),
        (("--race-type", "head-to-model", "--opponent", "rival", "--alternate-direction"), "one direction"),
        (("--race-type", "head-to-model", "--opponent", "rival", "--track", "oval", "--track",
          "reinvent_base"), "trains on one track, not 2"),
    ],
)  # fmt: skip
def test_bad_opponents_exit_2_with_one_sentence_and_store_nothing(
    args: tuple[str, ...], contains: str
) -> None:
    model_with_checkpoint("rival")
    model_with_checkpoint("elsewhere", track="reinvent_base")
    model_with_checkpoint("clockwise", direction="cw")
    model_service.create_model("untrained", network="compact")
    fails_unchanged("model", "create", "me", *args, contains=contains)


def test_clone_checks_the_opponents_again() -> None:
    model_with_checkpoint("rival")
    drx("model", "create", "me", "--race-type", "head-to-model", "--opponent", "rival")
    fails_unchanged("model", "clone", "me", "me2", "--track", "reinvent_base", contains="trained on 'oval'")
    fails_unchanged("model", "clone", "me", "me2", "--race-type", "head-to-model", "--opponent", "me2",
                    contains="cannot be its own opponent")  # fmt: skip


def test_the_opponent_drives_and_the_reward_params_list_it() -> None:
    """The opponent's checkpoint drives its car among the model's episodes; the model's params carry it
    as simapp gives an agent another agent; its camera sees it."""
    model_with_checkpoint("rival")
    drx("model", "create", "me", "--race-type", "head-to-model", "--opponent", "rival")
    env = _env("me")
    opp = env.opponent_envs[0]
    _obs, _info = env.reset(seed=3)
    env.action_space.seed(3)  # the model's random actions too: the same episodes on every run
    start = (opp.car_state.x, opp.car_state.y)
    seen = 0
    for _ in range(300):
        obs, _r, term, trunc, info = env.step(env.action_space.sample())
        p = info["params"]
        st = opp.car_state
        mid = 0.5 * opp.car.wheelbase  # the listed place is the car's body centre
        cx, cy = st.x + mid * math.cos(st.yaw), st.y + mid * math.sin(st.yaw)
        assert p["objects_location"][0] == pytest.approx([cx, cy], abs=1e-6)
        assert p["objects_speed"] == [pytest.approx(st.speed)] and p["objects_heading"] == [
            pytest.approx(st.yaw)
        ]
        assert p["objects_distance"][0] == pytest.approx(env._s[1], abs=1e-6)
        assert p["closest_objects"] == [0, 0] and isinstance(p["objects_left_of_center"][0], bool)
        empty = env.base.camera.render(env.base.car_state.x, env.base.car_state.y, env.base.car_state.yaw)
        seen += int(np.abs(np.asarray(obs, dtype=int)[..., 0] - empty.astype(int)).sum() > 1000)
        if term or trunc:
            env.reset()
    assert env.opponent_steps > 200  # it drove (standing out penalties aside)
    assert math.dist(start, (opp.car_state.x, opp.car_state.y)) > 0.1
    assert seen > 0  # the model's camera saw the opponent's car
    env.close()


def _one_behind_the_other(env: HeadToModelEnv, gap: float, opponent_ahead: bool) -> None:
    """Put the opponent ``gap`` m ahead of (or behind) the model's car on its line, heading its way."""
    st, car = env.base.car_state, env.base.car
    sign = 1.0 if opponent_ahead else -1.0
    x = st.x + car.reference_offset * math.cos(st.yaw) + sign * gap * math.cos(st.yaw)
    y = st.y + car.reference_offset * math.sin(st.yaw) + sign * gap * math.sin(st.yaw)
    env._obs[0], _ = env.opponent_envs[0].reset(
        options={"pose": {"x": x, "y": y, "heading": math.degrees(st.yaw)}}
    )
    env._place_opponents()
    env._place_agent()


@pytest.mark.parametrize("opponent_ahead", [True, False])
def test_a_crash_costs_the_car_behind(opponent_ahead: bool) -> None:
    """The model's car driving into the opponent ahead has crashed (its episode ends); the opponent
    driving into it from behind stands its collision penalty and the model's car drives on, not
    crashed (simapp's ``judge_action``)."""
    model_with_checkpoint("rival")
    drx("model", "create", "me", "--race-type", "head-to-model", "--opponent", "rival")
    env = _env("me")
    env.reset(seed=0, options={"start": 0.0})  # the oval's start straight
    _one_behind_the_other(env, 0.6, opponent_ahead)
    speeds = [a.speed if a.steering_angle == 0 else -1.0 for a in env.base.vehicle.actions]
    fast, slow = int(np.argmax(speeds)), int(np.argmin([s if s > 0 else 99.0 for s in speeds]))
    env.drivers.act = lambda obs: [slow if opponent_ahead else fast for _ in obs]  # type: ignore[method-assign]
    statuses = []
    for _ in range(40):
        _o, _r, term, _t, info = env.step(fast if opponent_ahead else slow)
        statuses.append(str(info["episode_status"]))
        if term or env.opponent_collisions:
            break
    if opponent_ahead:
        assert statuses[-1] == "crashed" and info["params"]["is_crashed"] and env.opponent_collisions == 0
    else:
        assert "crashed" not in statuses and not info["params"]["is_crashed"] and not term
        assert env.opponent_collisions == 1 and env._pause[0] == pytest.approx(env.rules.collision_penalty)
    env.close()


@pytest.mark.parametrize("workers", ["1", "2"])
def test_training_against_a_model_runs_a_real_job(tmp_path: Path, workers: str) -> None:
    """``drx train`` of a head-to-model model, a few hundred steps, in the trainer's process or in two
    rollout workers: every training step's params list the opponent, driving (the reward function
    logs what it is given); the trainer's evaluations are time trials (no objects)."""
    model_with_checkpoint("rival")
    log = tmp_path / "params.log"
    reward = tmp_path / "logs_the_rival.py"
    reward.write_text(
        "def reward_function(params):\n"
        "    keys = ('objects_location', 'objects_speed', 'objects_heading', 'objects_distance',\n"
        "            'objects_left_of_center')\n"
        "    n = {len(params[k]) for k in keys}\n"
        "    speed = params['objects_speed'][0] if params['objects_speed'] else 0.0\n"
        f"    with open({str(log)!r}, 'a') as f:\n"
        "        f.write(f\"{sorted(n)} {speed} {params['closest_objects']}\\n\")\n"
        "    return 1.0\n"
    )
    model_service.create_model("me", network="compact", reward=reward, race={"race_type": "head-to-model",
                               "opponents": ["rival"]}, hyperparameters={"episodes_per_iteration": 5},
                               stop_conditions={"max_episodes": 5})  # fmt: skip
    env = {**os.environ, "DRX_TORCH_THREADS": "1"}
    command = [sys.executable, "-m", "drx.cli.main", "train", "me", "--json", "--rollout-workers", workers,
               "--seed", "0"]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    assert '"status": "succeeded"' in done.stdout
    lines = log.read_text().splitlines()
    with_rival = [line for line in lines if line.startswith("[1] ")]
    alone = [line for line in lines if line.startswith("[0] ")]
    assert len(with_rival) + len(alone) == len(lines)
    assert len(with_rival) >= 100  # the training steps (5 episodes)
    assert alone  # the trainer's evaluation laps: time trials
    # it drives: a frozen car would show 0 m/s throughout; standing its penalties it shows 0 for a while
    # (a full-suite run under load saw it moving on 115 of 253 steps)
    assert sum(float(line.split()[1]) > 0.1 for line in with_rival) > len(with_rival) // 4
    assert all(line.endswith("[0, 0]") for line in with_rival)


def test_its_evaluation_is_a_time_trial_and_head_to_model_is_no_evaluation() -> None:
    model_with_checkpoint("rival")
    model_with_checkpoint("me", race={"race_type": "head-to-model", "opponents": ["rival"]})
    result = drx_json("evaluate", "me", "--laps", "1", "--time-cap-minutes", "0.2", "--seed", "1")
    assert result["rules"]["race_type"] == "time_trial"
    fails_unchanged("evaluate", "me", "--race-type", "head-to-model", contains="drx race")
