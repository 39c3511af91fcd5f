"""The local cache's bookkeeping: which stored object each cached file is a copy of.

Beside a model's cached files, ``.drx-store/<relpath>.json`` records the object's ETag and
the local file's size and modification time when the two were last the same (after a
download or an upload). A file is fetched again only when the stored ETag changed or the
local file was rewritten since, so a worker never downloads the same checkpoint twice.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from drx.atomic import atomic_write

SIDECARS = ".drx-store"


def _sidecar(model_dir: Path, relpath: str) -> Path:
    return model_dir / SIDECARS / f"{relpath}.json"


def _stat(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except FileNotFoundError:
        return None
    return st.st_size, st.st_mtime_ns


def record(model_dir: Path, relpath: str, etag: str) -> None:
    """Note that the local ``relpath`` is now a copy of the stored object ``etag``."""
    stat = _stat(model_dir / relpath)
    if stat is None:
        return
    path = _sidecar(model_dir, relpath)
    with atomic_write(path) as f:
        json.dump({"etag": etag, "size": stat[0], "mtime_ns": stat[1]}, f)


def recorded(model_dir: Path, relpath: str) -> dict[str, Any] | None:
    """The record of ``relpath`` (``None`` when the file was never stored or fetched)."""
    try:
        return dict(json.loads(_sidecar(model_dir, relpath).read_text()))
    except (OSError, ValueError):
        return None


def unchanged(model_dir: Path, relpath: str) -> str | None:
    """The ETag the local file is a copy of, or ``None`` when it is absent or was rewritten since."""
    rec = recorded(model_dir, relpath)
    if rec is None or _stat(model_dir / relpath) != (rec.get("size"), rec.get("mtime_ns")):
        return None
    return str(rec.get("etag"))


def forget(model_dir: Path, relpath: str) -> None:
    """Drop the record of ``relpath``."""
    _sidecar(model_dir, relpath).unlink(missing_ok=True)
