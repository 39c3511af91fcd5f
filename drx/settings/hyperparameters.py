"""DeepRacer's training hyperparameters and their Stable-Baselines3 equivalents.

Names, ranges and defaults are the console's (``../shared/DEEPRACER.md`` section 2).
PPO's fixed settings are DeepRacer's too: clip 0.2, GAE lambda 0.95, Adam eps 1e-5.
``to_deepracer_json()`` writes the ``hyperparameters.json`` a DeepRacer user knows.

A model's ``hyperparameters`` JSON (the registry's column) is :meth:`Hyperparameters.to_dict` plus
``network``, the policy network, always equal to the car snapshot's; :meth:`Hyperparameters.from_dict`
ignores it. Errors are :class:`~drx.errors.SettingError` naming the field (``batch_size``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from drx.errors import SettingError

ALGORITHMS = ("ppo", "sac")
BATCH_SIZES = (32, 64, 128, 256, 512)
LOSS_TYPES = ("huber", "mse")
# How the learning rate moves over a run (RateSchedule): DeepRacer's is constant; ``linear``
# falls from ``learning_rate`` to zero at the run's first limit (drx.train.stop.StopWatch.progress);
# ``settle`` holds ``learning_rate`` for the first half of the run, then falls to zero; ``anneal``
# (drx's default) holds it until the laps stop keeping the best's pace, then goes back to the best
# checkpoint at half the rate (drx.train.anneal).
LR_SCHEDULES = ("anneal", "constant", "linear", "settle")
ANNEAL = "anneal"
SCHEDULE_HOLDS = {"linear": 0.0, "settle": 0.5}  # the share of the run at the full rate
# What PPO's value and policy heads sit on: ``shared``, drx's one trunk (camera network) for both;
# ``separate``, DeepRacer's two towers, a value network and a policy network sharing no weight
# (deepracer-simapp's rl_coach ``network_0`` and ``network_1``; drx.interchange.deepracer.deepracer_weights).
TOWERS = ("shared", "separate")
# DeepRacer's fixed PPO settings.
PPO_CLIP_RANGE = 0.2
PPO_GAE_LAMBDA = 0.95
ADAM_EPS = 1e-5
# drx's SAC replay size: camera frames are 19 kB each, so the SB3 default of 1e6 would need 38 GB.
SAC_BUFFER_SIZE = 20_000  # [transitions]

# Fields that apply to one algorithm only.
PPO_ONLY = ("num_epochs", "entropy", "towers")
SAC_ONLY = ("sac_alpha",)

# What each field is, in words (``drx model show``) and with its allowed values (the CLI's help).
LABELS = {
    "batch_size": "gradient descent batch size",
    "num_epochs": "number of epochs",
    "learning_rate": "learning rate",
    "entropy": "entropy (beta)",
    "discount_factor": "discount factor",
    "loss_type": "loss type",
    "episodes_per_iteration": "episodes between policy updates",
    "sac_alpha": "SAC alpha",
    "lr_schedule": "learning rate schedule",
    "towers": "towers",
    "network": "network",
}
# DeepRacer's ranges, for the checks (_check) and the options' help (HELP) alike.
EPOCHS_RANGE = (3, 10)
LEARNING_RATE_RANGE = (1e-8, 1e-3)
UNIT_RANGE = (0.0, 1.0)  # entropy, discount factor, SAC alpha
EPISODES_PER_ITERATION_RANGE = {"ppo": (5, 100), "sac": (1, 100)}

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
    :param lr_schedule: ``anneal`` (drx's default): ``learning_rate`` until three evaluations
        in a row lap slower than 1.05x the best checkpoint (or miss a lap), then back to the best
        checkpoint's weights at half the rate (:mod:`drx.train.anneal`); ``constant``
        (DeepRacer's); ``linear``: from ``learning_rate`` down to zero when the run reaches its
        first limit (``max_minutes``, ``max_steps`` or ``max_episodes``); ``settle``:
        ``learning_rate`` for the first half of the run, then down to zero. A falling rate leaves
        the last checkpoint where the policy settled rather than wherever its last full-size
        steps took it. drx-only: DeepRacer has no such setting (a DeepRacer
        ``hyperparameters.json`` read without it gets drx's default).
    :param towers: PPO's ``shared`` trunk under both heads (drx's default), or DeepRacer's
        ``separate`` value and policy towers (:data:`TOWERS`). A model imported from DeepRacer
        has ``separate``; either exports to DeepRacer (a shared trunk goes into both towers).
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
    lr_schedule: str = ANNEAL
    towers: str = "shared"

    def __post_init__(self) -> None:
        _check(self)

    @classmethod
    def default(cls, algorithm: str = "ppo") -> Hyperparameters:
        """DeepRacer's defaults for an algorithm (SAC: MSE loss, one episode per update)."""
        if algorithm == "sac":
            return cls(algorithm="sac", loss_type="mse", episodes_per_iteration=1)
        return cls(algorithm=algorithm)

    @classmethod
    def build(
        cls, algorithm: str, overrides: dict[str, Any], base: dict[str, Any] | None = None
    ) -> Hyperparameters:
        """Validated hyperparameters: ``base`` (or DeepRacer's defaults) updated with ``overrides``.

        :param algorithm: ``ppo`` or ``sac``.
        :param overrides: fields to set; ``None`` values are ignored.
        :param base: the starting values (a stored model's JSON, e.g. a clone's parent's).
        :raises SettingError: a value is out of DeepRacer's range or its field does not apply to
            ``algorithm``.
        """
        given = {k: v for k, v in overrides.items() if v is not None}
        for key in PPO_ONLY if algorithm == "sac" else SAC_ONLY:
            if key in given:
                other = "ppo" if algorithm == "sac" else "sac"
                raise SettingError(
                    "{field} does not apply to {name}; use it with {algorithm} {other}.",
                    key,
                    "algorithm",
                    name=algorithm.upper(),
                    other=other,
                )
        if "loss_type" in given and given["loss_type"] not in LOSS_TYPES:
            raise SettingError(
                "{field} {value} is unknown; use huber or mse.", "loss_type", value=given["loss_type"]
            )
        start = cls.from_dict(base, algorithm) if base else cls.default(algorithm)
        return start.replace(**given)

    def replace(self, **changes: Any) -> Hyperparameters:
        """A copy with some values changed (validated)."""
        d = asdict(self)
        d.update({k: v for k, v in changes.items() if v is not None})
        return Hyperparameters(**d)

    def to_dict(self) -> dict[str, Any]:
        """drx's own JSON form (the registry's ``hyperparameters`` column, without ``network``)."""
        return asdict(self)

    def to_model_json(self, network: str) -> dict[str, Any]:
        """A model's ``hyperparameters`` column: :meth:`to_dict` plus the car's policy ``network``."""
        return {**self.to_dict(), "network": network}

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

    def learning_rate_schedule(self) -> float | RateSchedule:
        """SB3's ``learning_rate``: the rate, or a schedule of SB3's progress remaining (1 to 0).

        ``anneal``'s is the constant rate: the trainer multiplies it by the factor its rollbacks
        reached (:meth:`drx.train.rate.AnnealedRate.set_lr_factor`)."""
        if self.lr_schedule in SCHEDULE_HOLDS:
            return RateSchedule(self.learning_rate, SCHEDULE_HOLDS[self.lr_schedule])
        return self.learning_rate

    def ppo_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for SB3's ``PPO`` (besides policy, env and network)."""
        assert self.algorithm == "ppo", "ppo_kwargs() is for PPO hyperparameters; use sac_kwargs() for SAC"
        return {
            "learning_rate": self.learning_rate_schedule(),
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
            "learning_rate": self.learning_rate_schedule(),
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


@dataclass(frozen=True)
class RateSchedule:
    """A learning rate held for the first ``hold`` of the run, then falling linearly to zero at
    its end; called, as SB3 calls a schedule, with the share of the run still to go (1 to 0).
    (A class rather than a closure: SB3 pickles the schedule into a checkpoint.)"""

    rate: float
    hold: float = 0.0

    def __call__(self, progress_remaining: float) -> float:
        return self.rate * min(1.0, max(0.0, progress_remaining) / (1.0 - self.hold))


def _check(h: Hyperparameters) -> None:
    """Raise :class:`SettingError` naming the first field outside DeepRacer's range."""
    if h.algorithm not in ALGORITHMS:
        raise SettingError("{field} {value!r} is unknown; use ppo or sac.", "algorithm", value=h.algorithm)
    if h.batch_size not in BATCH_SIZES:
        raise SettingError(
            "{field} {value} is not allowed; use one of {allowed}.",
            "batch_size",
            value=h.batch_size,
            allowed=", ".join(map(str, BATCH_SIZES)),
        )
    lo, hi = EPOCHS_RANGE
    if not lo <= h.num_epochs <= hi:
        raise SettingError("{field} {value} is out of range; use {lo} to {hi}.", "num_epochs",
                           value=h.num_epochs, lo=lo, hi=hi)  # fmt: skip
    lo_lr, hi_lr = LEARNING_RATE_RANGE
    if not (math.isfinite(h.learning_rate) and lo_lr <= h.learning_rate <= hi_lr):
        raise SettingError(
            "{field} {value:g} is out of range; use {lo} to {hi}.",
            "learning_rate",
            value=h.learning_rate,
            lo=_power_of_ten(lo_lr),
            hi=_power_of_ten(hi_lr),
        )
    for name in ("entropy", "discount_factor", "sac_alpha"):
        value = getattr(h, name)
        lo_u, hi_u = UNIT_RANGE
        if not (math.isfinite(value) and lo_u <= value <= hi_u):
            raise SettingError("{field} {value:g} is out of range; use {lo:g} to {hi:g}.", name, value=value,
                               lo=lo_u, hi=hi_u)  # fmt: skip
    if h.lr_schedule not in LR_SCHEDULES:
        raise SettingError("{field} {value} is unknown; use anneal, constant, linear or settle.",
                           "lr_schedule", value=h.lr_schedule)  # fmt: skip
    if h.towers not in TOWERS:
        raise SettingError("{field} {value} is unknown; use shared or separate.", "towers", value=h.towers)
    if h.loss_type not in LOSS_TYPES:
        raise SettingError(
            "{field} {value!r} is unknown; use huber or mse (mean squared error).",
            "loss_type",
            value=h.loss_type,
        )
    low, high = EPISODES_PER_ITERATION_RANGE[h.algorithm]
    if not low <= h.episodes_per_iteration <= high:
        raise SettingError(
            "{field} {value} is out of range; use {low} to {high}.",
            "episodes_per_iteration",
            value=h.episodes_per_iteration,
            low=low,
            high=high,
        )


def _power_of_ten(x: float) -> str:
    """``1e-8`` rather than Python's ``1e-08``."""
    return f"{x:.0e}".replace("e-0", "e-")


_PPO, _SAC = Hyperparameters.default("ppo"), Hyperparameters.default("sac")
_EPI = EPISODES_PER_ITERATION_RANGE
_UNIT = f"{UNIT_RANGE[0]:g}-{UNIT_RANGE[1]:g}"
HELP = {  # the CLI options' help: ranges and defaults from the constants above and the dataclass
    "batch_size": f"Gradient descent batch size: {', '.join(map(str, BATCH_SIZES[:-1]))} "
    f"or {BATCH_SIZES[-1]}.",
    "num_epochs": f"PPO epochs per update, {EPOCHS_RANGE[0]}-{EPOCHS_RANGE[1]} "
    f"[PPO default: {_PPO.num_epochs}].",
    "learning_rate": f"Learning rate, {_power_of_ten(LEARNING_RATE_RANGE[0])} to "
    f"{_power_of_ten(LEARNING_RATE_RANGE[1])} [default: {_power_of_ten(_PPO.learning_rate)}].",
    "entropy": f"PPO entropy (beta), {_UNIT} [default: {_PPO.entropy:g}].",
    "discount_factor": f"Discount factor, {_UNIT} [default: {_PPO.discount_factor:g}].",
    "loss_type": f"Loss type: huber or mse [PPO: {_PPO.loss_type}, SAC: {_SAC.loss_type}].",
    "episodes_per_iteration": "Episodes between policy updates: "
    f"PPO {_EPI['ppo'][0]}-{_EPI['ppo'][1]} [{_PPO.episodes_per_iteration}], "
    f"SAC {_EPI['sac'][0]}-{_EPI['sac'][1]} [{_SAC.episodes_per_iteration}].",
    "sac_alpha": f"SAC alpha, {_UNIT} [default: {_SAC.sac_alpha:g}].",
    "lr_schedule": "Learning rate over the run: anneal, halved and back to the best checkpoint "
    "when 3 evaluations in a row lap slower than 1.05x the best; constant (DeepRacer's); linear, "
    "down to 0 at the run's first limit; settle, full for half the run, then down to 0 "
    f"[default: {_PPO.lr_schedule}].",
    "towers": "PPO: shared, one camera network under the value and policy heads (drx's, faster); "
    f"separate, DeepRacer's two towers [default: {_PPO.towers}].",
}
