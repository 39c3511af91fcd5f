"""The ``jobs`` table: the work queue (training and evaluation runs).

A worker claims a ``queued`` job by setting ``status='running'``,
``worker_id``, ``started_at`` and ``heartbeat_at`` in one transaction; it
refreshes ``heartbeat_at`` at least every ``lease_seconds``. A running job whose
heartbeat is older than its lease is considered abandoned and may be requeued
while ``attempts < max_attempts``. ``stop_requested`` asks the worker to stop
gracefully (``status='stopped'``, with ``stop_reason``).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, ForeignKey, Index, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from drx.registry.base import Base, utcnow

JOB_STATUSES = ("queued", "running", "succeeded", "stopped", "failed", "cancelled")
JOB_ACTIVE_STATUSES = ("queued", "running")
JOB_FINAL_STATUSES = ("succeeded", "stopped", "failed", "cancelled")


class Job(Base):
    """One queued or finished run of a model."""

    __tablename__ = "jobs"
    __table_args__ = (Index("ix_jobs_status_created_at", "status", "created_at"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(String(16))  # a name of drx.queue.kinds.KINDS
    status: Mapped[str] = mapped_column(String(16), default="queued")
    options: Mapped[dict[str, Any]] = mapped_column(default=dict)  # kind-specific settings
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    heartbeat_at: Mapped[datetime | None]
    worker_id: Mapped[str | None] = mapped_column(String(128))
    lease_seconds: Mapped[int] = mapped_column(default=60)
    attempts: Mapped[int] = mapped_column(default=0)
    max_attempts: Mapped[int] = mapped_column(default=3)
    stop_requested: Mapped[bool] = mapped_column(default=False)
    stop_reason: Mapped[str | None] = mapped_column(String(256))
    error: Mapped[str | None] = mapped_column(Text)
    log_path: Mapped[str | None] = mapped_column(String(1024))
    # the device a training's latest attempt runs on, as people read it: "cpu", "cuda:0 (NVIDIA A10G)"
    # (drx.train.device.device_label); NULL for evaluations and before revision 0008d
    device: Mapped[str | None] = mapped_column(String(128), default=None)
    # How each attempt ended: [{"attempt", "worker", "ended", "reason", "at"}], "ended" being
    # requeued or a final status
    attempt_log: Mapped[list[dict[str, Any]] | None] = mapped_column(JSON, default=None)
