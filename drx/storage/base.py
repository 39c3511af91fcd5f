"""The artifact store's interface, and the local folder that is its default.

A model's files sit under ``<root>/models/<name>/`` (deepracer-for-cloud's layout, see
:mod:`drx.train.checkpoint`). Code that writes them writes locally (atomically, as it
always did) and then calls :meth:`ArtifactStore.push`; code that reads them first calls
:meth:`ArtifactStore.pull`. For the local store both are no-ops: the folder *is* the store.

Paths kept in the registry (``checkpoints.path``) come from :meth:`ArtifactStore.stored_path`:
a local path for the local store, an ``s3://`` URL for a bucket, so that another host can
find the file (:meth:`ArtifactStore.local_path`).
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

MODELS = "models"
# Sub-folders of a model that training and evaluation read (the traces are read only by analyses).
MODEL_FILES = ("model", "ip", "reward_function.py")


class ArtifactStore:
    """Where model files live. The base class is the local folder (:class:`LocalStore`).

    :param url: what ``DRX_ARTIFACTS_URL`` said (or the default folder).
    :param root: the local folder holding ``models/<name>/`` on this host.
    """

    remote = False

    def __init__(self, url: str, root: Path) -> None:
        self.url = url
        self.root = Path(root)

    # ----- where --------------------------------------------------------------
    def model_dir(self, name: str) -> Path:
        """The local folder of model ``name``'s files (created on demand by the writers)."""
        return self.root / MODELS / name

    def relpath(self, name: str, path: Path | str) -> str:
        """``path`` (inside the model's local folder) relative to that folder, with ``/``."""
        return Path(path).resolve().relative_to(self.model_dir(name).resolve()).as_posix()

    def stored_path(self, name: str, path: Path | str) -> str:
        """What the registry records for a file of model ``name`` (here: the local path)."""
        return str(path)

    def local_path(self, stored: str) -> Path:
        """The local file for a path the registry recorded (fetched first when it is in a bucket)."""
        return Path(stored)

    def describe(self) -> dict[str, Any]:
        """What ``drx info`` shows: the URL, the kind of store and the local folder."""
        return {"url": self.url, "kind": "local", "local_folder": str(self.root)}

    # ----- moving files (no-ops here) ----------------------------------------------
    def check(self) -> None:
        """Raise a :class:`~drx.errors.DrxError` when the store cannot be used (a bucket: unreachable,
        missing, or the credentials refused). A local folder is created when first written."""

    def pull(self, name: str, *relpaths: str) -> None:
        """Make the local copies of these files of model ``name`` the stored ones."""

    def pull_tree(self, name: str, subs: Iterable[str] | None = None) -> None:
        """Fetch every stored file of model ``name`` (only under ``subs`` when given) not cached yet."""

    def push(self, name: str, *relpaths: str) -> None:
        """Store these local files of model ``name`` (each replaces the stored one whole)."""

    def push_tree(self, name: str, subs: Iterable[str] | None = None) -> None:
        """Store every local file of model ``name`` (under ``subs``) changed since it was last stored."""

    def put(self, name: str, relpath: str, source: Path) -> str:
        """Store a file from elsewhere (a video) as ``relpath`` of model ``name``; where it is stored.
        Here the file stays where it was written (on this machine already)."""
        return str(source)

    def listing(self, name: str, sub: str) -> list[str]:
        """The stored files of model ``name`` under ``sub`` (relative paths)."""
        folder = self.model_dir(name) / sub
        if not folder.is_dir():
            return []
        return sorted(self.relpath(name, p) for p in folder.rglob("*") if p.is_file())

    def delete(self, name: str, *relpaths: str) -> None:
        """Remove these files of model ``name`` (stored and local)."""
        for rel in relpaths:
            (self.model_dir(name) / rel).unlink(missing_ok=True)

    def remove_model(self, name: str) -> None:
        """Remove every file of model ``name``."""
        shutil.rmtree(self.model_dir(name), ignore_errors=True)


class LocalStore(ArtifactStore):
    """A folder on this machine (``$DRX_HOME/artifacts`` by default): every call is local."""
