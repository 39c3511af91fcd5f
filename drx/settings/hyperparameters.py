"""DeepRacer's training hyperparameters and their Stable-Baselines3 equivalents.

Names, ranges and defaults are the console's (``../shared/DEEPRACER.md`` section 2).
PPO's fixed settings are DeepRacer's too: clip 0.2, GAE lambda 0.95, Adam eps 1e-5.
``to_deepracer_json()`` writes the ``hyperparameters.json`` a DeepRacer user knows.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from drx.errors import DrxError

ALGORITHMS = ("ppo", "sac")
BATCH_SIZES = (32, 64, 128, 256, 512)
LOSS_TYPES = ("huber", "mse")
# DeepRacer's fixed PPO settings.
PPO_CLIP_RANGE = 0.2
PPO_GAE_LAMBDA = 0.95
ADAM_EPS = 1e-5
# drx's SAC replay size: camera frames are 19 kB each, so the SB3 default of 1e6 would need 38 GB.
SAC_BUFFER_SIZE = 20_000  # [transitions]

_LOSS_NAMES = {"huber": "huber", "mse": "mse", "mean squared error": "mse", "mean_squared_error": "mse"}


@dataclass(frozen=True)
class Hyperparameters:
    """One model's training hyperparameters, in DeepRacer's terms.

    :param algorithm: ``ppo`` (discrete or continuous) or ``sac`` (continuous only).
    :param batch_size: gradient descent batch size: 32, 64, 128, 256 or 512.
    :param num_epochs: PPO epochs over each iteration's experience, 3-10.
    :param learning_rate: Adam's learning rate, 1e-8..1e-3.
    :param entropy: PPO's entropy coefficient (beta), 0..1.
    :param discount_factor: gamma, 0..1.
    :param loss_type: ``huber`` or ``mse`` (mean squared error) for the value/critic loss.
    :param episodes_per_iteration: whole episodes collected between policy updates, 5-100 (SAC: 1-100).
    :param sac_alpha: SAC's entropy temperature, 0..1.
    """

    algorithm: str = "ppo"
    batch_size: int = 64
    num_epochs: int = 10
    learning_rate: float = 3e-4
    entropy: float = 0.01
    discount_factor: float = 0.99
    loss_type: str = "huber"
    episodes_per_iteration: int = 20
    sac_alpha: float = 0.2

    def __post_init__(self) -> None:
        _check(self)

    @classmethod
    def default(cls, algorithm: str = "ppo") -> Hyperparameters:
        """DeepRacer's defaults for an algorithm (SAC: MSE loss, one episode per update)."""
        if algorithm == "sac":
            return cls(algorithm="sac", loss_type="mse", episodes_per_iteration=1)
        return cls(algorithm=algorithm)

    def replace(self, **changes: Any) -> Hyperparameters:
        """A copy with some values changed (validated)."""
        d = asdict(self)
        d.update({k: v for k, v in changes.items() if v is not None})
        return Hyperparameters(**d)

    def to_dict(self) -> dict[str, Any]:
        """drx's own JSON form (the registry's ``hyperparameters`` column)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None, algorithm: str | None = None) -> Hyperparameters:
        """Read drx's form or DeepRacer's ``hyperparameters.json`` keys; missing keys take defaults."""
        d = dict(d or {})
        algo = str(d.get("algorithm") or algorithm or "ppo").lower()
        if algo in ("clipped_ppo", "clipped-ppo"):
            algo = "ppo"
        base = cls.default(algo).to_dict()
        aliases = {
            "lr": "learning_rate",
            "beta_entropy": "entropy",
            "num_episodes_between_training": "episodes_per_iteration",
        }
        known = {f.name for f in fields(cls)}
        for key, value in d.items():
            name = aliases.get(key, key)
            if name in known and value is not None:
                base[name] = value
        base["algorithm"] = algo
        base["loss_type"] = _LOSS_NAMES.get(str(base["loss_type"]).lower(), str(base["loss_type"]))
        for key in ("batch_size", "num_epochs", "episodes_per_iteration"):
            base[key] = int(base[key])
        for key in ("learning_rate", "entropy", "discount_factor", "sac_alpha"):
            base[key] = float(base[key])
        return cls(**base)

    def to_deepracer_json(self, max_episodes: int | None = None) -> dict[str, Any]:
        """DeepRacer's ``hyperparameters.json`` (as deepracer-for-cloud writes it)."""
        return {
            "batch_size": self.batch_size,
            "beta_entropy": self.entropy,
            "discount_factor": self.discount_factor,
            "e_greedy_value": 0.05,
            "epsilon_steps": 10000,
            "exploration_type": "categorical" if self.algorithm == "ppo" else "additive_noise",
            "loss_type": "huber" if self.loss_type == "huber" else "mean squared error",
            "lr": self.learning_rate,
            "num_episodes_between_training": self.episodes_per_iteration,
            "num_epochs": self.num_epochs,
            "stack_size": 1,
            "term_cond_avg_score": 100000.0,
            "term_cond_max_episodes": int(max_episodes or 100000),
            "sac_alpha": self.sac_alpha,
        }

    def ppo_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for SB3's ``PPO`` (besides policy, env and network)."""
        assert self.algorithm == "ppo", "ppo_kwargs() is for PPO hyperparameters; use sac_kwargs() for SAC"
        return {
            "learning_rate": self.learning_rate,
            "batch_size": self.batch_size,
            "n_epochs": self.num_epochs,
            "gamma": self.discount_factor,
            "gae_lambda": PPO_GAE_LAMBDA,
            "clip_range": PPO_CLIP_RANGE,
            "ent_coef": self.entropy,
            "vf_coef": 0.5,
            "max_grad_norm": 0.5,
            "normalize_advantage": True,
        }

    def sac_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for SB3's ``SAC`` (besides policy, env and network)."""
        assert self.algorithm == "sac", "sac_kwargs() is for SAC hyperparameters; use ppo_kwargs() for PPO"
        return {
            "learning_rate": self.learning_rate,
            "batch_size": self.batch_size,
            "gamma": self.discount_factor,
            "ent_coef": self.sac_alpha,
            "buffer_size": SAC_BUFFER_SIZE,
            "learning_starts": 0,
        }

    def optimizer_kwargs(self) -> dict[str, Any]:
        """Adam's settings shared by both algorithms.

        ``fused``: torch's single-kernel Adam (same arithmetic as the default ``foreach`` one);
        on the ``shallow`` network's 5.8 M parameters it cuts the optimizer step about 6x and the
        whole update of a batch of 64 by ~20% on CPU (``benchmarks/train_throughput.py``).
        """
        return {"eps": ADAM_EPS, "fused": True}


def _check(h: Hyperparameters) -> None:
    """Raise :class:`DrxError` naming the first value outside DeepRacer's range."""
    if h.algorithm not in ALGORITHMS:
        raise DrxError(f"Algorithm {h.algorithm!r} is unknown; use ppo or sac.")
    if h.batch_size not in BATCH_SIZES:
        raise DrxError(
            f"Batch size {h.batch_size} is not allowed; use one of {', '.join(map(str, BATCH_SIZES))}."
        )
    if not 3 <= h.num_epochs <= 10:
        raise DrxError(f"Number of epochs {h.num_epochs} is out of range; use 3 to 10.")
    if not (math.isfinite(h.learning_rate) and 1e-8 <= h.learning_rate <= 1e-3):
        raise DrxError(f"Learning rate {h.learning_rate:g} is out of range; use 1e-8 to 1e-3.")
    for name, value in (
        ("Entropy", h.entropy),
        ("Discount factor", h.discount_factor),
        ("SAC alpha", h.sac_alpha),
    ):
        if not (math.isfinite(value) and 0.0 <= value <= 1.0):
            raise DrxError(f"{name} {value:g} is out of range; use 0 to 1.")
    if h.loss_type not in LOSS_TYPES:
        raise DrxError(f"Loss type {h.loss_type!r} is unknown; use huber or mse (mean squared error).")
    low = 1 if h.algorithm == "sac" else 5
    if not low <= h.episodes_per_iteration <= 100:
        raise DrxError(
            f"Episodes between policy updates {h.episodes_per_iteration} is out of range; use {low} to 100."
        )
