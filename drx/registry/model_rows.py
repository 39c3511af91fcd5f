"""The ``models`` table: a car + a track + a reward function + settings, and its clone lineage."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, String, false
from sqlalchemy.orm import Mapped, mapped_column, relationship

from drx.registry.base import Base, utcnow
from drx.registry.model_settings import ModelSettings
from drx.registry.reward_rows import RewardSource
from drx.settings.car import DEFAULT_SIMULATOR, LEGACY_SIMULATOR
from drx.settings.race import RaceConfig

ALGORITHMS = ("ppo", "sac")
# draft: created, never trained; queued: a training job waits; training: a job runs;
# ready: trained (has checkpoints); stopped: training was stopped before any checkpoint;
# failed: the last training job failed.
MODEL_STATUSES = ("draft", "queued", "training", "ready", "stopped", "failed")


class Model(ModelSettings, Base):
    """A model: what to train (car, track, reward) and how (algorithm, hyperparameters, stop conditions).

    ``vehicle_spec`` is a snapshot of the car (:meth:`Vehicle.to_dict`) taken at
    creation, so removing or changing the garage car never changes the model.
    ``track_name`` is the track's canonical name (route id); ``track_sha256`` records
    the route file's hash at creation. ``parent_id`` / ``parent_checkpoint_id``
    record a clone's origin; ``parent_name`` keeps the parent's name even after
    the parent is removed with ``drx model rm --force``. ``race`` is the race type and its
    settings (:meth:`drx.settings.race.RaceConfig.to_dict`); models from before race types are time trials.
    ``domain_randomization``: training episodes vary lighting and colours
    (:mod:`drx.sim.domain_randomization`), DeepRacer's ``ENABLE_DOMAIN_RANDOMIZATION``.
    ``rollout_workers``: processes sampling the training episodes (:mod:`drx.train.rollout`);
    ``None``: as many as help on the machine that trains.
    ``episode_options``: the tracks (the first is ``track_name``), their direction and where episodes
    start (:meth:`drx.settings.episodes.EpisodeSettings.to_dict`); NULL for models from before
    revision 0007o, which train on ``track_name`` its own way with DeepRacer's default starts.
    ``device``: the torch device it trains on (``cpu``, ``cuda``, ``cuda:N``, ``mps``;
    :mod:`drx.settings.device`); NULL: ``auto``, a GPU torch can use, else the CPU.
    ``simulator``: the DeepRacer simulator whose car it trains and races on (``"5"``, ``"6"``;
    :mod:`drx.settings.car`); models from before revision 0009s keep ``"5"``, the car they trained on.
    ``car_randomization``: training episodes draw a car between versions 5 and 6.
    ``recipe``: the recipe the model was built by, with its choices and their reasons
    (:mod:`drx.recipes`); NULL for a model made without one (revision 0011r).
    """

    __tablename__ = "models"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    description: Mapped[str | None] = mapped_column(String(1024))
    vehicle_name: Mapped[str] = mapped_column(String(64))
    vehicle_spec: Mapped[dict[str, Any]]
    track_name: Mapped[str] = mapped_column(String(64))
    track_sha256: Mapped[str | None] = mapped_column(String(64))
    reward_sha256: Mapped[str] = mapped_column(ForeignKey("reward_sources.sha256"))
    reward_filename: Mapped[str] = mapped_column(String(512))
    algorithm: Mapped[str] = mapped_column(String(8))
    hyperparameters: Mapped[dict[str, Any]]
    stop_conditions: Mapped[dict[str, Any]]
    race: Mapped[dict[str, Any]] = mapped_column(default=lambda: RaceConfig().to_dict())
    domain_randomization: Mapped[bool] = mapped_column(default=False)
    rollout_workers: Mapped[int | None] = mapped_column(default=None)
    episode_options: Mapped[dict[str, Any] | None] = mapped_column(default=None)
    device: Mapped[str | None] = mapped_column(String(16), default=None)
    simulator: Mapped[str] = mapped_column(
        String(4), default=DEFAULT_SIMULATOR, server_default=LEGACY_SIMULATOR
    )
    car_randomization: Mapped[bool] = mapped_column(default=False, server_default=false())
    recipe: Mapped[dict[str, Any] | None] = mapped_column(default=None)
    status: Mapped[str] = mapped_column(String(16), default="draft")
    parent_id: Mapped[int | None] = mapped_column(ForeignKey("models.id", ondelete="SET NULL"), index=True)
    parent_name: Mapped[str | None] = mapped_column(String(64))
    parent_checkpoint_id: Mapped[int | None] = mapped_column(
        ForeignKey("checkpoints.id", ondelete="SET NULL", use_alter=True)
    )
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow)

    reward: Mapped[RewardSource] = relationship(lazy="joined")
    parent: Mapped[Model | None] = relationship(remote_side=[id], back_populates="children")
    children: Mapped[list[Model]] = relationship(back_populates="parent", passive_deletes=True)
