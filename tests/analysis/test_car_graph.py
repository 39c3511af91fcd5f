"""The car's ``model.pb``: every network x sensor x action-space type runs in OpenVINO as torch does.

OpenVINO (the DeepRacer car's inference engine; ``pip install openvino``) reads each graph
through its TensorFlow frontend, compiles it for the CPU and is fed real drx camera frames
one at a time, float32 NHWC in 0..255, as the car's inference node feeds them.
"""

from __future__ import annotations

import numpy as np
import pytest
from torch import nn

from drx.errors import DrxError
from drx.interchange.car.car_graph import (
    PPO_OUTPUT,
    SAC_OUTPUT,
    input_names,
    policy_to_graph,
)
from drx.interchange.car.car_package import INFERENCE_INPUT_KEYS
from drx.interchange.car.tf_graph import MO_2021_TF_OPS, GraphBuilder, parse_graph, tensor_value
from drx.interchange.package.onnx_policy import torch_outputs
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.train.algorithms import build_algorithm
from drx.vehicle import Vehicle, default_vehicle

ov = pytest.importorskip("openvino", reason="OpenVINO is not installed (pip install openvino)")
TOLERANCE = 1e-4
NETWORKS = ("shallow", "deep", "compact")
SENSORS = {  # name -> (Vehicle changes, env lidar_type, DeepRacer sensor of the lidar)
    "camera": ({}, "lidar", None),
    "stereo": ({"sensor": "stereo"}, "lidar", None),
    "lidar": ({"lidar": True}, "lidar", "LIDAR"),
    "sector-lidar": ({"lidar": True}, "sector", "SECTOR_LIDAR"),
}
ACTION_SPACES = {  # name -> (Vehicle changes, algorithm)
    "discrete": ({}, "ppo"),
    "continuous": ({"continuous": True, "steering_range": (-25.0, 20.0), "speed_range": (0.5, 2.5)}, "ppo"),
    "continuous-sac": ({"continuous": True}, "sac"),
}


def frames(env: DeepRacerEnv, count: int = 3, seed: int = 0) -> list:
    """Real observations at several starts along the lap, then one with random pixels."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        obs, _ = env.reset(options={"start": k / count})
        for _ in range(2):
            obs, *_ = env.step(env.action_space.sample())
        out.append(obs)
    noisy = {**obs} if isinstance(obs, dict) else obs.copy()
    cam = noisy["camera"] if isinstance(noisy, dict) else noisy
    cam[...] = rng.integers(0, 256, cam.shape, dtype=np.uint8)
    return [*out, noisy]


def compiled(graph: bytes, tmp_path) -> object:
    path = tmp_path / "model.pb"
    path.write_bytes(graph)
    core = ov.Core()
    return core.compile_model(core.read_model(str(path)), "CPU", {"INFERENCE_PRECISION_HINT": "f32"})


def feed(model: object, names: dict[str, str], obs: object) -> np.ndarray:
    """One inference, batch 1, as the car's inference node runs it."""
    ports = {sorted(p.get_names())[0].split(":")[0]: p for p in model.inputs}  # type: ignore[attr-defined]
    cam = obs["camera"] if isinstance(obs, dict) else obs
    feeds = {ports[names["camera"]]: cam[None].astype(np.float32)}
    if "lidar" in names:
        feeds[ports[names["lidar"]]] = obs["lidar"][None].astype(np.float32)  # type: ignore[index]
    return model(feeds)[model.outputs[0]][0]  # type: ignore[operator,attr-defined]


@pytest.mark.parametrize("space", list(ACTION_SPACES))
@pytest.mark.parametrize("sensor", list(SENSORS))
@pytest.mark.parametrize("network", NETWORKS)
def test_openvino_matches_torch(network: str, sensor: str, space: str, tmp_path) -> None:
    sensor_changes, lidar_type, lidar_name = SENSORS[sensor]
    space_changes, algorithm = ACTION_SPACES[space]
    actions = () if space_changes.get("continuous") else default_vehicle().actions
    vehicle = Vehicle(name="car", actions=actions, network=network, **sensor_changes, **space_changes)
    env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation", lidar_type=lidar_type)
    model = build_algorithm(env, network, Hyperparameters.default(algorithm), seed=3)
    graph = policy_to_graph(model.policy, vehicle)

    nodes = parse_graph(graph).node
    assert {n.op for n in nodes} <= MO_2021_TF_OPS
    consumed = {i.split(":")[0] for n in nodes for i in n.input}
    assert [n.name for n in nodes if n.name not in consumed] == [
        SAC_OUTPUT if algorithm == "sac" else PPO_OUTPUT
    ]
    lidar_values = {None: None, "LIDAR": 64, "SECTOR_LIDAR": 8}[lidar_name]
    names = input_names(vehicle, algorithm, lidar_values)
    placeholders = {
        n.name: [d.size for d in n.attr["shape"].shape.dim] for n in nodes if n.op == "Placeholder"
    }
    channels = 2 if sensor == "stereo" else 1
    assert placeholders.pop(names["camera"]) == [-1, 120, 160, channels]
    if lidar_name:
        assert names["lidar"].endswith(f"/{lidar_name}/{lidar_name}")
        assert placeholders.pop(names["lidar"]) == [-1, lidar_values]
    assert not placeholders
    assert all(any(key in name for key in INFERENCE_INPUT_KEYS) for name in names.values())
    head = "policy" if algorithm == "sac" else "main"
    assert names["camera"].startswith(f"main_level/agent/{head}/online/network_0/")

    runner = compiled(graph, tmp_path)
    for obs in frames(env):
        cam = obs["camera"] if isinstance(obs, dict) else obs
        lidar = obs["lidar"][None] if isinstance(obs, dict) else None
        expected = torch_outputs(model.policy, cam[None], lidar)[0]
        got = feed(runner, names, obs)
        assert got.shape == expected.shape
        assert np.abs(got - expected).max() < TOLERANCE, (got, expected)


def test_a_layer_the_car_cannot_run_is_refused() -> None:
    vehicle = Vehicle(name="elu", actions=default_vehicle().actions, network="compact")
    env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")
    model = build_algorithm(env, "compact", Hyperparameters.default("ppo"), seed=0)
    model.policy.features_extractor.head[1] = nn.ELU()  # TensorFlow's Elu: not in the 2021 model optimizer
    with pytest.raises(DrxError, match="operation Elu is not one the car's OpenVINO 2021 model optimizer"):
        policy_to_graph(model.policy, vehicle)
    model.policy.features_extractor.head[1] = nn.GELU()
    with pytest.raises(DrxError, match="cannot write the layer GELU"):
        policy_to_graph(model.policy, vehicle)


def test_graph_builder_refuses_unknown_ops_and_round_trips_constants() -> None:
    g = GraphBuilder()
    with pytest.raises(DrxError, match="AddV2 is not one"):
        g.op("AddV2", [], "x")
    weights = np.arange(12, dtype=np.float32).reshape(3, 4) / 7
    g.const(weights, "w")
    g.const(np.array([-1, 5], np.int32), "shape")
    nodes = {n.name: n for n in parse_graph(g.serialize()).node}
    assert np.array_equal(tensor_value(nodes["w"].attr["value"].tensor), weights)
    assert tensor_value(nodes["shape"].attr["value"].tensor).tolist() == [-1, 5]
    with pytest.raises(DrxError, match="not a TensorFlow frozen graph"):
        parse_graph(b"\xff\xff\xff not a protobuf")
