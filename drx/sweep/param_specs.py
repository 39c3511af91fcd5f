"""``--param`` specifications of a sweep: which hyperparameter, which values, checked against DeepRacer.

A specification is ``NAME=LOW:HIGH`` (uniform), ``NAME=LOW:HIGH:log`` (log-uniform) or
``NAME=A,B,C`` (a choice). Names are the words of :data:`PARAM_FIELDS`, the same as
``drx model create``'s options without the dashes (a test keeps them so); every value a trial
can draw must lie in DeepRacer's range, which :class:`drx.settings.hyperparameters.Hyperparameters`
checks (the one definition of the ranges, ``../shared/DEEPRACER.md`` section 2). Nothing here
imports Optuna until :meth:`ParamSpec.distribution` is called.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from drx.errors import SettingError
from drx.settings.hyperparameters import (
    BATCH_SIZES,
    LOSS_TYPES,
    LR_SCHEDULES,
    PPO_ONLY,
    SAC_ONLY,
    TOWERS,
    Hyperparameters,
)

# --param name -> Hyperparameters field ("lr" -> "learning_rate").
PARAM_FIELDS = {
    "batch-size": "batch_size",
    "epochs": "num_epochs",
    "lr": "learning_rate",
    "entropy": "entropy",
    "discount": "discount_factor",
    "loss": "loss_type",
    "episodes-per-iteration": "episodes_per_iteration",
    "sac-alpha": "sac_alpha",
    "lr-schedule": "lr_schedule",
    "towers": "towers",
}
INT_FIELDS = ("batch_size", "num_epochs", "episodes_per_iteration")
# no range makes sense for these
CHOICE_ONLY = {
    "batch_size": BATCH_SIZES, "loss_type": LOSS_TYPES, "lr_schedule": LR_SCHEDULES, "towers": TOWERS,
}  # fmt: skip
WORD_FIELDS = ("loss_type", "lr_schedule", "towers")  # choices of words, not numbers
SYNTAX = "write NAME=LOW:HIGH, NAME=LOW:HIGH:log or NAME=A,B,C (e.g. lr=1e-5:1e-3:log, batch-size=64,128,256)"


@dataclass(frozen=True)
class ParamSpec:
    """One swept hyperparameter.

    :param name: the ``--param`` name (``lr``, ``batch-size``...).
    :param field: the :class:`Hyperparameters` field it sets.
    :param low: the range's low end (``None`` for a choice).
    :param high: the range's high end (``None`` for a choice).
    :param log: draw the range on a log scale.
    :param choices: the values of a choice (``None`` for a range).
    """

    name: str
    field: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    choices: tuple[Any, ...] | None = None

    @property
    def is_int(self) -> bool:
        """Whether the hyperparameter takes whole numbers."""
        return self.field in INT_FIELDS

    def text(self) -> str:
        """The specification as the user writes it (stored with the sweep)."""
        if self.choices is not None:
            return f"{self.name}={','.join(str(c) for c in self.choices)}"
        return f"{self.name}={_num(self.low)}:{_num(self.high)}{':log' if self.log else ''}"

    def distribution(self) -> Any:
        """The Optuna distribution trials draw this hyperparameter from."""
        from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

        if self.choices is not None:
            return CategoricalDistribution(list(self.choices))
        assert self.low is not None and self.high is not None
        if self.is_int:
            return IntDistribution(int(self.low), int(self.high), log=self.log)
        return FloatDistribution(float(self.low), float(self.high), log=self.log)


def _num(value: float | None) -> str:
    return "" if value is None else f"{value:g}"


def parse_params(texts: list[str], algorithm: str) -> list[ParamSpec]:
    """Parse and check every ``--param`` of a sweep of a model trained with ``algorithm``.

    :raises DrxError: no ``--param``, a malformed one, an unknown or repeated name, a hyperparameter
        the algorithm does not use, or a value outside DeepRacer's range.
    """
    if not texts:
        raise SettingError(
            "A sweep needs at least one {field} to vary, e.g. {field} lr=1e-5:1e-3:log.", "param"
        )
    specs = [parse_param(text, algorithm) for text in texts]
    seen: set[str] = set()
    for spec in specs:
        if spec.field in seen:
            raise _bad(f"{spec.name} is given twice; give each hyperparameter once.")
        seen.add(spec.field)
    return specs


def parse_param(text: str, algorithm: str) -> ParamSpec:
    """Parse and check one ``--param NAME=...`` (see :func:`parse_params`)."""
    name, sep, values = (part.strip() for part in text.partition("="))
    if not sep or not name or not values:
        raise _bad(f"{text!r} is malformed; {SYNTAX}.")
    field = PARAM_FIELDS.get(name.lower())
    if field is None:
        raise _bad(f"{name} names no hyperparameter; use one of {', '.join(PARAM_FIELDS)}.")
    name = name.lower()
    if field in (SAC_ONLY if algorithm == "ppo" else PPO_ONLY):
        raise _bad(f"{name} does not apply to {algorithm.upper()} models; leave it out.")
    if "," in values or ":" not in values:
        spec = _choice(text, name, field, values)
    else:
        spec = _range(text, name, field, values)
    _check_in_range(text, spec, algorithm)
    return spec


def _choice(text: str, name: str, field: str, values: str) -> ParamSpec:
    items = [v.strip() for v in values.split(",")]
    if any(not v for v in items):
        raise _bad(f"{text!r} is malformed (an empty value); {SYNTAX}.")
    if field in WORD_FIELDS:
        parsed: list[Any] = [v.lower() for v in items]
    else:
        parsed = [_number(text, v, whole=field in INT_FIELDS) for v in items]
    if len(set(parsed)) != len(parsed):
        raise _bad(f"{text!r} repeats a value; give each value once.")
    return ParamSpec(name=name, field=field, choices=tuple(parsed))


def _range(text: str, name: str, field: str, values: str) -> ParamSpec:
    parts = [p.strip() for p in values.split(":")]
    if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2].lower() != "log"):
        raise _bad(f"{text!r} is malformed; {SYNTAX}.")
    if field in CHOICE_ONLY:
        allowed = ",".join(str(c) for c in CHOICE_ONLY[field])
        raise _bad(f"{name} takes a list of values, not a range; e.g. {name}={allowed}.")
    whole = field in INT_FIELDS
    low, high = (_number(text, p, whole=whole) for p in parts[:2])
    log = len(parts) == 3
    if not low < high:
        raise _bad(f"{text!r} has LOW {low:g} not below HIGH {high:g}; swap or widen them.")
    if log and low <= 0:
        raise _bad(f"{text!r} is on a log scale, so LOW must be above 0; raise it.")
    return ParamSpec(name=name, field=field, low=low, high=high, log=log)


def _number(text: str, value: str, whole: bool) -> float:
    try:
        number = float(value)
    except ValueError:
        raise _bad(f"{text!r} has {value!r}, which is not a number; {SYNTAX}.") from None
    if not math.isfinite(number):
        raise _bad(f"{text!r} has {value!r}, which is not a finite number; {SYNTAX}.")
    if whole:
        if number != int(number):
            raise _bad(f"{text!r} has {value!r}; that hyperparameter takes whole numbers.")
        return int(number)
    return number


def _check_in_range(text: str, spec: ParamSpec, algorithm: str) -> None:
    """Every value the spec can draw lies in DeepRacer's range (its ends suffice for a range)."""
    values = spec.choices if spec.choices is not None else (spec.low, spec.high)
    base = Hyperparameters.default(algorithm)
    for value in values:
        try:
            base.replace(**{spec.field: value})
        except SettingError as exc:
            reason = exc.worded(lambda _: spec.name).rstrip(".")
            raise _bad(f"{text} is outside DeepRacer's range: {reason[0].lower()}{reason[1:]}.") from None


def apply_params(params: dict[str, Any], specs: list[ParamSpec]) -> dict[str, Any]:
    """A trial's drawn values (keyed by ``--param`` name) as :class:`Hyperparameters` overrides."""
    by_name = {s.name: s for s in specs}
    return {by_name[name].field: value for name, value in params.items()}


def _bad(sentence: str) -> SettingError:
    """A sweep's ``param`` specification refused: ``sentence`` follows the field's name."""
    return SettingError("{field} " + sentence.replace("{", "{{").replace("}", "}}"), "param")
