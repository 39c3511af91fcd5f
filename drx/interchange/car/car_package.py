"""``drx model export --for-car``: the ``.tar.gz`` a physical DeepRacer car loads.

The car takes a model as a ``.tar.gz``, uploaded on its web console or put in a ``models``
folder on a USB stick. Its model loader (aws-deepracer/aws-deepracer-systems-pkg
``model_loader_module/model_loader_node.py``, ``model_install_state.py``,
``file_system_utils.py``) unpacks the archive, walks every folder in it and installs the
model only when it finds **exactly one** file ending in ``.pb``; it copies that file and the
``model_metadata.json`` at the archive's **root** into the model's folder and drops the rest.
The car's upload page (aws-deepracer/aws-deepracer-webserver-pkg ``webserver_pkg/models.py``,
``/api/uploadModels``) takes only files ending in ``.tar.gz`` and names the model after the
file name without it; from a USB stick the name is the file name up to its first dot.

The package drx writes holds just those two members, at its root:

- ``model.pb``: the policy as a frozen TensorFlow graph (:mod:`drx.interchange.car.car_graph`);
- ``model_metadata.json``: the car in DeepRacer's format, ``action_space``,
  ``action_space_type``, ``sensor``, ``neural_network``, ``training_algorithm``, ``version``
  (deepracer-for-cloud ``defaults/model_metadata*.json``).

:func:`check_car_archive` applies the loader's rules and the inference node's input filter
(aws-deepracer-inference-pkg ``intel_inference_eng.cpp``: inputs whose names contain
``observation``, ``LIDAR``, ``FRONT_FACING_CAMERA``, ``STEREO_CAMERAS`` or ``LEFT_CAMERA``).
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from drx.errors import DrxError, SettingError
from drx.interchange.car.car_graph import lidar_sensor, output_name, policy_to_graph
from drx.interchange.car.tf_graph import parse_graph
from drx.interchange.package.onnx_policy import load_policy
from drx.interchange.safe_tar import checked_members, open_archive, write_archive
from drx.services.checkpoints import choose_checkpoint
from drx.services.models import get_model
from drx.storage import get_store
from drx.vehicle import Vehicle

CAR_MODEL = "model.pb"
CAR_METADATA = "model_metadata.json"
INFERENCE_INPUT_KEYS = ("observation", "LIDAR", "FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA")


def car_metadata(vehicle: Vehicle, algorithm: str, lidar_values: int | None) -> dict[str, Any]:
    """The car's ``model_metadata.json``; a lidar of 8 values is DeepRacer's ``SECTOR_LIDAR``."""
    meta = vehicle.to_model_metadata(algorithm)
    if lidar_values is not None:
        meta["sensor"] = [s if s != "LIDAR" else lidar_sensor(lidar_values) for s in meta["sensor"]]
    return meta


def export_car(name: str, out: Path, which: str = "best") -> tuple[Path, dict[str, Any]]:
    """Write model ``name``'s car package to ``out`` (``.tar.gz``); return the path and a summary.

    :param which: ``best``, ``last`` or an iteration number.
    :raises DrxError: unknown model, no checkpoint, bad ``out``, a network the car cannot run.
    """
    out = Path(out)
    if not out.name.endswith(".tar.gz") or len(out.name) == len(".tar.gz"):
        raise SettingError(
            "{field} {value} must be NAME.tar.gz; the car's upload page takes only .tar.gz files.",
            "out",
            value=out,
        )
    model = get_model(name)
    chosen = choose_checkpoint(model, str(which).strip().lower())
    vehicle = model.vehicle()
    algorithm = "sac" if model.algorithm == "sac" else "ppo"
    if chosen.path.suffix == ".pb":  # a model imported from a DeepRacer package: its graph as it came
        graph = chosen.path.read_bytes()
        metadata = json.loads((chosen.path.parent / CAR_METADATA).read_text(encoding="utf-8"))
    else:
        policy = load_policy(chosen.path, vehicle, algorithm)
        lidar_values = int(policy.observation_space["lidar"].shape[0]) if vehicle.lidar else None  # type: ignore[index]
        graph = policy_to_graph(policy, vehicle)  # raises before anything is written
        metadata = car_metadata(vehicle, algorithm, lidar_values)
    with tempfile.TemporaryDirectory(prefix="drx-car-") as tmp:
        work = Path(tmp)
        (work / CAR_MODEL).write_bytes(graph)
        (work / CAR_METADATA).write_text(json.dumps(metadata, indent=2) + "\n", encoding="utf-8")
        write_archive(out, {CAR_MODEL: work / CAR_MODEL, CAR_METADATA: work / CAR_METADATA})
    get_store().put(name, f"exports/{out.name}", out)  # with a bucket: a copy every host can fetch
    summary = {
        "path": str(out),
        "model": name,
        "checkpoint": {"which": which, "iteration": chosen.iteration},
        "files": [CAR_MODEL, CAR_METADATA],
        "car_model_name": out.name[: -len(".tar.gz")],
        "output": output_name(algorithm),
        "metadata": metadata,
        "bytes": out.stat().st_size,
    }
    return out, summary


@dataclass(frozen=True)
class CarArchive:
    """What the car's loader would install from an archive."""

    model_member: str
    metadata: dict[str, Any]
    graph: Any  # the parsed GraphDef
    inputs: tuple[str, ...]  # Placeholder nodes the inference node feeds
    outputs: tuple[str, ...]  # nodes nothing consumes


def _is_model_file(member: str) -> bool:
    """The loader's test: ``os.path.splitext`` gives ``.pb`` (``model_loader_node.get_model_list``)."""
    return os.path.splitext(PurePosixPath(member).name)[1] == ".pb"


def check_car_archive(path: Path) -> CarArchive:
    """Apply the car's loading rules to a ``.tar.gz`` (module docstring).

    :raises DrxError: no or several ``.pb`` files, no ``model_metadata.json`` at the root, not a
        frozen graph, a graph the inference node would feed nothing, or no output.
    """
    path = Path(path)
    archive = path.name
    with open_archive(path) as tar:
        files = checked_members(tar, archive)
        models = sorted(m for m in files if _is_model_file(m))
        if len(models) != 1:
            found = ", ".join(models) or "none"
            raise DrxError(f"{archive} must hold exactly one .pb file for the car's loader (found {found}).")
        if CAR_METADATA not in files:
            raise DrxError(f"{archive} has no {CAR_METADATA} at its root, which the car's loader needs.")
        graph = parse_graph(_read(tar, files[models[0]], archive))
        try:
            metadata = json.loads(_read(tar, files[CAR_METADATA], archive).decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DrxError(f"{archive}: {CAR_METADATA} is not readable JSON ({exc}).") from exc
    placeholders = [n.name for n in graph.node if n.op == "Placeholder"]
    inputs = tuple(n for n in placeholders if any(key in n for key in INFERENCE_INPUT_KEYS))
    if not inputs:
        raise DrxError(
            f"{archive}: no input of the graph has a name the car's inference node feeds "
            f"({', '.join(INFERENCE_INPUT_KEYS)})."
        )
    consumed = {i.lstrip("^").split(":")[0] for n in graph.node for i in n.input}
    outputs = tuple(n.name for n in graph.node if n.name not in consumed and n.op != "Placeholder")
    if not outputs:
        raise DrxError(f"{archive}: the graph has no output node, so the car has nothing to read.")
    return CarArchive(models[0], metadata, graph, inputs, outputs)


def _read(tar: Any, member: Any, archive: str) -> bytes:
    source = tar.extractfile(member)
    if source is None:
        raise DrxError(f"{archive} member {member.name!r} cannot be read.")
    with source:
        return source.read()
