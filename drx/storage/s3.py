"""Model artifacts in AWS S3 or any S3-compatible store (MinIO, Ceph), through boto3.

``DRX_ARTIFACTS_URL=s3://bucket/prefix`` keeps model ``m``'s files under
``prefix/models/m/`` in the bucket. boto3 reads the endpoint and the credentials from the
standard AWS environment (``AWS_ENDPOINT_URL`` or ``AWS_ENDPOINT_URL_S3``,
``AWS_ACCESS_KEY_ID`` / ``AWS_SECRET_ACCESS_KEY`` or ``AWS_PROFILE``, ``AWS_REGION``), as the
AWS CLI does; deepracer-for-cloud names the same things ``DR_LOCAL_S3_BUCKET``,
``DR_LOCAL_S3_PROFILE`` and ``DR_REMOTE_MINIO_URL`` (aws-deepracer-community/deepracer-for-cloud,
``defaults/template-system.env``). With a custom endpoint drx asks for path-style addresses,
which MinIO and Ceph need.

Writes are atomic on both sides: an upload is one ``PutObject`` (S3 replaces an object only
once the whole body arrived, so no reader sees half a checkpoint under its name), and a
download goes to a temporary file in the cache that is renamed into place.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterable, Iterator
from functools import cached_property
from pathlib import Path
from typing import Any

from drx.atomic import atomic_write
from drx.errors import DrxError
from drx.storage import cache
from drx.storage.base import MODELS, ArtifactStore

CONNECT_TIMEOUT = 5  # [s] an unreachable endpoint fails in seconds, not minutes
READ_TIMEOUT = 60  # [s]
CREDENTIAL_CODES = {
    "InvalidAccessKeyId", "SignatureDoesNotMatch", "AccessDenied", "InvalidToken", "ExpiredToken",
    "InvalidSecurity", "403", "Forbidden", "AuthorizationHeaderMalformed",
}  # fmt: skip
MISSING_BUCKET_CODES = {"NoSuchBucket", "404", "NotFound"}


def endpoint_from_environment() -> str | None:
    """The custom endpoint the standard AWS variables name (``None``: AWS itself)."""
    return os.environ.get("AWS_ENDPOINT_URL_S3") or os.environ.get("AWS_ENDPOINT_URL") or None


class S3Store(ArtifactStore):
    """A bucket (and key prefix) holding model files; this host's copies live in ``cache_root``.

    :param url: ``s3://bucket/prefix``.
    :param bucket: the bucket.
    :param prefix: the key prefix (may be empty).
    :param cache_root: the local folder holding ``models/<name>/`` copies.
    """

    remote = True

    def __init__(self, url: str, bucket: str, prefix: str, cache_root: Path) -> None:
        super().__init__(url, cache_root)
        self.bucket = bucket
        self.prefix = prefix.strip("/")
        self._checked = False

    # ----- the client and its errors --------------------------------------------
    @cached_property
    def client(self) -> Any:
        """A boto3 S3 client configured from the environment."""
        try:
            import boto3
            from botocore.config import Config
        except ImportError:
            raise DrxError(
                f"DRX_ARTIFACTS_URL={self.url} needs boto3; install it with `pip install 'drx[s3]'`."
            ) from None
        endpoint = endpoint_from_environment()
        config = Config(
            connect_timeout=CONNECT_TIMEOUT,
            read_timeout=READ_TIMEOUT,
            retries={"max_attempts": 3, "mode": "standard"},
            s3={"addressing_style": "path"} if endpoint else None,
        )
        with self._errors():
            return boto3.session.Session().client("s3", endpoint_url=endpoint, config=config)

    def endpoint(self) -> str:
        """The endpoint URL requests go to."""
        return endpoint_from_environment() or "AWS S3"

    @contextlib.contextmanager
    def _errors(self) -> Iterator[None]:
        """Turn boto3's errors into one sentence naming the store and the fix."""
        from botocore import exceptions as bex

        try:
            yield
        except (bex.NoCredentialsError, bex.PartialCredentialsError):
            raise DrxError(
                f"No AWS credentials for the artifact store {self.url}; set AWS_ACCESS_KEY_ID and "
                "AWS_SECRET_ACCESS_KEY (or AWS_PROFILE)."
            ) from None
        except (bex.EndpointConnectionError, bex.ConnectTimeoutError, bex.ReadTimeoutError) as exc:
            raise DrxError(
                f"Cannot reach the artifact store {self.url} at {self.endpoint()} ({_first_line(exc)}); "
                "check DRX_ARTIFACTS_URL and AWS_ENDPOINT_URL."
            ) from None
        except bex.ClientError as exc:
            raise self._client_error(exc) from None
        except bex.BotoCoreError as exc:
            raise DrxError(
                f"The artifact store {self.url} at {self.endpoint()} failed ({_first_line(exc)}); "
                "check DRX_ARTIFACTS_URL and the AWS_* settings."
            ) from None

    def _client_error(self, exc: Any) -> DrxError:
        error = exc.response.get("Error", {})
        code = str(error.get("Code") or exc.response.get("ResponseMetadata", {}).get("HTTPStatusCode"))
        if code in CREDENTIAL_CODES:
            return DrxError(
                f"The artifact store {self.url} at {self.endpoint()} refused drx's credentials ({code}); "
                "check AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY (or AWS_PROFILE)."
            )
        if code == "NoSuchBucket":
            return self._missing_bucket()
        message = str(error.get("Message") or "").rstrip(".")
        return DrxError(
            f"The artifact store {self.url} at {self.endpoint()} answered {code}"
            + (f" ({message})" if message else "")
            + "; check DRX_ARTIFACTS_URL and the AWS_* settings."
        )

    def _missing_bucket(self) -> DrxError:
        return DrxError(
            f"Bucket {self.bucket!r} does not exist at {self.endpoint()}; create it "
            f"(`aws s3 mb s3://{self.bucket}`) or fix DRX_ARTIFACTS_URL={self.url}."
        )

    # ----- keys and paths ----------------------------------------------------------
    def _model_prefix(self, name: str) -> str:
        return "/".join(p for p in (self.prefix, MODELS, name) if p) + "/"

    def _key(self, name: str, relpath: str) -> str:
        return self._model_prefix(name) + relpath

    def stored_path(self, name: str, path: Path | str) -> str:
        """The ``s3://`` URL of a file of model ``name`` (what the registry records)."""
        return f"s3://{self.bucket}/{self._key(name, self.relpath(name, path))}"

    def local_path(self, stored: str) -> Path:
        """The cached copy of a stored file, fetched when it is missing or stale."""
        head = f"s3://{self.bucket}/{self._model_prefix('')}"
        if not stored.startswith(head):
            return Path(stored)
        name, _, relpath = stored[len(head) :].partition("/")
        self.pull(name, relpath)
        return self.model_dir(name) / relpath

    def describe(self) -> dict[str, Any]:
        """The URL, bucket, prefix, endpoint and this host's cache folder."""
        return {
            "url": self.url,
            "kind": "s3",
            "bucket": self.bucket,
            "prefix": self.prefix,
            "endpoint": self.endpoint(),
            "local_folder": str(self.root),
        }

    # ----- checks and listings -------------------------------------------------------
    def check(self) -> None:
        """Whether the bucket answers with these credentials (once per process).

        :raises DrxError: unreachable endpoint, missing bucket, refused or missing credentials.
        """
        if self._checked:
            return
        from botocore.exceptions import ClientError

        with self._errors():
            try:
                self.client.head_bucket(Bucket=self.bucket)
            except ClientError as exc:  # HEAD has no body: 404 is the bucket, 403 the credentials
                if exc.response.get("ResponseMetadata", {}).get("HTTPStatusCode") == 404:
                    raise self._missing_bucket() from None
                raise
        self._checked = True

    def _objects(self, name: str) -> dict[str, dict[str, Any]]:
        """The stored files of model ``name``: relative path -> ``{"etag", "size"}``."""
        found: dict[str, dict[str, Any]] = {}
        head = self._model_prefix(name)
        with self._errors():
            pages = self.client.get_paginator("list_objects_v2").paginate(Bucket=self.bucket, Prefix=head)
            for page in pages:
                for obj in page.get("Contents", []):
                    found[obj["Key"][len(head) :]] = {"etag": obj["ETag"], "size": obj["Size"]}
        return found

    def _etag(self, name: str, relpath: str) -> str | None:
        from botocore.exceptions import ClientError

        with self._errors():
            try:
                return str(self.client.head_object(Bucket=self.bucket, Key=self._key(name, relpath))["ETag"])
            except ClientError as exc:
                if exc.response.get("ResponseMetadata", {}).get("HTTPStatusCode") == 404:
                    return None
                raise

    def listing(self, name: str, sub: str) -> list[str]:
        """The stored files of model ``name`` under ``sub``."""
        return sorted(rel for rel in self._objects(name) if _under(rel, [sub] if sub else None))

    # ----- moving files ------------------------------------------------------------
    def pull(self, name: str, *relpaths: str) -> None:
        """Fetch these files when the cached copy is missing or stale; drop a cached copy whose
        object was deleted (e.g. the model was removed and made again elsewhere)."""
        folder = self.model_dir(name)
        for rel in relpaths:
            etag = self._etag(name, rel)
            if etag is None:
                self._drop_copy(folder, rel)
            elif cache.unchanged(folder, rel) != etag:
                self._download(name, rel)

    def pull_tree(self, name: str, subs: Iterable[str] | None = None) -> None:
        """Fetch every stored file of model ``name`` (under ``subs``) whose cached copy is missing
        or stale."""
        subs = list(subs) if subs is not None else None
        folder = self.model_dir(name)
        stored = self._objects(name)
        for rel, obj in stored.items():
            if _under(rel, subs) and cache.unchanged(folder, rel) != obj["etag"]:
                self._download(name, rel)
        for rel in _local_files(folder):
            if rel not in stored and _under(rel, subs):
                self._drop_copy(folder, rel)

    def _drop_copy(self, folder: Path, rel: str) -> None:
        """Delete a cached copy of an object that is gone (never a file this host made and did not store)."""
        if cache.recorded(folder, rel) is not None:
            (folder / rel).unlink(missing_ok=True)
            cache.forget(folder, rel)

    def _download(self, name: str, rel: str) -> None:
        target = self.model_dir(name) / rel
        with atomic_write(target, "wb") as f, self._errors():
            response = self.client.get_object(Bucket=self.bucket, Key=self._key(name, rel))
            shutil.copyfileobj(response["Body"], f, 1 << 20)
        cache.record(self.model_dir(name), rel, str(response["ETag"]))

    def push(self, name: str, *relpaths: str) -> None:
        """Upload these local files, each in one PUT."""
        for rel in relpaths:
            self._upload(name, rel, self.model_dir(name) / rel)

    def push_tree(self, name: str, subs: Iterable[str] | None = None) -> None:
        """Upload every local file of model ``name`` (under ``subs``) changed since it was stored."""
        subs = list(subs) if subs is not None else None
        folder = self.model_dir(name)
        for rel in _local_files(folder):
            if _under(rel, subs) and cache.unchanged(folder, rel) is None:
                self._upload(name, rel, folder / rel)

    def _upload(self, name: str, rel: str, source: Path, record: bool = True) -> None:
        if not source.is_file():
            return
        with self._errors(), source.open("rb") as body:
            response = self.client.put_object(Bucket=self.bucket, Key=self._key(name, rel), Body=body)
        if record:
            cache.record(self.model_dir(name), rel, str(response["ETag"]))

    def put(self, name: str, relpath: str, source: Path) -> str:
        """Upload a file from elsewhere (a video) as ``relpath`` of model ``name``; its ``s3://`` URL."""
        self._upload(name, relpath, Path(source), record=False)
        return f"s3://{self.bucket}/{self._key(name, relpath)}"

    def delete(self, name: str, *relpaths: str) -> None:
        """Delete these objects and their cached copies."""
        self._delete_keys([self._key(name, rel) for rel in relpaths])
        folder = self.model_dir(name)
        for rel in relpaths:
            (folder / rel).unlink(missing_ok=True)
            cache.forget(folder, rel)

    def remove_model(self, name: str) -> None:
        """Delete every object of model ``name``, and this host's cached copies."""
        head = self._model_prefix(name)
        self._delete_keys([head + rel for rel in self._objects(name)])
        shutil.rmtree(self.model_dir(name), ignore_errors=True)

    def _delete_keys(self, keys: list[str]) -> None:
        with self._errors():
            for start in range(0, len(keys), 1000):  # DeleteObjects takes 1000 keys a call
                chunk = [{"Key": k} for k in keys[start : start + 1000]]
                if chunk:
                    self.client.delete_objects(Bucket=self.bucket, Delete={"Objects": chunk, "Quiet": True})


def _under(rel: str, subs: list[str] | None) -> bool:
    return subs is None or any(rel == s or rel.startswith(s.rstrip("/") + "/") for s in subs)


def _local_files(folder: Path) -> list[str]:
    """A model folder's files, relative, without the cache's records and temporary files."""
    if not folder.is_dir():
        return []
    found = []
    for path in folder.rglob("*"):
        rel = path.relative_to(folder)
        if rel.parts[0] == cache.SIDECARS or path.name.startswith(".") or not path.is_file():
            continue
        found.append(rel.as_posix())
    return sorted(found)


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0].rstrip(".")
