"""Where DeepRacer's model folder comes from and goes to: a folder, a ``.tar.gz``, or
``s3://bucket/prefix`` (deepracer-for-cloud's local MinIO with ``AWS_ENDPOINT_URL``, or AWS S3).

:func:`opened` gives an import a folder on disk whatever the source (an archive is extracted with
:mod:`drx.interchange.safe_tar`'s checks, a bucket prefix downloaded); :func:`check_destination` and
:func:`place` give an export its destination only once the whole folder is written.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from drx.errors import DrxError, SettingError


def _s3_client() -> Any:
    """A boto3 S3 client for the environment's endpoint (AWS_ENDPOINT_URL for MinIO)."""
    from drx.storage.s3 import endpoint_from_environment

    try:
        import boto3
    except ImportError:
        raise DrxError("s3:// needs boto3; install drx[s3].") from None
    return boto3.client("s3", endpoint_url=endpoint_from_environment())


def is_model_source(source: str) -> bool:
    """Whether ``drx model import`` should read ``source`` as DeepRacer's model folder: ``s3://``, a
    folder, or an archive with a ``model/N_Step-M.ckpt.index`` member."""
    if source.startswith("s3://"):
        return True
    path = Path(source)
    if path.is_dir():
        return True
    if not path.is_file() or not path.name.endswith((".tar.gz", ".tgz", ".tar")):
        return False
    import tarfile
    import zlib
    from itertools import islice

    from drx.interchange.safe_tar import MAX_MEMBERS

    try:  # a look at the first members only: a bomb of members is refused by the importer's checks
        with tarfile.open(path) as tar:
            first = islice(tar, MAX_MEMBERS + 1)
            return any(
                m.isfile() and m.name.endswith(".ckpt.index") and "/model/" in f"/{m.name}" for m in first
            )
    except (tarfile.TarError, OSError, EOFError, zlib.error):
        return False  # the other importers say what is wrong with it


@contextmanager
def opened(source: str) -> Iterator[Path]:
    """A model folder on disk for ``source``: a folder, a ``.tar.gz`` (extracted safely into a
    temporary folder) or ``s3://bucket/prefix`` (downloaded into one)."""
    if source.startswith("s3://"):
        with tempfile.TemporaryDirectory(prefix="drx-import-") as tmp:
            _download(source, Path(tmp))
            yield Path(tmp)
        return
    path = Path(source)
    if path.is_dir():
        yield path
        return
    if not path.is_file():
        raise DrxError(
            f"{source} does not exist; give a DeepRacer model folder, its .tar.gz or s3://bucket/prefix."
        )
    from drx.interchange.safe_tar import checked_members, extract_files, open_archive

    with open_archive(path) as tar, tempfile.TemporaryDirectory(prefix="drx-import-") as tmp:
        members = checked_members(tar, path.name)
        extract_files(tar, members, Path(tmp), path.name)
        yield Path(tmp)


def _download(url: str, into: Path) -> None:
    bucket, _, prefix = url[len("s3://") :].partition("/")
    prefix = prefix.strip("/")
    client = _s3_client()
    try:
        pages = client.get_paginator("list_objects_v2").paginate(
            Bucket=bucket, Prefix=f"{prefix}/" if prefix else ""
        )
        keys = [obj["Key"] for page in pages for obj in page.get("Contents", [])]
        for key in keys:
            rel = key[len(prefix) :].lstrip("/") if prefix else key
            if not rel or ".." in Path(rel).parts:
                continue
            (into / rel).parent.mkdir(parents=True, exist_ok=True)
            client.download_file(bucket, key, str(into / rel))
    except Exception as exc:  # noqa: BLE001 - boto3's errors, in one sentence
        raise DrxError(
            f"Could not read {url} ({str(exc).splitlines()[0][:200]}); check the bucket and prefix."
        ) from exc
    if not keys:
        raise DrxError(f"{url} holds no files; give the prefix of a DeepRacer model folder.")


def check_destination(out: str) -> None:
    if out.startswith("s3://"):
        if len(out) <= len("s3://") or out[len("s3://") :].startswith("/"):
            raise SettingError("{field} {value} names no bucket; write s3://bucket/prefix.", "out", value=out)
        return
    path = Path(out)
    if (
        path.exists()
        and not path.name.endswith((".tar.gz", ".tgz"))
        and (not path.is_dir() or any(path.iterdir()))
    ):
        raise SettingError(
            "{field} {value} already exists and is not an empty folder; give a new folder, a .tar.gz or "
            "s3://bucket/prefix.", "out", value=out,
        )  # fmt: skip
    if not path.parent.is_dir():
        raise SettingError("{field} {value}: its folder does not exist; create it first.", "out", value=out)


def place(folder: Path, out: str) -> None:
    """Move the finished folder to its destination (a folder, a ``.tar.gz`` or ``s3://``)."""
    members = {str(p.relative_to(folder)): p for p in sorted(folder.rglob("*")) if p.is_file()}
    if out.startswith("s3://"):
        _upload(members, out)
        return
    path = Path(out)
    if path.name.endswith((".tar.gz", ".tgz")):
        from drx.interchange.safe_tar import write_archive

        write_archive(path, members)
        return
    staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    shutil.copytree(folder, staging, dirs_exist_ok=True)
    if path.is_dir():
        path.rmdir()  # checked empty before anything was written
    staging.rename(path)


def _upload(members: dict[str, Path], url: str) -> None:
    """Upload every file under ``s3://bucket/prefix/`` (AWS_ENDPOINT_URL for another S3 store)."""
    bucket, _, prefix = url[len("s3://") :].partition("/")
    client = _s3_client()
    try:
        for rel, path in members.items():
            client.upload_file(str(path), bucket, f"{prefix.strip('/')}/{rel}".lstrip("/"))
    except Exception as exc:  # noqa: BLE001 - boto3's errors: one sentence, never half a folder silently
        raise DrxError(
            f"Could not write to {url} ({str(exc).splitlines()[0][:200]}); check the bucket."
        ) from exc
