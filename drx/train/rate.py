"""The learning rate an update applies: SB3's schedule times the ``anneal`` factor.

SB3 sets each optimizer's rate at the start of ``train()`` (``_update_learning_rate``) from
``lr_schedule(_current_progress_remaining)``; drx sets the progress
(:func:`drx.train.algorithms.set_progress`). :class:`AnnealedRate` multiplies that rate by
:attr:`~AnnealedRate.lr_factor`, the factor :mod:`drx.train.anneal`'s rollbacks reached (1 for
every other schedule), for :class:`~drx.train.ppo.EpisodicPPO` and
:class:`~drx.train.sac.EpisodicSAC` alike.
"""

from __future__ import annotations

import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.utils import update_learning_rate


class AnnealedRate(BaseAlgorithm):
    """A mixin for an SB3 algorithm (listed before it): its updates run at the schedule's rate
    times :attr:`lr_factor`. Subclasses name their optimizers in :meth:`rate_optimizers`."""

    lr_factor: float = 1.0  # the anneal factor (drx.train.anneal.AnnealState.factor)

    def rate_optimizers(self) -> list[th.optim.Optimizer]:
        """The optimizers whose rate the schedule sets (PPO's one, SAC's actor's and critic's)."""
        raise NotImplementedError

    def current_learning_rate(self) -> float:
        """The rate the next update applies: the schedule's at the current progress, times the factor."""
        return float(self.lr_schedule(self._current_progress_remaining)) * self.lr_factor

    def set_lr_factor(self, factor: float) -> None:
        """Multiply the schedule's rate by ``factor`` from now on, and give the optimizers the new
        rate at once (a checkpoint written before the next update holds it too)."""
        self.lr_factor = float(factor)
        rate = self.current_learning_rate()
        for optimizer in self.rate_optimizers():
            update_learning_rate(optimizer, rate)

    def _update_learning_rate(self, optimizers: list[th.optim.Optimizer] | th.optim.Optimizer) -> None:
        """SB3's, with the factor: record the rate and give it to ``optimizers``."""
        rate = self.current_learning_rate()
        self.logger.record("train/learning_rate", rate)
        for optimizer in optimizers if isinstance(optimizers, list) else [optimizers]:
            update_learning_rate(optimizer, rate)

    def _excluded_save_params(self) -> list[str]:
        """SB3's, and :attr:`lr_factor`: the checkpoint's drx metadata keeps it (``lr_factor``)."""
        return [*super()._excluded_save_params(), "lr_factor"]
