"""DeepRacer's model folder end to end: ``drx model export --for-deepracer`` and ``drx model import``.

One small model on DeepRacer's shallow network and the real workshop model's car (9 actions) is
trained once for the module; every test reads what it wrote. The checks that do not trust drx:
its tensor set against the real ``.index`` files in ``../shared/deepracer-models/``, and DeepRacer's
own TensorFlow graph restoring the export as the simulator does (``tools/tf_check``).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch as th
from analysis._cli import fails_unchanged, invoke, ok_json

from drx.interchange.deepracer import deepracer_weights as dw
from drx.interchange.deepracer.tensor_bundle import read_bundle, read_index, write_bundle
from drx.vehicle import Vehicle

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT.parent / "shared" / "deepracer-models"
CONSOLE = MODELS / "console-2023-continuous-shallow"
WORKSHOP = MODELS / "workshop-2019-discrete-shallow"
META_GRAPH = CONSOLE / "model" / "146_Step-139684.ckpt.meta"
TF_PYTHON = ROOT / ".venv-tf" / "bin" / "python"
RESTORE_CHECK = ROOT / "tools" / "tf_check" / "restore_check.py"
TRACK = "Oval_track"  # DeepRacer's own oval: one-way, short


def _shared(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"{path} is absent: the real DeepRacer model folders live in ../shared/deepracer-models")
    return path


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """A shallow model with the workshop car, trained one iteration, and its export as a folder."""
    home = tmp_path_factory.mktemp("home")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DRX_HOME", str(home))
        mp.setenv("DRX_EVALUATION_SEED", "0")
        mp.delenv("DRX_ARTIFACTS_URL", raising=False)
        # the untrained model does not lap: its races end after 6 simulated seconds, not 3 minutes
        mp.setattr("drx.interchange.deepracer.export.LAP_CAP_MINUTES", 0.1)
        ok_json(
            "garage",
            "add",
            "nine",
            "--max-steering",
            "30",
            "--steering-levels",
            "3",
            "--max-speed",
            "1",
            "--speed-levels",
            "3",
            "--network",
            "shallow",
        )
        ok_json("model", "create", "m", "--car", "nine", "--track", TRACK, "--episodes-per-iteration", "5")
        ok_json("train", "m", "--max-episodes", "5")
        folder = home / "export" / "m-deepracer"
        folder.parent.mkdir()
        exported = ok_json("model", "export", "m", "--for-deepracer", "--out", folder, "--laps", "1")
        yield {"home": home, "folder": folder, "export": exported}


@pytest.fixture
def in_home(trained: dict[str, Any], monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Run the test in the trained model's data home."""
    monkeypatch.setenv("DRX_HOME", str(trained["home"]))
    return trained


def _checkpoint(folder: Path) -> Path:
    return folder / "model" / (folder / "model" / ".coach_checkpoint").read_text()


def test_the_folder_has_deepracers_files_and_drives_as_the_model(trained: dict[str, Any]) -> None:
    folder, export = trained["folder"], trained["export"]
    assert set(export["files"]) >= {
        "model_metadata.json",
        "reward_function.py",
        "training_params.yaml",
        "hyperparameters.json",
        "ip/hyperparameters.json",
        "model/model_metadata.json",
        "model/.coach_checkpoint",
        "model/deepracer_checkpoints.json",
    }
    assert not (folder / "model" / "checkpoint").exists()  # it would switch the simulator's restore
    name = (folder / "model" / ".coach_checkpoint").read_text()
    assert name == export["checkpoint"] and name.endswith(".ckpt") and "_Step-" in name
    assert {f"model/{name}.index", f"model/{name}.data-00000-of-00001"} <= set(export["files"])
    index = json.loads((folder / "model" / "deepracer_checkpoints.json").read_text())
    assert index["best_checkpoint"]["name"] == index["last_checkpoint"]["name"] == name
    meta = json.loads((folder / "model_metadata.json").read_text())
    assert meta["neural_network"] == "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"
    assert meta["version"] == "6"  # the car it trained on: simulator 6's, a new model's
    assert meta["training_algorithm"] == "clipped_ppo" and len(meta["action_space"]) == 9
    params = (folder / "training_params.yaml").read_text()
    assert f"WORLD_NAME: {TRACK}" in params and "TRACK_DIRECTION_CLOCKWISE" not in params  # a one-way track
    metrics = json.loads(next((folder / "metrics" / "training").glob("training-*.json")).read_text())
    assert metrics["version"] == 2.0 and {m["phase"] for m in metrics["metrics"]} == {
        "training",
        "evaluation",
    }
    # the export, read back from its own files, drives the same lap as the model
    assert export["exported_laps"] == export["original_laps"] and export["original_laps"]["laps"] >= 1
    assert export["distillation"] is None  # a shallow model is written tensor for tensor


def test_the_tensor_set_is_the_real_checkpoints(trained: dict[str, Any], tmp_path: Path) -> None:
    """Names, dtypes and shapes equal those of real console checkpoints, discrete and continuous."""
    ours = read_index(_checkpoint(trained["folder"]).with_suffix(".ckpt.index"))[1]
    real = read_index(_shared(WORKSHOP / "model" / "11_Step-38428.ckpt.index"))[1]
    assert [(e.name, e.dtype, e.shape) for e in ours] == [(e.name, e.dtype, e.shape) for e in real]
    continuous = Vehicle(
        name="c", continuous=True, steering_range=(-25, 27), speed_range=(1, 3.3), network="shallow"
    )
    tensors = dw.policy_tensors(_random_policy(continuous), continuous)
    write_bundle(tmp_path / "1_Step-1.ckpt", tensors)
    ours = read_index(tmp_path / "1_Step-1.ckpt.index")[1]
    real = read_index(_shared(CONSOLE / "model" / "146_Step-139684.ckpt.index"))[1]
    assert [(e.name, e.dtype, e.shape) for e in ours] == [(e.name, e.dtype, e.shape) for e in real]


def _random_policy(vehicle: Vehicle) -> Any:
    from drx.train.policy_weights import build_policy

    th.manual_seed(0)
    policy = build_policy(vehicle, "ppo", "separate")
    with th.no_grad():
        for p in policy.parameters():
            p.add_(th.randn_like(p) * 0.05)
    return policy


def _frames(vehicle: Vehicle, n: int = 6) -> np.ndarray:
    """Real camera frames of drx's simulator on the oval, driven by random actions."""
    from drx.sim.env import DeepRacerEnv

    env = DeepRacerEnv(track=TRACK, vehicle=vehicle)
    obs, _ = env.reset(seed=0)
    frames = [obs]
    while len(frames) < n:
        obs, _, done, cut, _ = env.step(env.action_space.sample())
        frames.append(obs)
        if done or cut:
            obs, _ = env.reset()
    return np.stack(frames).astype(np.uint8)


def _expected(policy: Any, frames: np.ndarray, value_scale: float) -> dict[str, np.ndarray]:
    obs = th.as_tensor(frames).permute(0, 3, 1, 2)
    with th.no_grad():
        distribution = policy.get_distribution(obs).distribution
        values = policy.predict_values(obs).numpy().reshape(-1) * value_scale
    probs = getattr(distribution, "probs", None)
    out = {"frames": frames, "value": values.astype(np.float32)}
    if probs is not None:
        out["policy"] = probs.numpy().astype(np.float32)
    else:
        out["policy"] = distribution.mean.numpy().astype(np.float32)
        out["log_std"] = policy.log_std.detach().numpy().astype(np.float32)
    return out


def _restore_in_tensorflow(
    checkpoint: Path, expected: dict[str, np.ndarray], tmp: Path, discrete: int | None
) -> None:
    if not TF_PYTHON.is_file():
        pytest.skip(f"{TF_PYTHON} is absent: run tools/tf_check/setup.sh for DeepRacer's own graph")
    np.savez(tmp / "frames.npz", **expected)
    args = [
        str(TF_PYTHON),
        str(RESTORE_CHECK),
        "--meta",
        str(_shared(META_GRAPH)),
        "--checkpoint",
        str(checkpoint),
        "--frames",
        str(tmp / "frames.npz"),
        "--atol",
        "1e-4",
        "--rtol",
        "1e-5",
        "--json",
    ]
    if discrete:
        args += ["--discrete", str(discrete)]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    result = json.loads(done.stdout)
    assert done.returncode == 0 and result["ok"], result
    assert result["unused_checkpoint_tensors"] == [] and set(result["quantities"]) >= {"policy", "value"}


def test_deepracers_graph_drives_the_export_as_drx_does(in_home: dict[str, Any], tmp_path: Path) -> None:
    """The trained discrete model's export, restored into DeepRacer's TensorFlow graph as the simulator
    restores it, gives drx's action probabilities and (scaled) values on drx's camera frames."""
    from drx.services.models import get_model
    from drx.train.checkpoint import checkpoint_path, read_meta
    from drx.train.policy_weights import load_policy_weights

    vehicle = get_model("m").vehicle()
    best = checkpoint_path(in_home["home"] / "artifacts" / "models" / "m", "best")
    policy = load_policy_weights(best, vehicle, "ppo")
    scale = float((read_meta(best).get("return_scale") or {}).get("rms") or 1.0)
    expected = _expected(policy, _frames(vehicle), scale)
    _restore_in_tensorflow(_checkpoint(in_home["folder"]), expected, tmp_path, discrete=9)


def test_deepracers_graph_drives_a_continuous_export(tmp_path: Path) -> None:
    continuous = Vehicle(
        name="c", continuous=True, steering_range=(-25, 27), speed_range=(1, 3.3), network="shallow"
    )
    policy = _random_policy(continuous)
    write_bundle(tmp_path / "3_Step-30.ckpt", dw.policy_tensors(policy, continuous, value_scale=3.0))
    expected = _expected(policy, _frames(continuous), 3.0)
    _restore_in_tensorflow(tmp_path / "3_Step-30.ckpt", expected, tmp_path, discrete=None)


def _laps(name: str) -> list[Any]:
    """A short time trial (it ends at the first off-track)."""
    trial = ok_json("evaluate", name, "--laps", "1", "--seed", "3", "--max-resets", "0")
    return [(lap["progress"], lap["status"], lap["time"]) for lap in trial["laps"]]


def test_an_import_races_as_the_original_trains_on_and_exports_back(
    in_home: dict[str, Any], tmp_path: Path
) -> None:
    imported = ok_json("model", "import", in_home["folder"], "--name", "back", "--trust-reward")
    assert imported["track"] == TRACK and imported["checkpoint"] == in_home["export"]["checkpoint"]
    shown = ok_json("model", "show", "back")
    assert shown["simulator"] == "6"  # the car its model_metadata.json names, as it trained
    assert (
        shown["hyperparameters"]["towers"] == "separate"
        and shown["hyperparameters"]["episodes_per_iteration"] == 5
    )
    assert _laps("back") == _laps("m")  # the same weights, the same seed: the same laps
    ok_json("train", "back", "--max-episodes", "5")
    ok_json("model", "clone", "back", "back-2")
    again = ok_json("model", "export", "back", "--for-deepracer", "--out", tmp_path / "again", "--laps", "0")
    tensors = read_bundle(tmp_path / "again" / "model" / again["checkpoint"])
    # training moved DeepRacer's two towers apart: they are kept as two, not merged
    dense = "middleware_fc_embedder/Dense_0/kernel"
    assert not np.array_equal(
        tensors[f"{dw.PREFIX}/network_0/{dense}"], tensors[f"{dw.PREFIX}/network_1/{dense}"]
    )


def test_archives_and_buckets(
    trained: dict[str, Any], s3_server: Any, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    archive = tmp_path / "m.tar.gz"
    shutil.make_archive(
        str(archive).removesuffix(".tar.gz"), "gztar", trained["folder"].parent, "m-deepracer"
    )
    assert (
        ok_json("model", "import", archive, "--name", "from-tar")["checkpoint"]
        == trained["export"]["checkpoint"]
    )
    s3_server.make_bucket("models")
    for key, value in s3_server.env().items():
        monkeypatch.setenv(key, value)
    monkeypatch.setenv("DRX_HOME", str(trained["home"]))
    ok_json(
        "model",
        "export",
        "m",
        "--for-deepracer",
        "--out",
        "s3://models/rl-deepracer-pretrained",
        "--laps",
        "0",
    )
    monkeypatch.setenv("DRX_HOME", str(tmp_path / "fresh"))
    got = ok_json("model", "import", "s3://models/rl-deepracer-pretrained", "--name", "from-s3")
    assert got["checkpoint"] == trained["export"]["checkpoint"]


def _copy(trained: dict[str, Any], tmp_path: Path) -> Path:
    folder = tmp_path / "broken"
    shutil.copytree(trained["folder"], folder)
    return folder


def test_bad_folders_are_refused_in_one_sentence(trained: dict[str, Any], tmp_path: Path) -> None:
    folder = _copy(trained, tmp_path)
    ckpt = _checkpoint(folder)
    data = ckpt.with_name(ckpt.name + ".data-00000-of-00001")
    good = data.read_bytes()
    data.write_bytes(good[: len(good) // 2])
    fails_unchanged("model", "import", folder, contains="bytes")
    flipped = bytearray(good)
    flipped[1000] ^= 0xFF
    data.write_bytes(bytes(flipped))
    fails_unchanged("model", "import", folder, contains="does not match its checksum")
    data.unlink()
    fails_unchanged("model", "import", folder, contains="missing")
    data.write_bytes(good)
    meta = json.loads((folder / "model_metadata.json").read_text())
    for change, words in (
        ({"action_space": meta["action_space"][:5]}, "policy_fc/kernel has shape [512, 9]"),
        ({"neural_network": "DEEP_CONVOLUTIONAL_NETWORK"}, "uses the network DEEP_CONVOLUTIONAL_NETWORK"),
        ({"sensor": ["FRONT_FACING_CAMERA", "RADAR"]}, "Unknown sensor 'RADAR'"),
        ({"sensor": ["STEREO_CAMERAS"]}, "front camera only"),
        ({"training_algorithm": "sac"}, "trained with sac"),
    ):
        (folder / "model_metadata.json").write_text(json.dumps({**meta, **change}))
        fails_unchanged("model", "import", folder, contains=words)
    (folder / "model_metadata.json").write_text(json.dumps(meta))
    (folder / "reward_function.py").unlink()
    fails_unchanged("model", "import", folder, contains="no reward_function.py")
    fails_unchanged(
        "model", "import", folder, "--checkpoint", "9_Step-9", contains="has no 9_Step-9.ckpt.index"
    )
    fails_unchanged("model", "import", tmp_path / "nowhere", contains="does not exist")
    assert ok_json("model", "list") == []


def test_a_real_folder_without_its_weights_says_so() -> None:
    """The console's folder here lacks its 45 MB .data files, as a partial download would."""
    err = fails_unchanged("model", "import", _shared(CONSOLE), contains="140_Step-123889")  # its best
    assert "data-00000-of-00001" in err or "weights" in err


def test_bad_exports_are_refused(in_home: dict[str, Any], tmp_path: Path) -> None:
    fails_unchanged(
        "model", "export", "m", "--for-deepracer", "--out", in_home["folder"], contains="already exists"
    )
    fails_unchanged(
        "model", "export", "m", "--for-deepracer", "--for-car", "--out", tmp_path / "x", contains="one of"
    )
    fails_unchanged(
        "model", "export", "m", "--for-deepracer", "--out", tmp_path / "no" / "x", contains="does not exist"
    )
    assert invoke("model", "export", "m", "--for-deepracer", "--out", "s3://", "--laps", "0").exit_code == 2


def test_the_start_keys_of_training_params_come_back(trained: dict[str, Any], tmp_path: Path) -> None:
    """simapp's ROUND_ROBIN_ADVANCE_DIST, START_POSITION_OFFSET and ALTERNATE_DRIVING_DIRECTION become
    the imported model's episode options; a value DeepRacer would not take is refused."""
    folder = _copy(trained, tmp_path)
    params = folder / "training_params.yaml"
    text = params.read_text()
    # later keys win in YAML: these replace the exported ones
    added = "ROUND_ROBIN_ADVANCE_DIST: 0.1\nSTART_POSITION_OFFSET: 0.25\n"
    added += "ALTERNATE_DRIVING_DIRECTION: 'true'\n"
    params.write_text(text + added)
    ok_json("model", "import", folder, "--name", "starts")
    options = ok_json("model", "show", "starts")["training_options"]
    assert (options["round_robin_advance"], options["start_position_offset"]) == (0.1, 0.25)
    assert options["alternate_direction"] is True and options["change_start_position"] is True
    params.write_text(text + "ROUND_ROBIN_ADVANCE_DIST: 1.5\n")
    fails_unchanged("model", "import", folder, "--name", "bad-starts", contains="training_params.yaml")


def test_the_real_folders_read_as_deepracer_wrote_them() -> None:
    """The console's 2023 folder and the 2019 workshop folder (their weights are not here) read up to
    their weights: car, chosen checkpoint, track and direction, hyperparameters, tensor set."""
    from drx.errors import DrxError
    from drx.interchange.deepracer.folder_import import read_folder, track_of

    console = read_folder(_shared(CONSOLE))
    v = console.vehicle
    assert v.continuous and v.steering_range == (-25.0, 27.0) and v.speed_range == (1.0, 3.3)
    # deepracer_checkpoints.json's best (its coach_checkpoint has lost its dot, as the README says)
    assert console.checkpoint_name == "140_Step-123889.ckpt" and console.iteration_and_steps == (140, 123889)
    # WORLD_NAME reInvent2019_wide with TRACK_DIRECTION_CLOCKWISE "false" (quoted): the _ccw route
    assert track_of(console) == "reInvent2019_wide_ccw"
    assert console.hyperparameters["num_episodes_between_training"] == 20 and console.version == "5"
    with pytest.raises(DrxError, match="has no 145_Step-136982.ckpt.index"):  # its last was not kept
        read_folder(CONSOLE, "last")
    # the workshop model: metadata in model/ only (version 3, 9 actions), .coach_checkpoint, the
    # tensor set of a 9-action car all pass; it stops at its missing reward function
    with pytest.raises(DrxError, match="no reward_function.py"):
        read_folder(_shared(WORKSHOP))
