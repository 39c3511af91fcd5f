"""The ONNX policy computes what the torch policy computes (within 1e-4) on camera frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drx.analysis.data import load_run
from drx.interchange.package.onnx_policy import (
    CAMERA_INPUT,
    LIDAR_INPUT,
    load_policy,
    policy_to_onnx,
    torch_outputs,
)
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.train.algorithms import build_algorithm
from drx.train.checkpoint import save_checkpoint
from drx.vehicle import Vehicle, default_vehicle, grid_actions

ort = pytest.importorskip("onnxruntime", reason="onnxruntime is not installed (pip install onnxruntime)")
TOLERANCE = 1e-4


def camera_frames(env: DeepRacerEnv, count: int = 6, seed: int = 0) -> tuple[np.ndarray, np.ndarray | None]:
    """Real frames from the env at several starts along the lap, plus random ones."""
    rng = np.random.default_rng(seed)
    cams, lidars = [], []
    for k in range(count):
        obs, _ = env.reset(options={"start": k / count})
        for _ in range(3):
            obs, *_ = env.step(env.action_space.sample())
        cams.append(obs["camera"] if isinstance(obs, dict) else obs)
        lidars.append(obs["lidar"] if isinstance(obs, dict) else None)
    shape = cams[0].shape
    cams += [rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(2)]
    lidar = None
    if lidars[0] is not None:
        lidars += [rng.uniform(0.15, 2.0, lidars[0].shape).astype(np.float32) for _ in range(2)]
        lidar = np.stack(lidars)
    return np.stack(cams), lidar


def run_onnx(model: object, frames: np.ndarray, lidar: np.ndarray | None) -> list[np.ndarray]:
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])  # type: ignore[attr-defined]
    feeds = {CAMERA_INPUT: frames}
    if lidar is not None:
        feeds[LIDAR_INPUT] = lidar
    return session.run(None, feeds)


def test_trained_checkpoint_matches_torch(trained: str) -> None:
    run = load_run(trained)
    vehicle = run.model.vehicle()
    policy = load_policy(Path(run.checkpoints["path"].iloc[-1]), vehicle)
    env = DeepRacerEnv(track=run.model.track_name, vehicle=vehicle, mode="evaluation")
    frames, _ = camera_frames(env)
    (probs,) = run_onnx(policy_to_onnx(policy, vehicle), frames, None)
    expected = torch_outputs(policy, frames)
    assert probs.shape == (len(frames), vehicle.n_actions)
    assert np.abs(probs - expected).max() < TOLERANCE
    assert np.allclose(probs.sum(axis=1), 1.0, atol=1e-5)
    assert (probs.argmax(axis=1) == policy.predict(frames, deterministic=True)[0]).all()


CASES = {
    "compact-discrete": ({}, "compact", "ppo"),
    "shallow-discrete": ({"actions": grid_actions(20, 3, 2, 1)}, "shallow", "ppo"),
    "deep-continuous": (
        {"continuous": True, "steering_range": (-25.0, 20.0), "speed_range": (0.5, 2.5)},
        "deep",
        "ppo",
    ),
    "sac-continuous": ({"continuous": True}, "compact", "sac"),
    "stereo": ({"sensor": "stereo"}, "compact", "ppo"),
    "lidar": ({"lidar": True}, "compact", "ppo"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_every_network_kind_matches_torch(case: str, tmp_path: Path) -> None:
    changes, network, algorithm = CASES[case]
    base = {"name": case}
    actions = () if changes.get("continuous") else default_vehicle().actions
    vehicle = Vehicle(**{**base, "actions": actions, **changes, "network": network})
    env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")
    model = build_algorithm(env, network, Hyperparameters.default(algorithm), seed=4)
    frames, lidar = camera_frames(env, count=3)
    saved = save_checkpoint(model, tmp_path / "last.zip", {"iteration": 0})
    policy = load_policy(saved, vehicle, algorithm)  # what the export reads: weights and the car
    expected = torch_outputs(model.policy, frames, lidar)
    assert np.abs(torch_outputs(policy, frames, lidar) - expected).max() < 1e-6
    outputs = run_onnx(policy_to_onnx(policy, vehicle), frames, lidar)
    assert np.abs(outputs[0] - expected).max() < TOLERANCE
    if vehicle.continuous:
        steer, speed = outputs[1][:, 0], outputs[1][:, 1]
        scaled = np.array([vehicle.scale_continuous(a) for a in expected])
        assert np.abs(outputs[1] - scaled).max() < 1e-3
        assert (steer >= vehicle.steering_range[0] - 1e-4).all() and (
            speed <= vehicle.speed_range[1] + 1e-4
        ).all()


@pytest.mark.parametrize("case", ["compact-discrete", "deep-continuous", "sac-continuous", "lidar"])
def test_openvino_runs_the_policy(case: str, tmp_path: Path) -> None:
    """OpenVINO, the DeepRacer car's inference engine, reads and runs the graph (skipped without it)."""
    ov = pytest.importorskip("openvino", reason="OpenVINO is not installed (pip install openvino)")
    changes, network, algorithm = CASES[case]
    actions = () if changes.get("continuous") else default_vehicle().actions
    vehicle = Vehicle(**{"name": case, "actions": actions, **changes, "network": network})
    env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")
    model = build_algorithm(env, network, Hyperparameters.default(algorithm), seed=4)
    frames, lidar = camera_frames(env, count=2)
    path = tmp_path / "policy.onnx"
    path.write_bytes(policy_to_onnx(model.policy, vehicle).SerializeToString())
    core = ov.Core()
    compiled = core.compile_model(core.read_model(str(path)), "CPU", {"INFERENCE_PRECISION_HINT": "f32"})
    feeds = {CAMERA_INPUT: frames, **({LIDAR_INPUT: lidar} if lidar is not None else {})}
    first = compiled(feeds)[compiled.outputs[0]]
    assert np.abs(first - torch_outputs(model.policy, frames, lidar)).max() < TOLERANCE
