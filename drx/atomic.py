"""Files written whole or not at all.

Every file drx keeps (checkpoints, results, caches, downloads, archives) is written to a
temporary file in the same folder, flushed to disk, then renamed over its final name with
``os.replace``: a reader, or a run resumed after ``kill -9``, sees the old file or the new
one, never half of one. On an error the temporary file is removed and the old file stays.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any, Literal


def fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (a no-op where folders cannot be opened, e.g. Windows)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextmanager
def atomic_write(path: Path, mode: Literal["w", "wb"] = "w", *, durable: bool = False) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path`` for writing; on a clean exit it replaces ``path``.

    :param mode: ``"w"`` (text, UTF-8) or ``"wb"``.
    :param durable: also fsync the folder, so the rename survives a power cut (checkpoints).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    if durable:
        fsync_dir(path.parent)


def write_json_atomic(path: Path, data: Any) -> None:
    """Write ``data`` as indented JSON (keys sorted) to ``path`` atomically."""
    with atomic_write(path) as f:
        json.dump(data, f, indent=2, sort_keys=True)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_write(path) as f:
        f.write(text)


def copy_atomic(src: Path, dst: Path) -> Path:
    """Copy ``src`` to ``dst`` atomically and durably (e.g. a checkpoint's ``last`` to ``best``)."""
    with atomic_write(dst, "wb", durable=True) as f, open(src, "rb") as source:
        shutil.copyfileobj(source, f, 1 << 20)
    return Path(dst)
