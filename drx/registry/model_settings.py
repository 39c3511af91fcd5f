"""A model row's columns as drx's typed settings, for the table's rows and for the quick reads alike.

:class:`ModelSettings` holds the methods of :class:`drx.registry.model_rows.Model` that read only
its columns; :mod:`drx.registry.quick` gives its plain rows the same methods without SQLAlchemy.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any, Protocol

from drx.settings.car import LEGACY_SIMULATOR, CarSettings
from drx.settings.episodes import EpisodeSettings
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.race import RaceConfig
from drx.settings.rollout import RolloutSettings
from drx.settings.stop import STOP_KEYS, StopConditions
from drx.vehicle import Vehicle


class ModelColumns(Protocol):
    """The columns of a model row the settings are read from."""

    @property
    def vehicle_spec(self) -> dict[str, Any]: ...
    @property
    def race(self) -> dict[str, Any]: ...
    @property
    def hyperparameters(self) -> dict[str, Any]: ...
    @property
    def algorithm(self) -> str: ...
    @property
    def stop_conditions(self) -> dict[str, Any]: ...
    @property
    def rollout_workers(self) -> int | None: ...
    @property
    def domain_randomization(self) -> bool: ...
    @property
    def episode_options(self) -> dict[str, Any] | None: ...
    @property
    def track_name(self) -> str: ...
    @property
    def simulator(self) -> str | None: ...
    @property
    def car_randomization(self) -> bool: ...
    @property
    def recipe(self) -> dict[str, Any] | None: ...


class ModelSettings:
    """The typed settings of a model row (a mixin: the row supplies :class:`ModelColumns`)."""

    def vehicle(self: ModelColumns) -> Vehicle:
        """The car snapshot as a validated :class:`~drx.vehicle.Vehicle`."""
        return Vehicle.from_dict(self.vehicle_spec)

    def race_config(self: ModelColumns) -> RaceConfig:
        """The race settings as a validated :class:`~drx.settings.race.RaceConfig`."""
        return RaceConfig.from_dict(self.race)

    def hyperparameter_settings(self: ModelColumns) -> Hyperparameters:
        """The ``hyperparameters`` JSON as :class:`~drx.settings.hyperparameters.Hyperparameters`
        (the one reader of its keys)."""
        return Hyperparameters.from_dict(self.hyperparameters, algorithm=self.algorithm)

    def stop_settings(self: ModelColumns, overrides: dict[str, Any] | None = None) -> StopConditions:
        """The ``stop_conditions`` JSON as :class:`~drx.settings.stop.StopConditions`, with a
        training job's ``options["stop"]`` (``overrides``: its non-empty values win) in place."""
        given = {k: v for k, v in (overrides or {}).items() if k in STOP_KEYS and v}
        return replace(StopConditions.from_dict(self.stop_conditions), **given)

    def rollout_settings(self: ModelColumns) -> RolloutSettings:
        """The ``rollout_workers`` and ``domain_randomization`` columns as
        :class:`~drx.settings.rollout.RolloutSettings`."""
        return RolloutSettings(self.rollout_workers, bool(self.domain_randomization))

    def car_settings(self: ModelColumns) -> CarSettings:
        """The ``simulator`` and ``car_randomization`` columns as :class:`~drx.settings.car.CarSettings`
        (a row from before them: simulator 5's car, the one it trained on)."""
        return CarSettings(self.simulator or LEGACY_SIMULATOR, bool(self.car_randomization))

    def episode_settings(self: ModelColumns) -> EpisodeSettings:
        """The ``episode_options`` JSON as :class:`~drx.settings.episodes.EpisodeSettings` (a model
        from before them: ``track_name`` alone, its route's own way, DeepRacer's default starts)."""
        return EpisodeSettings.from_dict(self.episode_options, track=self.track_name)


class ModelRecord(ModelSettings, SimpleNamespace):
    """A ``models`` row read by :mod:`drx.registry.quick`: its columns as attributes, and the
    settings methods of :class:`drx.registry.model_rows.Model`."""
