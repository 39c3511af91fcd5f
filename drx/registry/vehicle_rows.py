"""The ``vehicles`` table: cars in the garage."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import String
from sqlalchemy.orm import Mapped, mapped_column

from drx.registry.base import Base, utcnow
from drx.vehicle import Vehicle


class VehicleRow(Base):
    """A car in the garage.

    ``spec`` is :meth:`drx.vehicle.Vehicle.to_dict` (drx's storage format); the
    ``name`` inside it always equals the row's name. Models copy the spec when
    they are created, so changing or removing a car never changes a model.
    """

    __tablename__ = "vehicles"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    spec: Mapped[dict[str, Any]]
    source: Mapped[str | None] = mapped_column(String(512))  # e.g. "garage/fast.toml" or "options"
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    def vehicle(self) -> Vehicle:
        """The car as a validated :class:`~drx.vehicle.Vehicle`."""
        return Vehicle.from_dict({**self.spec, "name": self.name})
