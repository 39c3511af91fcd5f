"""The artifact store on an S3-compatible server the tests start (moto, tests/_servers.py).

Two data homes stand for two hosts sharing one bucket: what one pushes the other pulls, a
cached copy is fetched once, uploads and downloads are whole or not at all.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from drx.errors import DrxError
from drx.storage import cache, get_store, reset_stores
from drx.storage.s3 import S3Store


def _host(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, name: str) -> S3Store:
    """Switch to another data home (a host), same bucket."""
    monkeypatch.setenv("DRX_HOME", str(tmp_path / name))
    reset_stores()
    store = get_store()
    assert isinstance(store, S3Store)
    return store


def _count_gets(store: S3Store, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    gets: list[str] = []
    original = store.client.get_object

    def counting(**kwargs: object) -> object:
        gets.append(str(kwargs["Key"]))
        return original(**kwargs)

    monkeypatch.setattr(store.client, "get_object", counting)
    return gets


def test_one_host_pushes_the_other_pulls_once(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = _host(monkeypatch, tmp_path, "host-a")
    a.check()
    last = a.model_dir("m") / "model" / "last.zip"
    last.parent.mkdir(parents=True)
    last.write_bytes(b"weights v1" * 1000)
    (a.model_dir("m") / "training-simtrace").mkdir()
    (a.model_dir("m") / "training-simtrace" / "0-iteration.csv").write_text("episode,steps\n0,1\n")
    a.push_tree("m")
    stored = a.stored_path("m", last)
    assert stored == f"{s3_artifacts}/models/m/model/last.zip"
    assert a.listing("m", "training-simtrace") == ["training-simtrace/0-iteration.csv"]

    b = _host(monkeypatch, tmp_path, "host-b")
    gets = _count_gets(b, monkeypatch)
    assert b.model_dir("m") != a.model_dir("m")
    local = b.local_path(stored)
    assert local == b.model_dir("m") / "model" / "last.zip" and local.read_bytes() == last.read_bytes()
    b.pull("m", "model/last.zip")
    b.pull_tree("m", ["model"])
    assert gets == ["team/models/m/model/last.zip"]  # cached: fetched once
    b.pull_tree("m")
    assert (b.model_dir("m") / "training-simtrace" / "0-iteration.csv").is_file()

    last.write_bytes(b"weights v2" * 1000)  # host A's next checkpoint
    a.push("m", "model/last.zip")
    b.pull("m", "model/last.zip")
    assert local.read_bytes() == last.read_bytes() and len(gets) == 3
    local.write_bytes(b"rewritten here")  # a local rewrite makes the copy stale: fetched again
    b.pull("m", "model/last.zip")
    assert local.read_bytes() == last.read_bytes()
    assert not [p for p in local.parent.iterdir() if p.name.startswith(".")]  # no temporary left


def test_a_removed_object_drops_the_copy_but_never_an_unstored_file(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = _host(monkeypatch, tmp_path, "host-a")
    folder = a.model_dir("m") / "model"
    folder.mkdir(parents=True)
    (folder / "last.zip").write_bytes(b"x")
    a.push("m", "model/last.zip")
    b = _host(monkeypatch, tmp_path, "host-b")
    b.pull("m", "model/last.zip", "model/best.zip")
    mine = b.model_dir("m") / "model" / "best.zip"
    mine.write_bytes(b"made on host b, not stored yet")
    a.remove_model("m")  # e.g. removed on host A (and made again later under the same name)
    assert a.listing("m", "") == [] and not a.model_dir("m").exists()
    b.pull_tree("m", ["model"])
    assert not (b.model_dir("m") / "model" / "last.zip").exists()
    assert mine.read_bytes() == b"made on host b, not stored yet"


def test_an_upload_cut_short_leaves_the_stored_object_whole(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = _host(monkeypatch, tmp_path, "host-a")
    path = store.model_dir("m") / "model" / "last.zip"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"good" * 50_000)
    store.push("m", "model/last.zip")
    path.write_bytes(b"next" * 50_000)
    original = store.client.put_object

    class Broken:
        """A body that fails halfway, as a killed host's upload does."""

        def __init__(self, body: object) -> None:
            self.body, self.sent = body, 0

        def read(self, n: int = -1) -> bytes:
            if self.sent > 50_000:
                raise ConnectionResetError("connection lost halfway")
            chunk = self.body.read(n if n and n > 0 else 8192)  # type: ignore[attr-defined]
            self.sent += len(chunk)
            return chunk

        def __getattr__(self, name: str) -> object:
            return getattr(self.body, name)

    def half(**kwargs: object) -> object:
        kwargs["Body"] = Broken(kwargs["Body"])
        return original(**kwargs)

    monkeypatch.setattr(store.client, "put_object", half)
    with pytest.raises(Exception, match="halfway|connection|Connection"):
        store.push("m", "model/last.zip")
    monkeypatch.setattr(store.client, "put_object", original)
    other = _host(monkeypatch, tmp_path, "host-b")
    other.pull("m", "model/last.zip")
    assert (other.model_dir("m") / "model" / "last.zip").read_bytes() == b"good" * 50_000


def test_a_download_cut_short_keeps_the_previous_copy(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = _host(monkeypatch, tmp_path, "host-a")
    path = a.model_dir("m") / "model" / "last.zip"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"v1" * 10_000)
    a.push("m", "model/last.zip")
    b = _host(monkeypatch, tmp_path, "host-b")
    b.pull("m", "model/last.zip")
    path.write_bytes(b"v2" * 10_000)
    a.push("m", "model/last.zip")
    original = b.client.get_object

    def cut(**kwargs: object) -> dict[str, object]:
        response = dict(original(**kwargs))

        class Body:
            def read(self, n: int = -1) -> bytes:
                raise ConnectionResetError("connection lost halfway")

        response["Body"] = Body()
        return response

    monkeypatch.setattr(b.client, "get_object", cut)
    with pytest.raises(ConnectionResetError):
        b.pull("m", "model/last.zip")
    copy = b.model_dir("m") / "model" / "last.zip"
    assert copy.read_bytes() == b"v1" * 10_000
    assert [p.name for p in copy.parent.iterdir()] == ["last.zip"]
    monkeypatch.setattr(b.client, "get_object", original)
    b.pull("m", "model/last.zip")
    assert copy.read_bytes() == b"v2" * 10_000
    assert cache.unchanged(b.model_dir("m"), "model/last.zip") is not None


def test_unusable_stores_are_one_sentence(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from _servers import free_port

    def fails(url: str, *words: str) -> str:
        monkeypatch.setenv("DRX_ARTIFACTS_URL", url)
        reset_stores()
        with pytest.raises(DrxError) as info:
            get_store().check()
        text = str(info.value)
        assert "\n" not in text and all(w in text for w in words), text
        return text

    fails("s3://no-such-bucket-here/x", "Bucket 'no-such-bucket-here' does not exist", "create it")
    fails("gs://bucket/x", "DRX_ARTIFACTS_URL=gs://bucket/x is not supported", "s3://bucket/prefix")
    fails("s3://B_ad/x", "does not name an S3 bucket")
    monkeypatch.setenv("AWS_ENDPOINT_URL", f"http://127.0.0.1:{free_port()}")
    fails(s3_artifacts, "Cannot reach the artifact store", "AWS_ENDPOINT_URL")
    for key in ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_ENDPOINT_URL"):
        monkeypatch.delenv(key)
    monkeypatch.setenv("AWS_SHARED_CREDENTIALS_FILE", str(tmp_path / "none"))
    monkeypatch.setenv("AWS_CONFIG_FILE", str(tmp_path / "none"))
    monkeypatch.setenv("AWS_EC2_METADATA_DISABLED", "true")
    fails(s3_artifacts, "No AWS credentials", "AWS_ACCESS_KEY_ID")
    assert os.environ["DRX_ARTIFACTS_URL"] == s3_artifacts


def test_refused_credentials_are_one_sentence(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from _servers import Unavailable, start_s3

    try:
        server = start_s3(require_auth=True)  # checks keys: drx's are unknown to it
    except Unavailable as exc:
        pytest.skip(f"no S3-compatible server can start here: {exc}")
    try:
        for key, value in server.env().items():
            monkeypatch.setenv(key, value)
        monkeypatch.setenv("DRX_ARTIFACTS_URL", "s3://drx-team/models")
        reset_stores()
        with pytest.raises(DrxError, match="refused drx's credentials .*; check AWS_ACCESS_KEY_ID"):
            get_store().check()
    finally:
        server.stop()
