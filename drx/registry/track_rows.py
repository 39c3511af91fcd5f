"""The ``tracks`` table: routes imported with ``drx track import``.

Shipped tracks (DeepRacer's routes and drx's own, ``drx/tracks/*/*.npy``) are not
rows: they are read from the package. Imported routes are copied to
``$DRX_HOME/tracks/<name>.npy`` and described here.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import String
from sqlalchemy.orm import Mapped, mapped_column

from drx.registry.base import Base, utcnow


class TrackRow(Base):
    """An imported track route."""

    __tablename__ = "tracks"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    path: Mapped[str] = mapped_column(String(1024))  # the copied, fixed route (.npy)
    source_path: Mapped[str | None] = mapped_column(String(1024))  # where it was imported from
    sha256: Mapped[str] = mapped_column(String(64))  # of the copied route file
    length: Mapped[float]  # [m] centre line
    width: Mapped[float]  # [m] median road width
    direction: Mapped[str] = mapped_column(String(8))  # ccw | cw | -
    closed: Mapped[bool]
    n_waypoints: Mapped[int]
    notes: Mapped[list[Any]]  # what the import fixed, one sentence each
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
