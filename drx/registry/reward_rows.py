"""The ``reward_sources`` table: reward-function code, stored by content hash.

A model references the exact code it was trained with by its sha256, so
editing the file afterwards never changes an existing model.
"""

from __future__ import annotations

import hashlib
from datetime import datetime

from sqlalchemy import String, Text, true
from sqlalchemy.orm import Mapped, mapped_column

from drx.registry.base import Base, utcnow


def code_sha256(code: str) -> str:
    """The content hash a reward source is stored under (sha256 of its UTF-8 bytes)."""
    return hashlib.sha256(code.encode("utf-8")).hexdigest()


class RewardSource(Base):
    """One reward function's source code."""

    __tablename__ = "reward_sources"

    sha256: Mapped[str] = mapped_column(String(64), primary_key=True)
    code: Mapped[str] = mapped_column(Text)
    filename: Mapped[str] = mapped_column(String(512))  # the file name it was first stored from
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    # False for code from an imported package that nobody trusted yet: stored and shown, never run
    # until ``--trust-reward`` (see docs/SECURITY.md).
    trusted: Mapped[bool] = mapped_column(default=True, server_default=true())
