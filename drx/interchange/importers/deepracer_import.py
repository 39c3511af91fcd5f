"""``drx model import`` of a DeepRacer model package: a ``model.pb`` with its ``model_metadata.json``.

Such packages come from the DeepRacer console (a model downloaded for the car),
deepracer-for-cloud (``scripts/upload/upload-car.sh`` tars the training container's
``/opt/ml/model`` folder: ``model_metadata.json`` at the root, the frozen graph in
``agent/model.pb``), a car, or ``drx model export --for-car``. They are read with the car's
own rules (:func:`drx.interchange.car.car_package.check_car_archive`: exactly one ``.pb`` anywhere,
``model_metadata.json`` at the root); everything else in them is ignored, except a
``reward_function.py``, whose text is stored with the model (it is never run: evaluation
needs no reward).

The model keeps its graph and metadata (``model/model.pb``, ``model/model_metadata.json``) and
is driven by OpenVINO (:mod:`drx.interchange.car.openvino_policy`), so ``drx evaluate`` races it on
drx's tracks and ``drx leaderboard`` ranks it. It has no drx checkpoint, so it cannot be
trained further. Everything is checked (the graph loads in OpenVINO and fits the car) before
anything is written; a failure on the way removes what was written.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from sqlalchemy import select

from drx.atomic import write_json_atomic
from drx.errors import AlreadyExistsError, DrxError
from drx.interchange.car.car_package import CAR_METADATA, check_car_archive
from drx.interchange.car.openvino_policy import OpenVINOPolicy, openvino
from drx.interchange.safe_tar import checked_members, extract_files, open_archive
from drx.registry import Checkpoint, Model, RewardSource, VehicleRow, code_sha256, session_scope
from drx.services import garage, tracks
from drx.services.models import model_artifacts_dir
from drx.services.names import ITEM_NAME_RE, check_model_name
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.storage import get_store
from drx.vehicle import Vehicle

REWARD = "reward_function.py"
NO_REWARD = "# {archive} holds no reward function; this model was imported to be evaluated.\n"


def is_deepracer_package(path: Path) -> bool:
    """Whether an archive is a DeepRacer model package (a ``.pb`` and no drx manifest)."""
    from drx.interchange.package.model_package import MANIFEST

    with open_archive(path) as tar:
        names = [m.name.replace("\\", "/").split("/")[-1] for m in tar.getmembers() if m.isfile()]
    return MANIFEST not in names and any(n.endswith(".pb") for n in names)


def _car_for(vehicle: Vehicle, model_name: str) -> tuple[str, bool]:
    """A garage car with the same spec, else a new car named after the model."""

    def spec(v: Vehicle) -> dict[str, Any]:
        return {**v.to_dict(), "name": ""}

    entries = garage.list_vehicles()
    for entry in entries:
        if spec(entry.vehicle) == spec(vehicle):
            return entry.name, False
    taken = {entry.name for entry in entries}
    for name in (model_name, f"{model_name}-car"):
        if name not in taken and ITEM_NAME_RE.fullmatch(name):
            return name, True
    raise AlreadyExistsError(
        f"Car {model_name!r} exists with another action space; import with another --name."
    )


def _check_sensors(driver: OpenVINOPolicy, vehicle: Vehicle, archive: str) -> None:
    """The graph's inputs are the sensors ``model_metadata.json`` names (drx's env feeds those)."""
    channels = 2 if vehicle.sensor == "stereo" else 1
    if driver.channels != channels:
        raise DrxError(
            f"{archive}: model.pb takes {driver.channels}-channel frames but model_metadata.json names "
            f"{'STEREO_CAMERAS' if vehicle.sensor == 'stereo' else 'a single camera'}."
        )
    if bool(driver.lidar) != vehicle.lidar:
        has = "has a lidar input" if driver.lidar else "has no lidar input"
        raise DrxError(f"{archive}: model.pb {has}, which model_metadata.json's sensor list contradicts.")


def import_deepracer_package(archive_path: Path, name: str | None = None, track: str | None = None) -> Any:
    """Register the model in a DeepRacer package (module docstring); return an ``ImportResult``.

    :param name: the model's name here (default: the archive's name up to its first dot, as the car names it).
    :param track: the track the model is evaluated on by default (default: drx's default track).
    :raises DrxError: the car's rules fail, OpenVINO is missing, the graph does not fit its metadata,
        a taken name, an unknown track. Nothing is stored then.
    """
    from drx.interchange.importers.importer import vehicle_from_metadata_file

    archive_path = Path(archive_path)
    archive = archive_path.name
    openvino()  # says how to install it before anything else
    if name is None:
        name = archive.split(".", 1)[0]
        try:
            check_model_name(name)
        except DrxError:
            raise DrxError(f"Model name {name!r} (from the file name) is not allowed; give --name.") from None
    check_model_name(name)
    with session_scope() as session:
        if session.scalar(select(Model.id).where(Model.name == name)) is not None:
            raise AlreadyExistsError(f"Model {name!r} already exists; import with --name NEW-NAME.")
    track_entry = tracks.find_track(track or tracks.DEFAULT_TRACK)  # stored by its canonical name
    track_name, track_path = track_entry.name, track_entry.path
    package = check_car_archive(archive_path)
    with open_archive(archive_path) as tar, tempfile.TemporaryDirectory(prefix="drx-import-") as tmp:
        files = checked_members(tar, archive)
        rewards = [m for m in files if m.split("/")[-1] == REWARD]
        wanted = {k: files[k] for k in (package.model_member, CAR_METADATA, *rewards[:1])}
        work = Path(tmp)
        extract_files(tar, wanted, work, archive)
        graph, metadata = work / package.model_member, work / CAR_METADATA
        vehicle = vehicle_from_metadata_file(metadata, name)
        driver = OpenVINOPolicy(graph, package.metadata)  # loads, and its output fits the action space
        _check_sensors(driver, vehicle, archive)
        code = (work / rewards[0]).read_text(encoding="utf-8", errors="replace") if rewards else None
        car_name, car_new = _car_for(vehicle, name)
        folder = model_artifacts_dir(name)
        try:
            return _register(
                name,
                archive,
                vehicle,
                package.metadata,
                car_name,
                car_new,
                track_name,
                track_path,
                graph,
                code,
                folder,
            )
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise


def _register(
    name: str,
    archive: str,
    vehicle: Vehicle,
    metadata: dict[str, Any],
    car_name: str,
    car_new: bool,
    track_name: str,
    track_path: Path,
    graph: Path,
    code: str | None,
    folder: Path,
) -> Any:
    """Write the model folder and the registry rows (one transaction)."""
    from drx.interchange.importers.importer import ImportResult
    from drx.services.checkpoints import IMPORTED_GRAPH

    if folder.exists():  # left behind by a model of this name that no longer exists
        shutil.rmtree(folder)
    (folder / "model").mkdir(parents=True)
    stored = folder / "model" / IMPORTED_GRAPH
    shutil.copyfile(graph, stored)
    write_json_atomic(folder / "model" / CAR_METADATA, metadata)
    algorithm = "sac" if metadata.get("training_algorithm") == "sac" else "ppo"
    car = Vehicle.from_dict({**vehicle.to_dict(), "name": car_name})
    reward_code = code if code is not None else NO_REWARD.format(archive=archive)
    store = get_store()
    store.push_tree(name)  # with a bucket for artifacts, the files are stored before the rows exist
    with session_scope() as session:
        if car_new:
            session.add(VehicleRow(name=car_name, spec=car.to_dict(), source=f"import {archive}"))
        sha = code_sha256(reward_code)
        if session.get(RewardSource, sha) is None:
            session.add(RewardSource(sha256=sha, code=reward_code, filename=REWARD))
            session.flush()
        model = Model(
            name=name,
            description=f"DeepRacer model imported from {archive} (driven by OpenVINO)",
            vehicle_name=car_name,
            vehicle_spec=car.to_dict(),
            track_name=track_name,
            track_sha256=tracks.file_sha256(track_path),
            reward_sha256=sha,
            reward_filename=REWARD,
            algorithm=algorithm,
            hyperparameters=Hyperparameters.default(algorithm).to_model_json(vehicle.network),
            stop_conditions=StopConditions().to_dict(),
            status="ready",
        )
        session.add(model)
        session.flush()
        session.add(
            Checkpoint(
                model_id=model.id,
                iteration=0,
                path=store.stored_path(name, stored),
                steps=0,
                episodes=0,
                is_best=True,
            )
        )
    notes = [
        f"Its graph runs through OpenVINO; `drx evaluate` races it on {track_name!r} unless given --track."
    ]
    return ImportResult(name, car_name, car_new, track_name, False, sha, 0, folder, notes)
