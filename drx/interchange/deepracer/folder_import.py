"""``drx model import`` of DeepRacer's model folder: a model of deepracer-for-cloud, DeepRacer on
AWS or the console becomes a drx model that races at once and trains on.

The folder (or its ``.tar.gz``, or ``s3://bucket/prefix``) is read as DeepRacer's simulator reads
it (:mod:`drx.interchange.deepracer.folder_files`): the car from ``model_metadata.json``, the checkpoint
that ``deepracer_checkpoints.json`` or ``.coach_checkpoint`` names (some copies lose the dot), the
weights of its ``.index``/``.data`` (:mod:`drx.interchange.deepracer.tensor_bundle`, CRC-checked), the
reward, the hyperparameters from ``hyperparameters.json`` (root or ``ip/``), the track and
direction from ``training_params*.yaml``. The weights become a drx PPO policy with DeepRacer's
two towers (``towers`` ``separate``, :mod:`drx.interchange.deepracer.deepracer_weights`) saved as a drx
checkpoint, so ``drx evaluate`` races it, ``drx train`` and ``drx model clone`` continue from it,
and ``--for-deepracer`` exports it back, tower for tower.

Everything is checked before anything is stored, and nothing in the folder runs: the reward is
stored and shown, and runs only with ``--trust-reward`` (:mod:`drx.interchange.importers.importer`).

Not carried over: the optimiser's state (DeepRacer's checkpoint has none) and the value head's
scale. DeepRacer's value head predicts raw returns; drx's PPO divides returns by their running
root-mean-square (:mod:`drx.train.stability`), learnt again in the first iterations of training.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from drx.errors import AlreadyExistsError, DrxError, SettingError
from drx.interchange.deepracer import deepracer_weights as weights
from drx.interchange.deepracer import folder_files as files
from drx.interchange.deepracer.locations import opened
from drx.interchange.deepracer.tensor_bundle import read_bundle, read_index
from drx.settings.car import simulator_of_metadata
from drx.vehicle import Vehicle

MAX_JSON_BYTES = 10 << 20  # [bytes] DeepRacer on AWS refuses metadata files over 10 MB


@dataclass(frozen=True)
class DeepRacerFolder:
    """What a DeepRacer model folder holds, read and checked.

    :param root: the folder (the one holding ``model/``).
    :param vehicle: the car of its ``model_metadata.json`` (``shallow`` network).
    :param checkpoint: the chosen checkpoint's prefix (``.../model/N_Step-M.ckpt``).
    :param hyperparameters: ``hyperparameters.json``'s keys (empty when it has none).
    :param training_params: ``training_params*.yaml``'s keys (empty when it has none).
    :param version: the simulator version its metadata names.
    """

    root: Path
    vehicle: Vehicle
    checkpoint: Path
    hyperparameters: dict[str, Any]
    training_params: dict[str, Any]
    version: str | None

    @property
    def checkpoint_name(self) -> str:
        return self.checkpoint.name

    @property
    def iteration_and_steps(self) -> tuple[int, int]:
        match = files.CHECKPOINT_NAME.match(self.checkpoint.name)
        return (int(match.group(1)), int(match.group(2))) if match else (0, 0)


def _root(path: Path) -> Path | None:
    """The model folder at or one level below ``path`` (an archive often wraps it in a folder)."""
    for candidate in (path, *sorted(p for p in path.iterdir() if p.is_dir())) if path.is_dir() else ():
        if any((candidate / "model").glob("*.ckpt.index")):
            return candidate
    return None


def _json(path: Path, label: str) -> Any:
    if path.stat().st_size > MAX_JSON_BYTES:
        raise DrxError(f"{label} is over {MAX_JSON_BYTES >> 20} MB; it is not a DeepRacer file.")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DrxError(f"{label} is not valid JSON ({exc}); the folder is damaged.") from exc


def _vehicle(root: Path, name: str) -> tuple[Vehicle, str | None, str]:
    """The car of the folder's ``model_metadata.json`` (root copy first, then ``model/``)."""
    path = next((p for p in (root / files.METADATA, root / files.MODEL_METADATA) if p.is_file()), None)
    if path is None:
        raise DrxError(
            f"{root.name} has no model_metadata.json (at its root or in model/); it is not a model folder."
        )
    meta = _json(path, f"{root.name}/{path.relative_to(root)}")
    if not isinstance(meta, dict) or "action_space" not in meta:
        raise DrxError(
            f"{root.name}/{path.relative_to(root)} has no action_space; it is not a model_metadata.json."
        )
    algorithm = str(meta.get("training_algorithm", "clipped_ppo")).lower()
    if algorithm not in ("clipped_ppo", "ppo"):
        raise DrxError(
            f"{root.name} was trained with {algorithm}; drx imports DeepRacer's PPO checkpoints "
            "(clipped_ppo) so far."
        )
    network = meta.get("neural_network", weights.DEEPRACER_NETWORK)
    if network != weights.DEEPRACER_NETWORK:
        raise DrxError(
            f"{root.name} uses the network {network}; drx imports DeepRacer's "
            f"{weights.DEEPRACER_NETWORK} (the network DeepRacer on AWS trains)."
        )
    space = meta.get("action_space")
    if isinstance(space, list) and all(isinstance(a, dict) and "index" in a for a in space):
        meta = {**meta, "action_space": sorted(space, key=lambda a: int(a["index"]))}
    try:
        vehicle = Vehicle.from_model_metadata(name, meta)
    except DrxError as exc:
        raise DrxError(f"{root.name}/{path.name}: {exc}") from exc
    except (KeyError, TypeError, ValueError) as exc:
        raise DrxError(f"{root.name}/{path.name} has a malformed action_space ({exc!r}).") from exc
    weights.check_exportable(vehicle, "ppo")
    version = meta.get("version")
    return vehicle, None if version is None else str(version), path.name


def _checkpoint(root: Path, which: str) -> Path:
    """The prefix of the checkpoint ``which`` names: ``best`` / ``last`` from
    ``deepracer_checkpoints.json``, else the one ``.coach_checkpoint`` names, or ``N_Step-M``."""
    model = root / "model"
    named: str | None = None
    if which not in ("best", "last"):
        named = which if which.endswith(".ckpt") else f"{which}.ckpt"
        if not files.CHECKPOINT_NAME.match(named):
            raise SettingError(
                "{field} {value!r} is invalid; use best, last or N_Step-M.", "checkpoint", value=which
            )
    elif (model / "deepracer_checkpoints.json").is_file():
        index = _json(model / "deepracer_checkpoints.json", f"{root.name}/model/deepracer_checkpoints.json")
        entry = index.get(f"{which}_checkpoint") if isinstance(index, dict) else None
        named = entry.get("name") if isinstance(entry, dict) else None
    if named is None:
        coach = next(
            (p for p in (model / ".coach_checkpoint", model / "coach_checkpoint") if p.is_file()), None
        )
        if coach is not None:
            named = coach.read_text(encoding="utf-8", errors="replace").strip()
    indexes = sorted(p.name.removesuffix(".index") for p in model.glob("*.ckpt.index"))
    if named is None and len(indexes) == 1:
        named = indexes[0]
    if named is None:
        raise DrxError(
            f"{root.name}/model has {len(indexes)} checkpoints and no deepracer_checkpoints.json or "
            ".coach_checkpoint to say which; give --checkpoint N_Step-M."
        )
    if named not in indexes:
        raise DrxError(
            f"{root.name}/model has no {named}.index (it holds {', '.join(indexes) or 'none'}); "
            "give --checkpoint with one of those."
        )
    return model / named


def _optional_json(root: Path, *candidates: str) -> dict[str, Any]:
    for rel in candidates:
        if (root / rel).is_file():
            data = _json(root / rel, f"{root.name}/{rel}")
            if not isinstance(data, dict):
                raise DrxError(f"{root.name}/{rel} is not a JSON object of settings.")
            return data
    return {}


def read_folder(path: Path, which: str = "best", name: str = "imported") -> DeepRacerFolder:
    """Read and check a DeepRacer model folder (nothing is stored, nothing runs).

    :param which: ``best``, ``last`` or a checkpoint name ``N_Step-M``.
    :param name: the car's name, for the :class:`~drx.vehicle.Vehicle`.
    :raises DrxError: a missing file, a checkpoint that does not fit the car, a damaged or absent
        ``.data``, an unknown network, sensor or algorithm: one sentence each.
    """
    root = _root(Path(path))
    if root is None:
        raise DrxError(
            f"{path} holds no model/ folder with a checkpoint (N_Step-M.ckpt.index); it is not "
            "a DeepRacer model folder."
        )
    vehicle, version, _ = _vehicle(root, name)
    checkpoint = _checkpoint(root, which)
    _, entries = read_index(checkpoint.with_name(checkpoint.name + ".index"))
    weights.check_tensor_set({e.name: e.shape for e in entries}, vehicle, checkpoint.name)
    if not (root / files.REWARD).is_file():
        raise DrxError(
            f"{root.name} has no reward_function.py at its root; DeepRacer's model folder needs one."
        )
    params: dict[str, Any] = {}
    yamls = sorted(root.glob("training_params*.yaml"))
    if yamls:
        params = files.read_yaml(
            yamls[0].read_text(encoding="utf-8", errors="replace"), f"{root.name}/{yamls[0].name}"
        )
    hyper = _optional_json(root, files.HYPERPARAMETERS, files.IP_HYPERPARAMETERS)
    return DeepRacerFolder(root, vehicle, checkpoint, hyper, params, version)


def track_of(folder: DeepRacerFolder) -> str | None:
    """The route id its ``training_params.yaml`` names (``WORLD_NAME`` and its direction), or ``None``."""
    world = folder.training_params.get("WORLD_NAME")
    if not world:
        return None
    world = str(world)
    candidates = [world]
    if (
        "TRACK_DIRECTION_CLOCKWISE" in folder.training_params
    ):  # as the simulator: the suffix when the key is there
        cw = files.yaml_bool(folder.training_params["TRACK_DIRECTION_CLOCKWISE"])
        candidates.insert(0, f"{world}_{'cw' if cw else 'ccw'}")
    from drx.services.tracks import find_track

    for candidate in candidates:
        try:
            return find_track(candidate).name
        except DrxError:
            continue
    raise DrxError(
        f"Its training_params.yaml names the track {world!r}, which drx does not have; give --track."
    )


@dataclass
class FolderImport:
    """What ``drx model import`` registered from a DeepRacer model folder."""

    model: str
    car: str
    car_created: bool
    track: str
    checkpoint: str
    iteration: int
    version: str | None
    notes: list[str]

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def import_folder(
    source: str,
    name: str | None = None,
    track: str | None = None,
    which: str = "best",
    trust_reward: bool = False,
) -> FolderImport:
    """Register a DeepRacer model folder as a drx model (see the module docstring).

    :param name: the model's name (default: the folder's ``MODEL_NAME`` or its folder name).
    :param track: the track to train and race on (default: its ``training_params.yaml``'s).
    :param which: ``best``, ``last`` or ``N_Step-M``.
    :param trust_reward: run the reward once to check it, and let drx train with it.
    """
    from drx.interchange.importers.importer import garage_car_for, read_reward, sigterm_as_interrupt
    from drx.services.names import check_model_name

    with sigterm_as_interrupt(), opened(source) as path:
        folder = read_folder(path, which)
        label = Path(source.rstrip("/")).name
        default = str(folder.training_params.get("MODEL_NAME") or label.removesuffix(".tar.gz"))
        name = check_model_name(name or default)
        _check_free(name)
        track_name = track or track_of(folder) or "reinvent_base"
        reward = read_reward(folder.root / files.REWARD, label, trust_reward)
        tensors = read_bundle(folder.checkpoint)  # every CRC checked before anything is stored
        car_name, car_new = garage_car_for(replace(folder.vehicle, name=name), name)
        return _register(folder, tensors, name, car_name, car_new, track_name, reward, label)


def _check_free(name: str) -> None:
    from sqlalchemy import select

    from drx.registry import Model, session_scope

    with session_scope() as session:
        if session.scalar(select(Model.id).where(Model.name == name)) is not None:
            raise AlreadyExistsError(f"Model {name!r} already exists; import with --name NEW-NAME.")


def _hyperparameters(folder: DeepRacerFolder) -> Any:
    from drx.settings.hyperparameters import Hyperparameters

    try:
        return Hyperparameters.from_dict(folder.hyperparameters, "ppo").replace(towers="separate")
    except DrxError as exc:
        raise DrxError(f"{folder.root.name}/hyperparameters.json: {exc}") from exc
    except (TypeError, ValueError) as exc:
        raise DrxError(f"{folder.root.name}/hyperparameters.json has a malformed value ({exc}).") from exc


def _register(
    folder: DeepRacerFolder,
    tensors: dict[str, Any],
    name: str,
    car_name: str,
    car_new: bool,
    track_name: str,
    reward: Any,
    label: str,
) -> FolderImport:
    """Write the drx checkpoint and the registry rows; a failure removes what was written."""
    from drx.atomic import copy_atomic, write_json_atomic
    from drx.registry import Checkpoint, Model, VehicleRow, session_scope
    from drx.services import rewards, tracks
    from drx.services.models import model_artifacts_dir
    from drx.settings.stop import StopConditions
    from drx.storage import get_store
    from drx.train.checkpoint import BEST, LAST, save_checkpoint

    hp = _hyperparameters(folder)
    simulator = simulator_of_metadata(folder.version)[0]  # the car its model_metadata.json names
    vehicle = replace(folder.vehicle, name=car_name)
    entry = tracks.find_track(track_name)
    episodes = _episode_settings(folder, entry.name)
    iteration, steps = folder.iteration_and_steps
    model_dir = model_artifacts_dir(name)
    if model_dir.exists():
        shutil.rmtree(model_dir)
    try:
        algorithm = _algorithm_with(vehicle, hp, tensors)
        meta = {
            "iteration": iteration, "steps": steps, "episodes": 0, "elapsed": 0.0, "network": "shallow",
            "algorithm": "ppo", "towers": "separate", "return_scale": {"rms": None},
            "imported_from": label, "deepracer_checkpoint": folder.checkpoint_name,
        }  # fmt: skip
        best = save_checkpoint(algorithm, model_dir / "model" / BEST, meta)
        copy_atomic(best, model_dir / "model" / LAST)
        metadata = vehicle.to_model_metadata("ppo", simulator)
        write_json_atomic(model_dir / "model" / "model_metadata.json", metadata)
        stop = StopConditions()
        write_json_atomic(model_dir / "ip" / "hyperparameters.json", hp.to_deepracer_json(stop.max_episodes))
        store = get_store()
        store.push_tree(name)
        with session_scope() as session:
            if car_new:
                session.add(VehicleRow(name=car_name, spec=vehicle.to_dict(), source=f"import {label}"))
            source = rewards.store_reward_code(session, reward.code, files.REWARD, reward.trusted)
            model = Model(
                name=name,
                description=f"Imported from DeepRacer's model folder {label}",
                vehicle_name=car_name,
                vehicle_spec=vehicle.to_dict(),
                track_name=entry.name,
                track_sha256=tracks.file_sha256(entry.path),
                reward_sha256=source.sha256,
                reward_filename=files.REWARD,
                algorithm="ppo",
                hyperparameters=hp.to_model_json("shallow"),
                stop_conditions=stop.to_dict(),
                status="ready",
                episode_options=episodes,
                simulator=simulator,
            )
            session.add(model)
            session.flush()
            session.add(Checkpoint(model_id=model.id, iteration=iteration, path=store.stored_path(name, best),
                                   steps=steps, episodes=0, is_best=True))  # fmt: skip
    except BaseException:
        shutil.rmtree(model_dir, ignore_errors=True)
        raise
    notes = []
    if not reward.trusted:
        notes.append(
            f"Its reward function was stored but not run; read it with `drx reward show {name}` and import "
            "with --trust-reward to train it further."
        )
    version_note = _simulator_note(folder.version)
    if version_note:
        notes.append(version_note)
    return FolderImport(
        name, car_name, car_new, entry.name, folder.checkpoint_name, iteration, folder.version, notes
    )


def _simulator_note(version: str | None) -> str | None:
    """What drx says of the simulator version a folder's ``model_metadata.json`` names: nothing when
    drx has that version's car (5, 6: the model gets it), else which car it drives
    (:func:`drx.settings.car.simulator_of_metadata`)."""
    return simulator_of_metadata(version)[1]


def _episode_settings(folder: DeepRacerFolder, track_name: str) -> dict[str, Any]:
    """Where and which way its episodes started, from ``training_params.yaml``'s keys (simapp's
    ``CHANGE_START_POSITION``, ``ROUND_ROBIN_ADVANCE_DIST``, ``START_POSITION_OFFSET``,
    ``ALTERNATE_DRIVING_DIRECTION``; DeepRacer's defaults where a key is absent)."""
    from drx.settings.episodes import EpisodeSettings

    params = folder.training_params
    given: dict[str, Any] = {}
    for key, name in (("CHANGE_START_POSITION", "change_start_position"),
                      ("ALTERNATE_DRIVING_DIRECTION", "alternate_direction")):  # fmt: skip
        if key in params:
            given[name] = files.yaml_bool(params[key])
    try:
        for key, name in (("ROUND_ROBIN_ADVANCE_DIST", "round_robin_advance"),
                          ("START_POSITION_OFFSET", "start_position_offset")):  # fmt: skip
            if key in params:
                given[name] = float(params[key])
        return EpisodeSettings.from_dict(given, track=track_name).to_dict()
    except (DrxError, TypeError, ValueError) as exc:
        raise DrxError(f"{folder.root.name}/training_params.yaml: {exc}") from exc


def _algorithm_with(vehicle: Vehicle, hp: Any, tensors: dict[str, Any]) -> Any:
    """drx's PPO for the car, with DeepRacer's two towers holding the checkpoint's weights."""
    from drx.sim.env import DeepRacerEnv
    from drx.train.algorithms import build_algorithm

    algorithm = build_algorithm(DeepRacerEnv(track="oval", vehicle=vehicle), "shallow", hp)
    algorithm.policy.load_state_dict(weights.policy_state(tensors, vehicle), strict=True)
    return algorithm
