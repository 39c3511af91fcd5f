"""Where drx keeps its data: ``DRX_HOME``, ``DRX_DATABASE_URL`` and ``DRX_ARTIFACTS_URL``."""

from __future__ import annotations

import os
from pathlib import Path

from drx.errors import DrxError


def data_home() -> Path:
    """The data home: ``$DRX_HOME``, default ``~/.drx``. Created on first use.

    :raises DrxError: the path (or a folder above it) exists and is not a folder.
    """
    home = Path(os.environ.get("DRX_HOME") or Path.home() / ".drx").expanduser()
    blocker = next((p for p in (home, *home.parents) if p.exists()), None)
    if blocker is not None and not blocker.is_dir():
        where = "DRX_HOME" if os.environ.get("DRX_HOME") else "The data home"
        raise DrxError(
            f"{where} {home} is not a folder ({blocker} is a file); point DRX_HOME at a folder, "
            "or move the file away."
        )
    home.mkdir(parents=True, exist_ok=True)
    return home


def database_url() -> str:
    """The registry's SQLAlchemy URL: ``$DRX_DATABASE_URL``, default SQLite in the data home."""
    return os.environ.get("DRX_DATABASE_URL") or f"sqlite:///{data_home() / 'drx.db'}"


def project_root() -> Path:
    """The source checkout (holds ``tracks/``, ``rewards/``, ``garage/`` samples)."""
    return Path(__file__).resolve().parent.parent
