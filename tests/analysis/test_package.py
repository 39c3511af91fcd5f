"""``drx model export`` / ``drx model import``: package contents, the round trip, and bad packages."""

from __future__ import annotations

import io
import json
import shutil
import tarfile
from pathlib import Path

import numpy as np
import pytest

from drx.analysis.data import load_run
from drx.config import project_root
from drx.interchange.package import model_package as pkg
from drx.registry import Checkpoint, session_scope
from drx.services import garage, tracks
from drx.services import models as model_service
from drx.vehicle import default_vehicle

from ._cli import fails_unchanged, ok_json
from .conftest import use_home

DEEPRACER_HP_KEYS = {
    "batch_size", "beta_entropy", "discount_factor", "e_greedy_value", "epsilon_steps", "exploration_type",
    "loss_type", "lr", "num_episodes_between_training", "num_epochs", "stack_size", "term_cond_avg_score",
    "term_cond_max_episodes", "sac_alpha",
}  # fmt: skip


@pytest.fixture
def package(trained: str, tmp_path: Path) -> Path:
    """The trained model exported (best checkpoint) to ``tmp_path/base.tar.gz``."""
    out = tmp_path / "base.tar.gz"
    data = ok_json("model", "export", trained, "--out", out)
    assert Path(data["path"]) == out
    return out


LAP_KEYS = ("laps_completed", "fastest_lap", "average_lap", "total_time", "off_track_count", "resets", "laps")


def trial(model_name: str) -> dict:
    """``drx evaluate``: a short time trial of the model's best checkpoint (1 lap, at most 3 resets, one seed
    so that two models driving alike drive the same laps)."""
    args = ("evaluate", model_name, "--laps", 1, "--max-resets", 3, "--time-cap-minutes", 0.5, "--seed", 7)
    data = ok_json(*args)
    assert data["status"] == "complete" and data["laps"]
    return {k: data[k] for k in LAP_KEYS}


def test_package_contents(package: Path, trained: str) -> None:
    with tarfile.open(package) as tar:
        names = set(tar.getnames())
        read = {n: tar.extractfile(n).read() for n in names}  # type: ignore[union-attr]
    assert names == {
        pkg.MANIFEST,
        pkg.METADATA,
        pkg.REWARD,
        pkg.HYPERPARAMETERS,
        pkg.ONNX,
        pkg.CHECKPOINT,
        pkg.TRACK,
    }
    meta = json.loads(read[pkg.METADATA])
    assert meta["action_space_type"] == "discrete" and len(meta["action_space"]) == 10
    assert meta["sensor"] == ["FRONT_FACING_CAMERA"] and meta["training_algorithm"] == "clipped_ppo"
    assert meta["neural_network"] and meta["version"]
    hp = json.loads(read[pkg.HYPERPARAMETERS])
    assert set(hp) == DEEPRACER_HP_KEYS and hp["num_episodes_between_training"] == 5
    assert b"def reward_function(params" in read[pkg.REWARD]
    manifest = json.loads(read[pkg.MANIFEST])
    run = load_run(trained)
    assert manifest["model"]["name"] == trained
    assert manifest["checkpoint"]["iteration"] == run.best_iteration
    assert set(manifest["files"]) == names - {pkg.MANIFEST}
    onnx = pytest.importorskip("onnx")
    model = onnx.load_from_string(read[pkg.ONNX])
    assert [i.name for i in model.graph.input] == ["camera"]
    assert [o.name for o in model.graph.output] == ["action_probabilities"]


def test_export_checkpoint_choices(trained: str, tmp_path: Path) -> None:
    run = load_run(trained)
    last = ok_json("model", "export", trained, "--checkpoint", "last", "--out", tmp_path / "last.tar.gz")
    assert last["checkpoint"]["iteration"] == int(run.checkpoints["iteration"].max())
    number = ok_json(
        "model", "export", trained, "--checkpoint", run.best_iteration, "--out", tmp_path / "n.tgz"
    )
    assert number["checkpoint"]["iteration"] == run.best_iteration
    held = {run.best_iteration, int(run.checkpoints["iteration"].max())}
    gone = next(i for i in range(10) if i not in held)
    fails_unchanged("model", "export", trained, "--checkpoint", gone, "--out", tmp_path / "g.tar.gz",
                    contains=f"iteration {gone}")  # fmt: skip
    fails_unchanged("model", "export", trained, "--checkpoint", "first", "--out", tmp_path / "f.tar.gz",
                    contains="--checkpoint 'first' is invalid; use best, last")  # fmt: skip
    fails_unchanged("model", "export", trained, "--out", tmp_path / "x.zip", contains=".tar.gz")
    assert not list(tmp_path.glob("[gfx].*"))


def test_round_trip_import_evaluate_clone(package: Path, trained: str, tmp_path: Path, monkeypatch) -> None:
    expected = trial(trained)
    use_home(monkeypatch, tmp_path / "other_home")
    data = ok_json("model", "import", package)
    # the built-in car has the trained one's spec (DeepRacer's actions, drx's default network)
    assert data["model"] == trained and data["car"] == "default" and data["track"] == "oval"
    model = model_service.get_model(trained)
    assert model.status == "ready"
    assert model.vehicle().to_dict() == {
        **default_vehicle().to_dict(),
        "name": data["car"],
        "network": "compact",
    }
    assert garage.get_vehicle(data["car"]).network == "compact"
    assert trial(trained) == expected  # same laps, times, progress, resets
    again = ok_json("model", "import", package, "--name", "base-2")
    assert again["car"] == data["car"] and not again["car_created"]
    clone = model_service.clone_model("base-2", "base-2-clone")
    with session_scope() as session:
        cp = session.get_one(Checkpoint, clone.parent_checkpoint_id)
        assert Path(cp.path).is_file()
    out = tmp_path / "again.tar.gz"
    ok_json("model", "export", "base-2", "--out", out)
    with tarfile.open(out) as a, tarfile.open(package) as b:
        assert a.extractfile(pkg.ONNX).read() == b.extractfile(pkg.ONNX).read()  # type: ignore[union-attr]


def test_import_existing_name_stores_nothing(package: Path, trained: str) -> None:
    fails_unchanged("model", "import", package, contains="already exists")


def _tar(path: Path, members: dict[str, bytes], links: dict[str, str] | None = None) -> Path:
    with tarfile.open(path, "w:gz") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
        for name, target in (links or {}).items():
            info = tarfile.TarInfo(name)
            info.type = tarfile.SYMTYPE
            info.linkname = target
            tar.addfile(info)
    return path


def _members(package: Path) -> dict[str, bytes]:
    with tarfile.open(package) as tar:
        return {n: tar.extractfile(n).read() for n in tar.getnames()}  # type: ignore[union-attr]


def test_dot_dot_member_is_rejected(package: Path, tmp_path: Path, monkeypatch) -> None:
    members = _members(package)
    use_home(monkeypatch, tmp_path / "home")
    evil = _tar(tmp_path / "evil.tar.gz", {**members, "../escaped.txt": b"gotcha"})
    fails_unchanged("model", "import", evil, contains="'..'")
    absolute = _tar(tmp_path / "abs.tar.gz", {**members, "/tmp/drx-absolute.txt": b"gotcha"})
    fails_unchanged("model", "import", absolute, contains="absolute")
    link = _tar(tmp_path / "link.tar.gz", members, links={"model.onnx.lnk": "/etc/passwd"})
    fails_unchanged("model", "import", link, contains="link")
    assert not (tmp_path / "escaped.txt").exists() and not Path("/tmp/drx-absolute.txt").exists()
    assert not any(p.name == "escaped.txt" for p in tmp_path.rglob("*"))


def test_not_a_drx_export(package: Path, tmp_path: Path, monkeypatch) -> None:
    members = _members(package)
    use_home(monkeypatch, tmp_path / "home")
    plain = _tar(tmp_path / "plain.tar.gz", {k: v for k, v in members.items() if k != pkg.MANIFEST})
    fails_unchanged("model", "import", plain, contains="not a drx export")
    (tmp_path / "junk.tar.gz").write_bytes(b"\x1f\x8b not really gzip")
    fails_unchanged("model", "import", tmp_path / "junk.tar.gz", contains="not a tar.gz")
    damaged = dict(members)
    damaged[pkg.REWARD] = members[pkg.REWARD] + b"\n# edited\n"
    fails_unchanged("model", "import", _tar(tmp_path / "dmg.tar.gz", damaged), contains="sha256")
    fails_unchanged("model", "import", tmp_path / "missing.tar.gz", contains="does not exist")


def _metadata_variant(members: dict[str, bytes], **changes: object) -> dict[str, bytes]:
    meta = json.loads(members[pkg.METADATA])
    meta.update(changes)
    data = json.dumps(meta).encode()
    manifest = json.loads(members[pkg.MANIFEST])
    manifest["files"][pkg.METADATA] = __import__("hashlib").sha256(data).hexdigest()
    return {**members, pkg.METADATA: data, pkg.MANIFEST: json.dumps(manifest).encode()}


def test_bad_metadata_in_package(package: Path, tmp_path: Path, monkeypatch) -> None:
    members = _members(package)
    use_home(monkeypatch, tmp_path / "home")
    sensor = _tar(tmp_path / "s.tar.gz", _metadata_variant(members, sensor=["THERMAL_CAMERA"]))
    fails_unchanged("model", "import", sensor, contains="Unknown sensor")
    fast = json.loads(members[pkg.METADATA])["action_space"]
    fast[0]["speed"] = 9.0
    speed = _tar(tmp_path / "v.tar.gz", _metadata_variant(members, action_space=fast))
    fails_unchanged("model", "import", speed, contains="speed 9")


def test_bare_model_metadata_makes_a_garage_car(tmp_path: Path) -> None:
    meta = default_vehicle().to_model_metadata()
    meta["action_space"] = [{"steering_angle": s, "speed": v} for s, v in ((-20, 1.5), (0, 3.0), (20, 1.5))]
    meta["sensor"] = ["STEREO_CAMERAS", "LIDAR"]
    path = tmp_path / "model_metadata.json"
    path.write_text(json.dumps(meta))
    data = ok_json("model", "import", path, "--name", "stereo-car")
    car = garage.get_vehicle("stereo-car")
    assert data["car"] == "stereo-car" and car.sensor == "stereo" and car.lidar and car.n_actions == 3
    assert [a.speed for a in car.actions] == [1.5, 3.0, 1.5]
    fails_unchanged("model", "import", path, "--name", "stereo-car", contains="already exists")
    meta["sensor"] = ["FRONT_FACING_CAMERA", "RADAR"]
    path.write_text(json.dumps(meta))
    fails_unchanged("model", "import", path, "--name", "radar-car", contains="Unknown sensor")
    meta["sensor"] = ["FRONT_FACING_CAMERA"]
    meta["action_space"][1]["steering_angle"] = 45
    path.write_text(json.dumps(meta))
    fails_unchanged("model", "import", path, "--name", "wide-car", contains="45")
    meta["action_space"] = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.2, "high": 2}}
    meta["action_space_type"] = "continuous"
    path.write_text(json.dumps(meta))
    fails_unchanged("model", "import", path, "--name", "slow-car", contains="0.2")
    path.write_text("{not json")
    fails_unchanged("model", "import", path, "--name", "junk-car", contains="JSON")


def test_model_path(trained: str) -> None:
    data = ok_json("model", "path", trained)
    folder = Path(data["path"])
    assert (folder / "training-simtrace").is_dir() and (folder / "model" / "model_metadata.json").is_file()
    assert np.isfinite(len(list((folder / "training-simtrace").glob("*-iteration.csv"))))
    fails_unchanged("model", "path", "nobody", contains="No model named")


def test_import_brings_its_track(trained: str, tmp_path: Path, monkeypatch) -> None:
    best = Path(load_run(trained).checkpoints.query("is_best")["path"].iloc[0])
    use_home(monkeypatch, tmp_path / "exporter")
    tracks.import_track(project_root() / "drx" / "tracks" / "drx" / "kidney.npy", "my-kidney")
    model = model_service.create_model("on-kidney", track="my-kidney", network="compact")
    folder = model_service.model_artifacts_dir("on-kidney")
    (folder / "model").mkdir(parents=True)
    shutil.copyfile(best, folder / "model" / "best.zip")  # a checkpoint that fits the same car
    with session_scope() as session:
        session.add(
            Checkpoint(model_id=model.id, iteration=2, path=str(folder / "model" / "best.zip"), is_best=True)
        )
    out = tmp_path / "kidney.tar.gz"
    ok_json("model", "export", "on-kidney", "--out", out)
    use_home(monkeypatch, tmp_path / "importer")
    data = ok_json("model", "import", out)
    assert data["track"] == "my-kidney" and data["track_imported"]
    assert tracks.find_track("my-kidney").source == "imported"
    assert model_service.get_model("on-kidney").track_name == "my-kidney"
