"""``drx model import`` runs nothing from a package: crafted pickles, rewards, bombs and manifests."""

from __future__ import annotations

import base64
import hashlib
import io
import json
import os
import pickle
import signal
import subprocess
import sys
import tarfile
import tempfile
import time
import zipfile
from pathlib import Path

import pytest
import torch as th

from drx.interchange import safe_tar
from drx.interchange.package import model_package as pkg
from drx.registry import RewardSource, session_scope
from drx.services import models as model_service

from ._cli import fails_unchanged, invoke, ok_json
from .conftest import use_home

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def members(trained: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, bytes]:
    """The trained model's package as ``{member: bytes}``; the test then runs in an empty home."""
    out = tmp_path / "base.tar.gz"
    ok_json("model", "export", trained, "--out", out)
    with tarfile.open(out) as tar:
        data = {n: tar.extractfile(n).read() for n in tar.getnames()}  # type: ignore[union-attr]
    use_home(monkeypatch, tmp_path / "home")
    return data


def _package(path: Path, members: dict[str, bytes], **replace: bytes) -> Path:
    """A package with some members replaced and the manifest's hashes made to match."""
    files = {**members, **replace}
    manifest = json.loads(files[pkg.MANIFEST])
    for name in replace:
        if name in manifest["files"]:
            manifest["files"][name] = hashlib.sha256(replace[name]).hexdigest()
    files[pkg.MANIFEST] = json.dumps(manifest).encode()
    with tarfile.open(path, "w:gz") as tar:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


class _Payload:
    """Unpickling this creates a file: the proof that a pickle ran."""

    def __init__(self, mark: Path) -> None:
        self.mark = mark

    def __reduce__(self) -> tuple:
        return (Path.touch, (self.mark,))


def _checkpoint_with(checkpoint: bytes, **members: bytes) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(checkpoint)) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            dst.writestr(item, members.get(item.filename, src.read(item.filename)))
    return out.getvalue()


def test_a_pickle_in_sb3_data_is_never_run(members: dict[str, bytes], tmp_path: Path) -> None:
    mark = tmp_path / "pwned"
    data = json.loads(zipfile.ZipFile(io.BytesIO(members[pkg.CHECKPOINT])).read("data"))
    payload = base64.b64encode(pickle.dumps(_Payload(mark))).decode()
    for key in ("policy_class", "observation_space", "action_space", "lr_schedule"):
        data[key] = {":type:": "<class 'object'>", ":serialized:": payload}
    checkpoint = _checkpoint_with(members[pkg.CHECKPOINT], data=json.dumps(data).encode())
    package = _package(tmp_path / "p.tar.gz", members, **{pkg.CHECKPOINT: checkpoint})
    result = ok_json("model", "import", package)
    assert not mark.exists()
    assert ok_json("evaluate", result["model"], "--laps", 1, "--max-resets", 1, "--time-cap-minutes", 0.2)
    assert not mark.exists()  # evaluating reads weights only too


def test_a_pickle_in_the_weights_is_refused(members: dict[str, bytes], tmp_path: Path) -> None:
    mark = tmp_path / "pwned"
    buffer = io.BytesIO()
    th.save({"weights": _Payload(mark)}, buffer)
    checkpoint = _checkpoint_with(members[pkg.CHECKPOINT], **{"policy.pth": buffer.getvalue()})
    package = _package(tmp_path / "p.tar.gz", members, **{pkg.CHECKPOINT: checkpoint})
    fails_unchanged("model", "import", package, contains="holds more than weights and is refused")
    assert not mark.exists()


def test_the_reward_is_stored_not_run_until_trusted(members: dict[str, bytes], tmp_path: Path) -> None:
    mark = tmp_path / "ran"
    code = (
        f"import pathlib\npathlib.Path({str(mark)!r}).touch()\nwhile True:\n    pass\n\n\n"
        "def reward_function(params):\n    return 1.0\n"
    )
    package = _package(tmp_path / "p.tar.gz", members, **{pkg.REWARD: code.encode()})
    t0 = time.monotonic()
    result = ok_json("model", "import", package)
    assert time.monotonic() - t0 < 60 and not mark.exists()
    assert any("--trust-reward" in note for note in result["notes"])
    with session_scope() as session:
        row = session.get_one(RewardSource, result["reward_sha256"])
        assert row.code == code and not row.trusted
    shown = ok_json("reward", "show", result["model"])
    assert shown["code"] == code
    clone = model_service.clone_model(result["model"], "clone")
    for name in (result["model"], clone.name):
        err = fails_unchanged("train", name, "--detach", contains="has not run")
        assert "--trust-reward" in err and f"drx reward show {name}" in err
    assert not mark.exists()


def test_trust_reward_runs_it_under_the_limits(
    members: dict[str, bytes], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from drx.sim import reward_guard

    monkeypatch.setattr(reward_guard, "LOAD_TIME_LIMIT", 0.3)
    code = "while True:\n    pass\n\n\ndef reward_function(params):\n    return 1.0\n"
    package = _package(tmp_path / "p.tar.gz", members, **{pkg.REWARD: code.encode()})
    fails_unchanged("model", "import", package, "--trust-reward", contains="ran longer than 0.3 s")
    result = ok_json("model", "import", _package(tmp_path / "ok.tar.gz", members), "--trust-reward")
    with session_scope() as session:
        assert session.get_one(RewardSource, result["reward_sha256"]).trusted
    assert invoke("train", result["model"], "--detach").exit_code == 0


def test_an_untrusted_reward_is_trusted_by_train_trust_reward(
    members: dict[str, bytes], tmp_path: Path
) -> None:
    result = ok_json("model", "import", _package(tmp_path / "p.tar.gz", members))
    fails_unchanged("train", result["model"], "--detach", contains="has not run")
    assert invoke("train", result["model"], "--detach", "--trust-reward").exit_code == 0
    with session_scope() as session:
        assert session.get_one(RewardSource, result["reward_sha256"]).trusted


def test_a_reward_without_reward_function_or_with_bad_syntax(
    members: dict[str, bytes], tmp_path: Path
) -> None:
    no_fn = _package(tmp_path / "a.tar.gz", members, **{pkg.REWARD: b"def other(params):\n    return 1\n"})
    fails_unchanged("model", "import", no_fn, contains="defines no function named reward_function")
    bad = _package(tmp_path / "b.tar.gz", members, **{pkg.REWARD: b"def reward_function(params)\n"})
    fails_unchanged("model", "import", bad, contains="line 1: syntax error")


def _raw_tar(path: Path, entries: list[tuple[str, int, bytes | None]]) -> Path:
    """A tar.gz of (name, size, data or None for zeros) entries, streamed (bombs stay small)."""
    with tarfile.open(path, "w:gz", compresslevel=1) as tar:
        for name, size, data in entries:
            info = tarfile.TarInfo(name)
            info.size = size
            tar.addfile(info, io.BytesIO(data) if data is not None else _Zeros(size))
    return path


class _Zeros(io.RawIOBase):
    def __init__(self, size: int) -> None:
        self.left = size

    def readinto(self, b: bytearray) -> int:  # type: ignore[override]
        n = min(len(b), self.left)
        b[:n] = bytes(n)
        self.left -= n
        return n

    def read(self, n: int = -1) -> bytes:
        n = self.left if n < 0 else min(n, self.left)
        self.left -= n
        return bytes(n)


def _no_temporaries() -> list[str]:
    return [p.name for p in Path(tempfile.gettempdir()).glob("drx-import-*")]


def test_bombs_by_ratio_and_by_count(
    members: dict[str, bytes], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(safe_tar, "MAX_TOTAL_BYTES", 8 << 20)  # a small cap keeps the test fast
    before = _no_temporaries()
    entries = [(n, len(d), d) for n, d in members.items()]
    ratio = _raw_tar(tmp_path / "ratio.tar.gz", [*entries, ("zeros.bin", 64 << 20, None)])
    assert ratio.stat().st_size < 4 << 20  # 64 MiB of zeros in well under 1 MiB, beside the package
    fails_unchanged("model", "import", ratio, contains="unpacks to more than 8 MiB")
    many = _raw_tar(tmp_path / "many.tar.gz", [*entries, *[(f"f{i}", 1, b"x") for i in range(100_000)]])
    t0 = time.monotonic()
    fails_unchanged("model", "import", many, contains="more than 64 members")
    assert time.monotonic() - t0 < 10
    assert _no_temporaries() == before


def test_bytes_are_counted_while_extracting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A header that understates its size cannot slip past: the cap counts bytes written."""
    archive = _raw_tar(tmp_path / "a.tar.gz", [("a.bin", 3 << 20, None), ("b.bin", 3 << 20, None)])
    monkeypatch.setattr(safe_tar, "MAX_TOTAL_BYTES", 4 << 20)
    with safe_tar.open_archive(archive) as tar:
        files = {m.name: m for m in tar.getmembers()}  # skipping the declared-size check
        target = tmp_path / "out"
        target.mkdir()
        with pytest.raises(safe_tar.DrxError, match="unpacks to more than 4 MiB"):
            safe_tar.extract_files(tar, files, target, "a.tar.gz")


@pytest.mark.parametrize(
    "change, said",
    [
        ({"format_version": "two"}, "format_version is 'two', not a whole number"),
        ({"files": ["drx_checkpoint.zip"]}, "files is ['drx_checkpoint.zip'], not an object"),
        ({"model": {"hyperparameters": "fast"}}, "model.hyperparameters is 'fast', not an object or null"),
        ({"model": {"name": 7}}, "model.name is 7, not a string"),
        ({"model": {"stop_conditions": {"max_minutes": "soon"}}}, "stop conditions"),
        ({"files": {"../../etc/passwd": "0" * 64}}, "lacks '../../etc/passwd'"),
    ],
)
def test_malformed_manifests_exit_2_with_one_sentence(
    members: dict[str, bytes], tmp_path: Path, change: dict, said: str
) -> None:
    manifest = json.loads(members[pkg.MANIFEST])
    for key, value in change.items():
        if key == "model":
            manifest["model"].update(value)
        elif key == "files" and isinstance(value, dict):
            manifest["files"].update(value)
        else:
            manifest[key] = value
    files = {**members, pkg.MANIFEST: json.dumps(manifest).encode()}
    path = tmp_path / "m.tar.gz"
    with tarfile.open(path, "w:gz") as tar:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    fails_unchanged("model", "import", path, contains=said)


def test_sigterm_during_import_leaves_no_temporary_folder(members: dict[str, bytes], tmp_path: Path) -> None:
    """An import killed with SIGTERM while it works removes its temporary folder and stores nothing."""
    package = _package(tmp_path / "p.tar.gz", members)
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    env = {**os.environ, "TMPDIR": str(tmpdir), "PYTHONPATH": str(ROOT)}
    code = (
        "import time, drx.interchange.importers.importer as imp\n"
        "real = imp._read_manifest\n"
        "def slow(*a, **k):\n    print('extracted', flush=True)\n    time.sleep(30)\n"
        "    return real(*a, **k)\n"
        "imp._read_manifest = slow\n"
        f"imp.import_package({str(package)!r})\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == b"extracted"
    assert list(tmpdir.glob("drx-import-*"))
    proc.send_signal(signal.SIGTERM)
    proc.wait(30)
    assert proc.returncode != 0
    assert not list(tmpdir.glob("drx-import-*"))
    assert invoke("model", "list", "--json").exit_code == 0
