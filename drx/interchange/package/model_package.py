"""``drx model export``: a trained model as a DeepRacer-style package (``.tar.gz``).

The package's members, all at its top level as in a DeepRacer model download:

| member | what |
|---|---|
| ``model_metadata.json`` | the car in DeepRacer's format (actions, sensors, network, algorithm, version) |
| ``reward_function.py`` | the exact reward code the model was trained with |
| ``hyperparameters.json`` | DeepRacer's hyperparameter keys |
| ``model.onnx`` | the policy (see :mod:`drx.interchange.package.onnx_policy`) |
| ``drx_checkpoint.zip`` | drx's own checkpoint (SB3 zip with ``drx.json``), to resume or clone |
| ``track.npy`` | the route the model was trained on |
| ``drx_export.json`` | drx's manifest: the model row, the checkpoint's figures, each member's sha256 |

``drx model import`` recognises a package by its manifest and checks every hash.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import drx
from drx.errors import DrxError, SettingError
from drx.interchange.package.onnx_policy import CAMERA_INPUT, LIDAR_INPUT, export_onnx
from drx.interchange.safe_tar import write_archive
from drx.registry import RewardSource, session_scope
from drx.services.checkpoints import choose_checkpoint
from drx.services.models import get_model
from drx.services.tracks import find_track
from drx.storage import get_store
from drx.train.checkpoint import read_meta

FORMAT = "drx-model-export"
FORMAT_VERSION = 1
MANIFEST = "drx_export.json"
METADATA = "model_metadata.json"
REWARD = "reward_function.py"
HYPERPARAMETERS = "hyperparameters.json"
ONNX = "model.onnx"
CHECKPOINT = "drx_checkpoint.zip"
TRACK = "track.npy"


def sha256_file(path: Path) -> str:
    """sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def export_model(name: str, out: Path, which: str = "best") -> tuple[Path, dict[str, Any]]:
    """Write model ``name``'s package to ``out`` (``.tar.gz``); return the path and the manifest.

    :param which: ``best``, ``last`` or an iteration number.
    :raises DrxError: unknown model, no checkpoint, bad ``out``.
    """
    out = Path(out)
    if not out.name.endswith((".tar.gz", ".tgz")):
        raise SettingError("{field} {value} must end with .tar.gz.", "out", value=out)
    model = get_model(name)
    chosen = choose_checkpoint(model, str(which).strip().lower())  # the one `drx evaluate` would drive
    if chosen.path.suffix == ".pb":
        raise DrxError(
            f"Model {name!r} is a DeepRacer model (a model.pb, no drx checkpoint); export it with --for-car."
        )
    meta = read_meta(chosen.path)
    vehicle = model.vehicle()
    hp = model.hyperparameter_settings()
    with session_scope() as session:
        code = session.get_one(RewardSource, model.reward_sha256).code
    track = find_track(model.track_name)
    track_path, track_source = track.path, track.source
    with tempfile.TemporaryDirectory(prefix="drx-export-") as tmp:
        work = Path(tmp)
        metadata = vehicle.to_model_metadata(model.algorithm, model.car_settings().simulator)
        (work / METADATA).write_text(json.dumps(metadata, indent=2) + "\n")
        (work / REWARD).write_text(code, encoding="utf-8")
        max_episodes = model.stop_settings().max_episodes
        (work / HYPERPARAMETERS).write_text(json.dumps(hp.to_deepracer_json(max_episodes), indent=2) + "\n")
        export_onnx(chosen.path, vehicle, work / ONNX)
        files = {
            METADATA: work / METADATA,
            REWARD: work / REWARD,
            HYPERPARAMETERS: work / HYPERPARAMETERS,
            ONNX: work / ONNX,
            CHECKPOINT: chosen.path,
            TRACK: track_path,
        }
        manifest = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "drx_version": drx.__version__,
            "exported_at": datetime.now(UTC).isoformat(timespec="seconds"),
            "model": {
                "name": model.name,
                "description": model.description,
                "vehicle_name": model.vehicle_name,
                "vehicle_spec": model.vehicle_spec,
                "track_name": model.track_name,
                "track_source": track_source,
                "track_sha256": model.track_sha256,
                "reward_filename": model.reward_filename,
                "reward_sha256": model.reward_sha256,
                "algorithm": model.algorithm,
                "hyperparameters": model.hyperparameters,
                "stop_conditions": model.stop_conditions,
                "domain_randomization": bool(model.domain_randomization),
                "simulator": model.car_settings().simulator,
                "car_randomization": model.car_settings().car_randomization,
                "parent_name": model.parent_name,
            },
            "checkpoint": {
                "which": which,
                "iteration": chosen.iteration,
                **{k: meta.get(k) for k in ("steps", "episodes", "eval_progress", "eval_lap_time")},
            },
            "onnx": onnx_signature(vehicle),
            "files": {k: sha256_file(p) for k, p in files.items()},
        }
        (work / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
        write_archive(out, {MANIFEST: work / MANIFEST, **files})
    get_store().put(name, f"exports/{out.name}", out)  # with a bucket: a copy every host can fetch
    return out, manifest


def onnx_signature(vehicle: Any) -> dict[str, Any]:
    """The ONNX policy's inputs and outputs, as the manifest records them."""
    channels = 2 if vehicle.sensor == "stereo" else 1
    inputs = {CAMERA_INPUT: {"dtype": "uint8", "shape": ["N", 120, 160, channels]}}
    if vehicle.lidar:
        inputs[LIDAR_INPUT] = {"dtype": "float32", "shape": ["N", "beams"]}
    if vehicle.continuous:
        outputs = {"action": "[-1, 1] (steering, speed)", "action_scaled": "(steering deg, speed m/s)"}
    else:
        outputs = {
            "action_probabilities": f"softmax over {vehicle.n_actions} actions, in model_metadata order"
        }
    return {"inputs": inputs, "outputs": outputs}
