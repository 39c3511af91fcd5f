"""An unreachable database or bucket, refused credentials: one sentence, exit 2, nothing stored.

The PostgreSQL and S3-compatible servers are the ones the tests start on 127.0.0.1
(tests/_servers.py); "unreachable" is a port on 127.0.0.1 nobody listens on.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from _servers import PG_PASSWORD, Postgres, Unavailable, free_port, start_s3

from drx.registry.engine import dispose_engines
from drx.registry.testing import snapshot
from drx.storage import reset_stores

from .helpers import fails, fails_unchanged, ok, ok_json

CREATE = ("model", "create", "m", "--track", "oval", "--network", "compact")


def _use_database(monkeypatch: pytest.MonkeyPatch, url: str) -> None:
    monkeypatch.setenv("DRX_DATABASE_URL", url)
    dispose_engines()


def test_an_unreachable_database_or_a_wrong_password(
    postgres_server: Postgres, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    home = Path(str(tmp_path / "drx_home"))
    wrong = postgres_server.url.replace(PG_PASSWORD, "not-the-password")
    _use_database(monkeypatch, wrong)
    err = fails(
        *CREATE, contains=("Cannot open the registry", "password authentication failed", "DRX_DATABASE_URL")
    )
    assert "not-the-password" not in err  # the password is never printed
    _use_database(monkeypatch, f"postgresql+psycopg://postgres:x@127.0.0.1:{free_port()}/postgres")
    fails(
        "model", "list", contains=("Cannot open the registry at postgresql+psycopg://postgres:***@127.0.0.1",)
    )
    fails(*CREATE, contains="check DRX_DATABASE_URL")
    assert not any(p.is_file() for p in home.rglob("*")), "nothing is written in the data home"
    _use_database(monkeypatch, postgres_server.url)
    from drx.registry.testing import empty_database

    empty_database(postgres_server.url)
    assert ok_json("model", "list") == []  # and nothing reached the real database


def _bucket_env(monkeypatch: pytest.MonkeyPatch, url: str, **env: str) -> None:
    monkeypatch.setenv("DRX_ARTIFACTS_URL", url)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    reset_stores()


def test_an_unusable_bucket_stores_nothing(s3_artifacts: str, monkeypatch: pytest.MonkeyPatch) -> None:
    ok(*CREATE)  # the bucket works
    good = snapshot()
    _bucket_env(monkeypatch, "s3://no-such-bucket-here/x")
    fails_unchanged(*CREATE[:2], "m2", *CREATE[3:], contains=("Bucket 'no-such-bucket-here' does not exist",))
    fails_unchanged("train", "m", "--detach", contains="does not exist")
    fails_unchanged("model", "rm", "m", contains="does not exist")
    _bucket_env(monkeypatch, s3_artifacts, AWS_ENDPOINT_URL=f"http://127.0.0.1:{free_port()}")
    fails_unchanged(
        "train", "m", "--detach", contains=("Cannot reach the artifact store", "AWS_ENDPOINT_URL")
    )
    fails_unchanged("worker", "--exit-when-idle", contains="Cannot reach the artifact store")
    fails_unchanged("evaluate", "m", contains="Cannot reach the artifact store")
    _bucket_env(monkeypatch, "ftp://host/x")
    fails_unchanged(
        *CREATE[:2], "m3", *CREATE[3:], contains="DRX_ARTIFACTS_URL=ftp://host/x is not supported"
    )
    assert snapshot()["rows"] == good["rows"]


def test_refused_credentials_store_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    try:
        server = start_s3(require_auth=True)
    except Unavailable as exc:
        pytest.skip(f"no S3-compatible server can start here: {exc}")
    try:
        _bucket_env(monkeypatch, "s3://drx-team/models", **server.env())
        fails_unchanged(*CREATE, contains=("refused drx's credentials", "AWS_SECRET_ACCESS_KEY"))
        assert ok_json("model", "list") == []
    finally:
        server.stop()


def test_info_shows_the_store(s3_artifacts: str, s3_server: object, monkeypatch: pytest.MonkeyPatch) -> None:
    data = ok_json("info")
    store = data["artifact_store"]
    assert data["artifacts"] == s3_artifacts and store["kind"] == "s3" and store["status"] == "ok"
    assert store["endpoint"] == s3_server.endpoint  # type: ignore[attr-defined]
    assert "artifact cache" in ok("info").stdout
    _bucket_env(monkeypatch, "s3://no-such-bucket-here/x")
    assert "does not exist" in ok_json("info")["artifact_store"]["status"]  # shown, so one can look
