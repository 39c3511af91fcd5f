"""``drx model import``: a package from ``drx model export`` back into the registry, or a bare
DeepRacer ``model_metadata.json`` into the garage.

Everything is checked before anything is written: the archive's members (see
:mod:`drx.interchange.safe_tar`), the manifest and every member's hash, the car (sensors,
action ranges), the hyperparameters, the reward code, the checkpoint (it must load and
fit the car), and the names. Then the track (when it is not known here), the car (when
the garage has no identical one), the reward code, the model (status ``ready``) and its
checkpoint are registered; a failure on the way removes what was written.

Trust (docs/SECURITY.md): importing runs nothing from the package. The checkpoint's policy
is rebuilt from the car and read as weights only (:mod:`drx.train.policy_weights`; SB3's
pickled ``data`` is never read). The reward file is compiled (a syntax check, which runs
nothing), stored, hashed and shown, but not run: the model evaluates without it, and
training it (or a clone using it) asks for ``--trust-reward``. ``--trust-reward`` at import
runs its top-level code once, under the reward limits, to check it like ``drx model create``.
A SIGTERM during the import ends it like Ctrl-C: nothing stored, the temporary folder removed.
"""

from __future__ import annotations

import ast
import contextlib
import json
import shutil
import signal
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy import select

from drx.atomic import copy_atomic, write_json_atomic
from drx.errors import AlreadyExistsError, DrxError
from drx.interchange.package import model_package as pkg
from drx.interchange.safe_tar import checked_members, extract_files, open_archive
from drx.registry import Checkpoint, Model, VehicleRow, session_scope
from drx.services import garage, rewards, tracks
from drx.services.models import model_artifacts_dir
from drx.services.names import ITEM_NAME_RE, check_item_name, check_model_name
from drx.settings.car import LEGACY_SIMULATOR, check_simulator
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.sim.reward_loader import FUNCTION_NAME, RewardFunctionError, load_reward_function
from drx.storage import get_store
from drx.train.checkpoint import BEST, LAST, read_meta
from drx.train.policy_weights import load_policy_weights
from drx.vehicle import Vehicle

MAX_REWARD_BYTES = 1 << 20  # [bytes] a reward file larger than this is refused (they are a few KB)
SHA256_HEX = frozenset("0123456789abcdef")


def vehicle_from_metadata_file(path: Path, name: str) -> Vehicle:
    """A car from a DeepRacer ``model_metadata.json``.

    :raises DrxError: unreadable JSON, unknown sensor or network, actions out of DeepRacer's ranges.
    """
    try:
        meta = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DrxError(f"{Path(path).name} is not a readable JSON file ({exc}).") from exc
    if not isinstance(meta, dict) or "action_space" not in meta:
        raise DrxError(f"{Path(path).name} is not a DeepRacer model_metadata.json (it has no action_space).")
    try:
        return Vehicle.from_model_metadata(name, meta)
    except DrxError as exc:
        raise DrxError(f"{Path(path).name}: {exc}") from exc
    except (KeyError, TypeError, ValueError) as exc:
        raise DrxError(
            f"{Path(path).name} has a malformed action_space ({exc!r}); see DeepRacer's format."
        ) from exc


def import_metadata(path: Path, name: str | None = None) -> garage.GarageEntry:
    """Add the car described by a bare ``model_metadata.json`` to the garage.

    :param name: the car's name (default: the folder holding the file, skipping a folder named ``model``).
    """
    path = Path(path)
    if name is None:
        folder = path.resolve().parent
        name = folder.parent.name if folder.name == "model" else folder.name
        try:
            check_item_name(name, "car")
        except DrxError as exc:
            raise DrxError(
                f"Car name {name!r} (from the file's folder) is not allowed; give --name."
            ) from exc
    check_item_name(name, "car")
    vehicle = vehicle_from_metadata_file(path, name)
    return garage.add_vehicle(vehicle, source=str(path))


@dataclass
class ImportResult:
    """What an import registered."""

    model: str
    car: str
    car_created: bool
    track: str
    track_imported: bool
    reward_sha256: str
    checkpoint_iteration: int
    folder: Path
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {**self.__dict__, "folder": str(self.folder)}


def _read_manifest(work: Path, archive: str, members: set[str]) -> dict[str, Any]:
    """The manifest, its shape checked and every listed member's hash verified.

    :param members: the files the archive really holds.
    """
    try:
        manifest = json.loads((work / pkg.MANIFEST).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DrxError(
            f"{archive} has an unreadable {pkg.MANIFEST} ({exc}); it is not a drx export."
        ) from exc
    if not isinstance(manifest, dict) or manifest.get("format") != pkg.FORMAT:
        raise DrxError(
            f"{archive} is not a drx export ({pkg.MANIFEST} does not name the format {pkg.FORMAT})."
        )
    version = manifest.get("format_version", 0)
    if type(version) is not int:
        raise _malformed(archive, "format_version", version, "a whole number")
    if version > pkg.FORMAT_VERSION:
        raise DrxError(f"{archive} was written by a newer drx (format {version}); upgrade drx.")
    files = manifest.get("files")
    if not isinstance(files, dict) or not all(
        isinstance(k, str) and isinstance(v, str) and len(v) == 64 and set(v) <= SHA256_HEX
        for k, v in files.items()
    ):
        raise _malformed(archive, "files", files, "an object of member name -> sha256")
    for key, kind in (("model", dict), ("checkpoint", dict)):
        if not isinstance(manifest.get(key, {}), kind):
            raise _malformed(archive, key, manifest.get(key), "an object")
    for member, digest in files.items():
        if member not in members:
            raise DrxError(
                f"{archive} lacks {member!r}, which its manifest lists; the package is incomplete."
            )
        if pkg.sha256_file(work / member) != digest:
            raise DrxError(
                f"{archive}: {member!r} does not match its recorded sha256; the package is damaged."
            )
    missing = [m for m in (pkg.METADATA, pkg.REWARD, pkg.CHECKPOINT) if m not in files]
    if missing or not isinstance(manifest.get("model"), dict):
        raise DrxError(f"{archive} is not a complete drx export (missing {', '.join(missing) or 'model'}).")
    _check_model_entry(manifest["model"], archive)
    return manifest


MODEL_FIELDS: dict[str, tuple[type, ...]] = {
    "name": (str,), "description": (str, type(None)), "vehicle_name": (str, type(None)),
    "vehicle_spec": (dict,), "track_name": (str,), "algorithm": (str,), "reward_filename": (str, type(None)),
    "hyperparameters": (dict, type(None)), "stop_conditions": (dict, type(None)),
    "parent_name": (str, type(None)),
}  # fmt: skip


def _check_model_entry(m: dict[str, Any], archive: str) -> None:
    """Every manifest value drx reads has the JSON type it should."""
    for key, types in MODEL_FIELDS.items():
        if key in m and not isinstance(m[key], types):
            json_names: dict[type, str] = {dict: "an object", str: "a string", type(None): "null"}
            want = " or ".join(json_names[t] for t in types)
            raise _malformed(archive, f"model.{key}", m[key], want)


def _malformed(archive: str, key: str, value: Any, want: str) -> DrxError:
    shown = repr(value)
    shown = shown if len(shown) <= 40 else shown[:37] + "..."
    return DrxError(
        f"{archive} has a malformed manifest: {key} is {shown}, not {want}; export the model again."
    )


def _check_policy(checkpoint: Path, vehicle: Vehicle, algorithm: str, archive: str) -> None:
    """The checkpoint's weights load into the car's network (weights only: nothing is unpickled)."""
    try:
        policy = load_policy_weights(checkpoint, vehicle, algorithm)
    except DrxError as exc:
        raise DrxError(f"{archive}: {exc}") from exc
    space = policy.action_space
    n = getattr(space, "n", None)
    if (n is None) != vehicle.continuous or (n is not None and int(n) != vehicle.n_actions):
        raise DrxError(
            f"{archive}: the checkpoint's action space {space} does not fit the car ({vehicle.summary()})."
        )


def garage_car_for(vehicle: Vehicle, model_name: str) -> tuple[str, bool]:
    """The garage car to use: any car with the same spec, else a new car named after the car or the model."""

    def spec(v: Vehicle) -> dict[str, Any]:
        return {**v.to_dict(), "name": ""}

    for entry in garage.list_vehicles():
        if spec(entry.vehicle) == spec(vehicle):
            return entry.name, False
    taken = {entry.name for entry in garage.list_vehicles()}
    for name in (vehicle.name, model_name):
        if name not in taken and ITEM_NAME_RE.fullmatch(name):
            return name, True
    raise AlreadyExistsError(
        f"Cars {vehicle.name!r} and {model_name!r} exist with other action spaces; "
        "import with another --name."
    )


def _track_for(
    manifest_model: dict[str, Any], route: Path | None, archive: str
) -> tuple[str, bool, list[str]]:
    name = str(manifest_model.get("track_name") or "")
    try:
        entry = tracks.find_track(name)
        name, path = entry.name, entry.path
    except DrxError:
        if route is None:
            raise DrxError(
                f"{archive} was trained on track {name!r}, which is not known here; import it first."
            ) from None
        check_item_name(name, "track")
        tracks.import_track(route, name)
        return name, True, [f"Imported its track {name!r} from the package."]
    notes = []
    if route is not None and tracks.file_sha256(path) != pkg.sha256_file(route):
        notes.append(
            f"Track {name!r} here differs from the one the model was trained on; the local one is used."
        )
    return name, False, notes


@dataclass
class _Checked:
    """Everything an import writes, checked."""

    name: str
    manifest_model: dict[str, Any]
    vehicle: Vehicle
    car_name: str
    car_new: bool
    hp: dict[str, Any]
    stop: dict[str, Any]
    reward: CheckedReward
    checkpoint: Path
    iteration: int
    archive_path: Path


def _check_package(
    work: Path, manifest: dict[str, Any], name: str | None, archive_path: Path, trust_reward: bool
) -> _Checked:
    """Check the extracted package's model, car, hyperparameters, reward and checkpoint; write nothing."""
    archive = archive_path.name
    m = manifest["model"]
    name = check_model_name(name or str(m.get("name", "")))
    with session_scope() as session:
        if session.scalar(select(Model.id).where(Model.name == name)) is not None:
            raise AlreadyExistsError(f"Model {name!r} already exists; import with --name NEW-NAME.")
    try:
        vehicle = Vehicle.from_dict({**(m.get("vehicle_spec") or {}), "name": m.get("vehicle_name") or name})
    except DrxError as exc:
        raise DrxError(f"{archive}: {exc}") from exc
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DrxError(f"{archive} has a malformed car in its manifest ({exc!r}).") from exc
    meta_vehicle = vehicle_from_metadata_file(work / pkg.METADATA, vehicle.name)
    if meta_vehicle.to_model_metadata()["action_space"] != vehicle.to_model_metadata()["action_space"]:
        raise DrxError(f"{archive}: model_metadata.json and the manifest disagree on the action space.")
    algorithm = str(m.get("algorithm", "ppo"))
    try:
        hp = Hyperparameters.build(algorithm, {}, base=m.get("hyperparameters") or None).to_model_json(
            vehicle.network
        )
        stop = StopConditions().overridden(m.get("stop_conditions")).to_dict()
    except DrxError as exc:
        raise DrxError(f"{archive}: {exc}") from exc
    except (TypeError, ValueError, KeyError, AttributeError) as exc:
        raise DrxError(f"{archive} has malformed hyperparameters or stop conditions ({exc!r}).") from exc
    reward = read_reward(work / pkg.REWARD, archive, trust_reward)
    checkpoint = work / pkg.CHECKPOINT
    _check_policy(checkpoint, vehicle, str(hp["algorithm"]), archive)
    iteration = read_meta(checkpoint).get("iteration", manifest.get("checkpoint", {}).get("iteration", 0))
    if type(iteration) is not int or iteration < 0:
        raise _malformed(archive, "the checkpoint's iteration", iteration, "a whole number >= 0")
    car_name, car_new = garage_car_for(vehicle, name)
    return _Checked(
        name, m, vehicle, car_name, car_new, hp, stop, reward, checkpoint, iteration, archive_path
    )


@dataclass(frozen=True)
class CheckedReward:
    """The package's reward code, checked without running it (or run once, when trusted)."""

    code: str
    filename: str
    trusted: bool


def read_reward(path: Path, archive: str, trust: bool) -> CheckedReward:
    """Read and compile the reward file (compiling runs nothing); run it only when ``trust``."""
    if path.stat().st_size > MAX_REWARD_BYTES:
        raise DrxError(f"{archive}: {pkg.REWARD} is over {MAX_REWARD_BYTES >> 20} MiB; refusing it.")
    try:
        code = path.read_text(encoding="utf-8")
        tree = ast.parse(code, filename=pkg.REWARD)
    except UnicodeDecodeError as exc:
        raise DrxError(f"{archive}: {pkg.REWARD} is not UTF-8 text ({exc}).") from exc
    except SyntaxError as exc:
        raise DrxError(f"{archive}: {pkg.REWARD}, line {exc.lineno}: syntax error: {exc.msg}.") from None
    if not any(isinstance(n, ast.FunctionDef) and n.name == FUNCTION_NAME for n in tree.body):
        raise DrxError(f"{archive}: {pkg.REWARD} defines no function named {FUNCTION_NAME}(params).")
    if trust:
        try:
            load_reward_function(path)
        except RewardFunctionError as exc:
            raise DrxError(f"{archive}: {exc}") from exc
    return CheckedReward(code, pkg.REWARD, trust)


def import_package(archive_path: Path, name: str | None = None, trust_reward: bool = False) -> ImportResult:
    """Register the model in a ``drx model export`` package (module docstring).

    :param name: the model's name here (default: its name in the package).
    :param trust_reward: run the package's reward file once to check it, and let drx train with it.
    :raises DrxError: not a drx export, damaged, unsafe members, bad car, taken name. Nothing is stored then.
    """
    archive_path = Path(archive_path)
    archive = archive_path.name
    with (
        sigterm_as_interrupt(),
        open_archive(archive_path) as tar,
        tempfile.TemporaryDirectory(prefix="drx-import-") as tmp,
    ):
        files = checked_members(tar, archive)
        if pkg.MANIFEST not in files:
            raise DrxError(
                f"{archive} is not a drx export (it has no {pkg.MANIFEST}); make one with `drx model export`."
            )
        work = Path(tmp)
        extract_files(tar, files, work, archive)
        manifest = _read_manifest(work, archive, set(files))
        checked = _check_package(work, manifest, name, archive_path, trust_reward)
        route = work / pkg.TRACK if (work / pkg.TRACK).is_file() else None
        track_name, track_new, notes = _track_for(checked.manifest_model, route, archive)
        if not checked.reward.trusted:
            notes.append(
                "Its reward function was stored but not run; read it with "
                f"`drx reward show {checked.name}` and train with --trust-reward to run it."
            )
        folder = model_artifacts_dir(checked.name)
        try:
            return _register(checked, track_name, track_new, folder, notes)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            if track_new:
                tracks.remove_track(track_name)
            raise


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """A SIGTERM during the import raises KeyboardInterrupt, so every ``finally`` (the temporary
    folder, a half-registered model) runs as for Ctrl-C."""

    def handler(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: nothing to install
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _register(c: _Checked, track_name: str, track_new: bool, folder: Path, notes: list[str]) -> ImportResult:
    """Write the model folder and the registry rows (one transaction)."""
    # a package from before simulator 6 trained on version 5's car, the only one drx had
    simulator = check_simulator(c.manifest_model.get("simulator", LEGACY_SIMULATOR))
    if folder.exists():  # left behind by a model of this name that no longer exists
        shutil.rmtree(folder)
    best = copy_atomic(c.checkpoint, folder / "model" / BEST)
    copy_atomic(c.checkpoint, folder / "model" / LAST)
    car = Vehicle.from_dict({**c.vehicle.to_dict(), "name": c.car_name})
    algorithm = str(c.hp["algorithm"])
    write_json_atomic(folder / "model" / "model_metadata.json", car.to_model_metadata(algorithm, simulator))
    write_json_atomic(
        folder / "ip" / "hyperparameters.json",
        Hyperparameters.from_dict(c.hp).to_deepracer_json(StopConditions.from_dict(c.stop).max_episodes),
    )
    track_path = tracks.find_track(track_name).path
    meta = read_meta(best)
    m = c.manifest_model
    store = get_store()
    store.push_tree(c.name)  # with a bucket for artifacts, the files are stored before the rows exist
    with session_scope() as session:
        if c.car_new and c.car_name != garage.BUILTIN_CAR:
            session.add(
                VehicleRow(name=c.car_name, spec=car.to_dict(), source=f"import {c.archive_path.name}")
            )
        source = rewards.store_reward_code(session, c.reward.code, c.reward.filename, c.reward.trusted)
        model = Model(
            name=c.name,
            description=m.get("description") or f"Imported from {c.archive_path.name}",
            vehicle_name=c.car_name,
            vehicle_spec=car.to_dict(),
            track_name=track_name,
            track_sha256=tracks.file_sha256(track_path),
            reward_sha256=source.sha256,
            reward_filename=str(m.get("reward_filename") or pkg.REWARD),
            algorithm=algorithm,
            hyperparameters=c.hp,
            stop_conditions=c.stop,
            domain_randomization=bool(m.get("domain_randomization", False)),
            simulator=simulator,
            car_randomization=bool(m.get("car_randomization", False)),
            status="ready",
            parent_name=m.get("parent_name"),
        )
        session.add(model)
        session.flush()
        session.add(
            Checkpoint(
                model_id=model.id,
                iteration=c.iteration,
                path=store.stored_path(c.name, best),
                steps=int(meta.get("steps", 0)),
                episodes=int(meta.get("episodes", 0)),
                eval_progress=meta.get("eval_progress"),
                eval_lap_time=meta.get("eval_lap_time"),
                is_best=True,
            )
        )
    return ImportResult(
        c.name, c.car_name, c.car_new, track_name, track_new, source.sha256, c.iteration, folder, notes
    )
