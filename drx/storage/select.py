"""``DRX_ARTIFACTS_URL`` -> the artifact store (one per URL and process)."""

from __future__ import annotations

import os
import threading
from pathlib import Path
from urllib.parse import urlparse

from drx.errors import DrxError
from drx.storage.base import ArtifactStore, LocalStore

URL_ENV = "DRX_ARTIFACTS_URL"

_stores: dict[tuple[str, str], ArtifactStore] = {}
_lock = threading.Lock()


def store_url() -> str:
    """``$DRX_ARTIFACTS_URL``, default the data home's ``artifacts`` folder."""
    from drx.config import data_home

    return os.environ.get(URL_ENV) or str(data_home() / "artifacts")


def parse_s3_url(url: str) -> tuple[str, str]:
    """``s3://bucket/some/prefix`` -> ``("bucket", "some/prefix")``.

    :raises DrxError: no bucket name, or one S3 does not accept.
    """
    parsed = urlparse(url)
    bucket, prefix = parsed.netloc, parsed.path.strip("/")
    if not bucket or not (3 <= len(bucket) <= 63) or any(c not in _BUCKET_CHARS for c in bucket):
        raise DrxError(
            f"{URL_ENV}={url} does not name an S3 bucket; use s3://bucket/prefix "
            "(a bucket name is 3-63 lower-case letters, digits, dots and hyphens)."
        )
    return bucket, prefix


_BUCKET_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789.-")


def _build(url: str, home: Path) -> ArtifactStore:
    scheme = urlparse(url).scheme.lower()
    if scheme == "s3":
        from drx.storage.s3 import S3Store

        bucket, prefix = parse_s3_url(url)
        cache = home / "cache" / "s3" / bucket / (prefix or "_")
        return S3Store(url, bucket, prefix, cache)
    if scheme == "file":
        return LocalStore(url, Path(urlparse(url).path))
    if scheme and len(scheme) > 1:  # a Windows drive letter is not a scheme
        raise DrxError(
            f"{URL_ENV}={url} is not supported; use s3://bucket/prefix (AWS S3, MinIO, Ceph...) "
            "or a local folder."
        )
    return LocalStore(url, Path(url).expanduser())


def get_store() -> ArtifactStore:
    """The artifact store ``$DRX_ARTIFACTS_URL`` names (for this data home).

    :raises DrxError: an unsupported URL.
    """
    from drx.config import data_home

    url, home = store_url(), data_home()
    key = (url, str(home))
    with _lock:
        store = _stores.get(key)
        if store is None:
            store = _stores[key] = _build(url, home)
    return store


def artifacts_dir() -> Path:
    """Local folder holding every model's files (checkpoints, traces, exports).

    ``$DRX_ARTIFACTS_URL`` names the artifact store (:func:`get_store`), default the data home's
    ``artifacts`` folder; with a bucket (``s3://...``) this is this host's cache of it.
    """
    path = get_store().root
    path.mkdir(parents=True, exist_ok=True)
    return path


def reset_stores() -> None:
    """Forget the stores made so far (tests switch URLs and data homes)."""
    with _lock:
        _stores.clear()
