"""``drx model export``: a trained model as a DeepRacer-style package (``.tar.gz``).

The package's members, all at its top level as in a DeepRacer model download:

| member | what |
|---|---|
| ``model_metadata.json`` | the car in DeepRacer's format (actions, sensors, network, algorithm, version) |
| ``reward_function.py`` | the exact reward code the model was trained with |
| ``hyperparameters.json`` | DeepRacer's hyperparameter keys |
| ``model.onnx`` | the policy (see :mod:`drx.analysis.onnx_policy`) |
| ``drx_checkpoint.zip`` | drx's own checkpoint (SB3 zip with ``drx.json``), to resume or clone |
| ``track.npy`` | the route the model was trained on |
| ``drx_export.json`` | drx's manifest: the model row, the checkpoint's figures, each member's sha256 |

``drx model import`` recognises a package by its manifest and checks every hash.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import select

import drx
from drx.analysis.data import model_folder
from drx.analysis.onnx_policy import CAMERA_INPUT, LIDAR_INPUT, export_onnx
from drx.analysis.safe_tar import write_archive
from drx.errors import DrxError, NotFoundError
from drx.registry import Checkpoint, RewardSource, session_scope
from drx.services.models import get_model
from drx.services.tracks import resolve_track_path
from drx.train.checkpoint import BEST, LAST, read_meta
from drx.train.hyperparameters import Hyperparameters

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


@dataclass(frozen=True)
class ChosenCheckpoint:
    """The checkpoint file an export uses and its run state (``drx.json``)."""

    path: Path
    iteration: int
    meta: dict[str, Any]


def _candidates(model_id: int, folder: Path) -> list[ChosenCheckpoint]:
    with session_scope() as session:
        paths = [
            Path(p) for p in session.scalars(select(Checkpoint.path).where(Checkpoint.model_id == model_id))
        ]
    paths += [folder / "model" / BEST, folder / "model" / LAST]
    out, seen = [], set()
    for p in paths:
        if p.is_file() and p.resolve() not in seen:
            seen.add(p.resolve())
            meta = read_meta(p)
            out.append(ChosenCheckpoint(p, int(meta.get("iteration", -1)), meta))
    return out


def choose_checkpoint(name: str, which: str = "best") -> ChosenCheckpoint:
    """The checkpoint ``best``, ``last`` or of iteration ``N`` of model ``name``.

    drx keeps two files per model (``model/best.zip`` and ``model/last.zip``), so an
    iteration number can be exported only while one of them still holds it.

    :raises DrxError: unknown model, no checkpoint, or no file holding iteration ``N``.
    """
    model = get_model(name)
    folder = model_folder(model)
    found = _candidates(model.id, folder)
    if not found:
        raise NotFoundError(f"Model {name!r} has no checkpoint yet; train it first (`drx train {name}`).")
    which = str(which).strip().lower()
    if which == "best":
        best = [c for c in found if c.path.name == BEST]
        return best[0] if best else max(found, key=lambda c: c.iteration)
    if which == "last":
        return max(found, key=lambda c: c.iteration)
    if not which.isdigit():
        raise DrxError(f"--checkpoint {which!r} is unknown; use best, last or an iteration number.")
    match = [c for c in found if c.iteration == int(which)]
    if not match:
        held = ", ".join(f"{c.path.stem} = iteration {c.iteration}" for c in found)
        raise NotFoundError(
            f"No checkpoint file holds iteration {which} of {name!r} "
            f"(drx keeps the best and the last: {held})."
        )
    return match[0]


def export_model(name: str, out: Path, which: str = "best") -> tuple[Path, dict[str, Any]]:
    """Write model ``name``'s package to ``out`` (``.tar.gz``); return the path and the manifest.

    :param which: ``best``, ``last`` or an iteration number.
    :raises DrxError: unknown model, no checkpoint, bad ``out``.
    """
    out = Path(out)
    if not out.name.endswith((".tar.gz", ".tgz")):
        raise DrxError(f"--out {out} must end with .tar.gz.")
    model = get_model(name)
    chosen = choose_checkpoint(name, which)
    vehicle = model.vehicle()
    hp = Hyperparameters.from_dict(model.hyperparameters, model.algorithm)
    with session_scope() as session:
        code = session.get_one(RewardSource, model.reward_sha256).code
    track_path, track_source = resolve_track_path(model.track_name)
    with tempfile.TemporaryDirectory(prefix="drx-export-") as tmp:
        work = Path(tmp)
        (work / METADATA).write_text(json.dumps(vehicle.to_model_metadata(model.algorithm), indent=2) + "\n")
        (work / REWARD).write_text(code, encoding="utf-8")
        max_episodes = (model.stop_conditions or {}).get("max_episodes")
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
                "parent_name": model.parent_name,
            },
            "checkpoint": {
                "which": which,
                "iteration": chosen.iteration,
                **{k: chosen.meta.get(k) for k in ("steps", "episodes", "eval_progress", "eval_lap_time")},
            },
            "onnx": onnx_signature(vehicle),
            "files": {k: sha256_file(p) for k, p in files.items()},
        }
        (work / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
        write_archive(out, {MANIFEST: work / MANIFEST, **files})
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
