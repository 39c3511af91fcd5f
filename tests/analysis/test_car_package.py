"""``drx model export --for-car`` and ``drx model import`` of DeepRacer packages.

The car package passes the car loader's rules; a DeepRacer-style package (deepracer-for-cloud's
layout: ``model_metadata.json`` at the root, ``agent/model.pb``) imports and races through
OpenVINO; the round trip (export for the car, import, evaluate) drives the same laps.
"""

from __future__ import annotations

import builtins
import io
import json
import tarfile
from pathlib import Path

import numpy as np
import pytest

from drx.interchange.car.car_graph import PPO_OUTPUT, SAC_OUTPUT, policy_to_graph
from drx.interchange.car.car_package import CAR_METADATA, CAR_MODEL, check_car_archive
from drx.interchange.car.openvino_policy import OpenVINOPolicy
from drx.interchange.car.tf_graph import graph_def_class, parse_graph
from drx.interchange.package.onnx_policy import torch_outputs
from drx.services import models as model_service
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.sim.lidar import Lidar
from drx.train.algorithms import build_algorithm
from drx.vehicle import Vehicle, default_vehicle

from ._cli import fails_unchanged, ok_json
from .conftest import use_home
from .test_package import trial

pytest.importorskip("openvino", reason="OpenVINO is not installed (pip install openvino)")


@pytest.fixture
def car_package(trained: str, tmp_path: Path) -> Path:
    """The trained model exported for the car to ``tmp_path/base-car.tar.gz``."""
    out = tmp_path / "base-car.tar.gz"
    data = ok_json("model", "export", trained, "--for-car", "--out", out)
    assert Path(data["path"]) == out and data["car_model_name"] == "base-car"
    return out


def _tar(path: Path, members: dict[str, bytes]) -> Path:
    with tarfile.open(path, "w:gz") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


def _members(package: Path) -> dict[str, bytes]:
    with tarfile.open(package) as tar:
        return {n: tar.extractfile(n).read() for n in tar.getnames()}  # type: ignore[union-attr]


def test_car_package_passes_the_loader_rules(car_package: Path, trained: str) -> None:
    with tarfile.open(car_package) as tar:
        assert sorted(tar.getnames()) == sorted([CAR_METADATA, CAR_MODEL])
    checked = check_car_archive(car_package)
    assert checked.model_member == CAR_MODEL and checked.outputs == (PPO_OUTPUT,)
    assert checked.inputs == (
        "main_level/agent/main/online/network_0/FRONT_FACING_CAMERA/FRONT_FACING_CAMERA",
    )
    meta = checked.metadata
    assert set(meta) == {
        "action_space",
        "action_space_type",
        "sensor",
        "neural_network",
        "training_algorithm",
        "version",
    }
    assert meta["sensor"] == ["FRONT_FACING_CAMERA"] and meta["training_algorithm"] == "clipped_ppo"
    assert len(meta["action_space"]) == model_service.get_model(trained).vehicle().n_actions


def test_round_trip_export_for_car_import_evaluate(
    car_package: Path, trained: str, tmp_path, monkeypatch
) -> None:
    expected = trial(trained)
    use_home(monkeypatch, tmp_path / "other_home")
    data = ok_json("model", "import", car_package)
    assert data["model"] == "base-car" and data["track"] == "oval"
    # the built-in car has the same spec as the trained one (DeepRacer's actions, drx's default network)
    assert data["car"] == "default" and not data["car_created"]
    assert model_service.get_model("base-car").status == "ready"
    assert trial("base-car") == expected  # the OpenVINO graph drives the same laps as the torch policy
    board = ok_json("leaderboard", "--track", "oval")
    assert "base-car" in json.dumps(board)
    fails_unchanged("evaluate", "base-car", "--checkpoint", "7", contains="use best")
    fails_unchanged("model", "export", "base-car", "--out", tmp_path / "drx.tar.gz", contains="--for-car")
    again = tmp_path / "again.tar.gz"  # an imported model exports its graph as it came
    ok_json("model", "export", "base-car", "--for-car", "--out", again)
    assert _members(again)[CAR_MODEL] == _members(car_package)[CAR_MODEL]


def test_deepracer_for_cloud_layout_imports(car_package: Path, tmp_path, monkeypatch) -> None:
    members = _members(car_package)
    use_home(monkeypatch, tmp_path / "home")
    drfc = _tar(
        tmp_path / "carfile.tar.gz",
        {
            CAR_METADATA: members[CAR_METADATA],
            f"agent/{CAR_MODEL}": members[CAR_MODEL],
            "agent/checkpoint": b"model_checkpoint_path: '12_Step-345.ckpt'\n",
            "reward_function.py": b"def reward_function(params):\n    raise SystemExit('never run')\n",
        },
    )
    data = ok_json("model", "import", drfc, "--name", "from-cloud", "--track", "oval")
    assert data["model"] == "from-cloud" and data["track"] == "oval"
    stored = ok_json("reward", "show", "from-cloud")
    assert "never run" in json.dumps(stored)


def test_sac_graph_without_tanh_is_squashed_as_deepracer_does(tmp_path: Path) -> None:
    """DeepRacer's SAC graph ends before the tanh its simulator applies; drx's ends after it."""
    vehicle = Vehicle(name="sac", continuous=True, network="compact")
    env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")
    sac = build_algorithm(env, "compact", Hyperparameters.default("sac"), seed=1)
    graph = parse_graph(policy_to_graph(sac.policy, vehicle))
    ours = tmp_path / "ours.pb"
    ours.write_bytes(graph.SerializeToString())
    nodes = {n.name: n for n in graph.node}
    tanh = nodes[nodes[SAC_OUTPUT].input[0]]
    assert tanh.op == "Tanh"
    nodes[SAC_OUTPUT].input[0] = tanh.input[0]  # DeepRacer's layout: the raw mean is the output
    raw = graph_def_class()()
    raw.node.extend(n for n in graph.node if n.name != tanh.name)
    theirs = tmp_path / "theirs.pb"
    theirs.write_bytes(raw.SerializeToString())
    meta = vehicle.to_model_metadata("sac")
    mine, deepracer = OpenVINOPolicy(ours, meta), OpenVINOPolicy(theirs, meta)
    assert not mine.squash and deepracer.squash
    for k in range(3):
        obs, _ = env.reset(options={"start": k / 3})
        expected, _ = sac.policy.predict(obs, deterministic=True)
        assert np.abs(mine(obs) - expected).max() < 1e-4
        assert np.abs(deepracer(obs) - expected).max() < 1e-4


def test_bad_deepracer_packages_store_nothing(car_package: Path, tmp_path, monkeypatch) -> None:
    members = _members(car_package)
    use_home(monkeypatch, tmp_path / "home")
    two = _tar(tmp_path / "two.tar.gz", {**members, "agent/model.pb": members[CAR_MODEL]})
    fails_unchanged("model", "import", two, "--name", "two", contains="exactly one .pb")
    nested = _tar(
        tmp_path / "n.tar.gz", {f"model/{CAR_METADATA}": members[CAR_METADATA], CAR_MODEL: members[CAR_MODEL]}
    )
    fails_unchanged("model", "import", nested, "--name", "n", contains="no model_metadata.json at its root")
    junk = _tar(tmp_path / "junk.tar.gz", {CAR_METADATA: members[CAR_METADATA], CAR_MODEL: b"\xff\xff junk"})
    fails_unchanged("model", "import", junk, "--name", "junk", contains="not a TensorFlow frozen graph")
    meta = json.loads(members[CAR_METADATA])
    meta["action_space"] = meta["action_space"][:4]
    wrong = _tar(
        tmp_path / "w.tar.gz", {CAR_METADATA: json.dumps(meta).encode(), CAR_MODEL: members[CAR_MODEL]}
    )
    fails_unchanged("model", "import", wrong, "--name", "w", contains="outputs 10 values")
    meta = json.loads(members[CAR_METADATA])
    meta["sensor"] = ["STEREO_CAMERAS"]
    stereo = _tar(
        tmp_path / "st.tar.gz", {CAR_METADATA: json.dumps(meta).encode(), CAR_MODEL: members[CAR_MODEL]}
    )
    fails_unchanged("model", "import", stereo, "--name", "st", contains="1-channel frames")
    fails_unchanged("model", "import", car_package, "--track", "nowhere", contains="nowhere")
    bad_name = tmp_path / "my model.tar.gz"  # a space: not a model name
    bad_name.write_bytes(car_package.read_bytes())
    fails_unchanged("model", "import", bad_name, contains="--name")


def test_import_without_openvino_says_how_to_add_it(car_package: Path, tmp_path, monkeypatch) -> None:
    use_home(monkeypatch, tmp_path / "home")
    real_import = builtins.__import__

    def no_openvino(name: str, *args, **kwargs):  # as if `pip install openvino` had not been run
        if name == "openvino" or name.startswith("openvino."):
            raise ImportError("No module named 'openvino'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_openvino)
    fails_unchanged("model", "import", car_package, contains="pip install openvino")


def test_export_for_car_refuses_bad_out(trained: str, tmp_path) -> None:
    fails_unchanged(
        "model", "export", trained, "--for-car", "--out", tmp_path / "car.zip", contains=".tar.gz"
    )
    fails_unchanged(
        "model", "export", "nobody", "--for-car", "--out", tmp_path / "car.tar.gz", contains="nobody"
    )


def test_sector_lidar_model_is_fed_drx_ranges_folded_into_sectors(tmp_path: Path) -> None:
    """An imported SECTOR_LIDAR model races in drx's evaluation env, whose lidar gives 64 ranges."""
    vehicle = Vehicle(name="sector", actions=default_vehicle().actions, lidar=True, network="compact")
    sector_env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation", lidar_type="sector")
    ppo = build_algorithm(sector_env, "compact", Hyperparameters.default("ppo"), seed=2)
    graph = tmp_path / "model.pb"
    graph.write_bytes(policy_to_graph(ppo.policy, vehicle))
    meta = vehicle.to_model_metadata("ppo")
    meta["sensor"] = ["FRONT_FACING_CAMERA", "SECTOR_LIDAR"]
    driver = OpenVINOPolicy(graph, meta)
    assert driver.lidar.endswith("/SECTOR_LIDAR/SECTOR_LIDAR") and driver.lidar_values == 8
    ranges_env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")  # 64 ranges
    for k in range(3):
        obs, _ = ranges_env.reset(options={"start": k / 3})
        sectors = Lidar().sectors(obs["lidar"])
        expected = torch_outputs(ppo.policy, obs["camera"][None], sectors[None])[0]
        assert np.abs(driver.outputs(obs["camera"], obs["lidar"]) - expected).max() < 1e-4
        assert driver(obs) == int(np.argmax(expected))


def test_old_observation_model_without_sensor_key(car_package: Path, tmp_path, monkeypatch) -> None:
    """Models from before the sensor list name their camera input ``observation`` (the car's default)."""
    members = _members(car_package)
    graph = parse_graph(members[CAR_MODEL])
    old = next(n.name for n in graph.node if n.op == "Placeholder")
    new = "main_level/agent/main/online/network_0/observation/observation"
    for node in graph.node:
        if node.name == old:
            node.name = new
        node.input[:] = [new if i == old else i for i in node.input]
    meta = json.loads(members[CAR_METADATA])
    del meta["sensor"], meta["training_algorithm"]
    use_home(monkeypatch, tmp_path / "home")
    legacy = _tar(
        tmp_path / "legacy.tar.gz",
        {CAR_METADATA: json.dumps(meta).encode(), CAR_MODEL: graph.SerializeToString()},
    )
    assert check_car_archive(legacy).inputs == (new,)
    ok_json("model", "import", legacy)
    assert trial("legacy")["laps"]
