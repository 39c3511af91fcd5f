"""The ``anneal`` learning-rate schedule: back to the best checkpoint, at half the rate, when the
laps stop keeping the best's pace.

With a constant rate, drx's last checkpoint lapped 1.08-1.37x slower than its best
(``docs/RACING.md``, "Is the last checkpoint worse?"): the policy drifts to a safer, slower line
after its best evaluation, and a racer who stops the run then submits the slower model. Under
``anneal`` the trainer judges every evaluated iteration against the best checkpoint
(:func:`judge`): it *holds* when every evaluation episode completed the lap and their mean lap
time is within :data:`TOLERANCE` of the best's. After :data:`STRIKES` evaluated iterations in a
row that do not hold, the trainer loads the best checkpoint's weights back and halves the
learning rate (no lower than :data:`FLOOR` of the model's ``learning_rate``), so the ``last``
checkpoint is again the best's policy and the smaller steps that follow stay nearer to it.

Nothing happens before the run has a best checkpoint whose evaluation completed every lap
(there is no pace to keep yet), and an iteration that was not evaluated (cut by a limit or a
stop) counts neither way. The state (:class:`AnnealState`) travels in the checkpoint's metadata,
so a resumed run goes on at the annealed rate; a clone starts at the full rate.

This module is pure (no torch): the trainer applies its verdicts
(:meth:`drx.train.trainer.Trainer._anneal`), the CLI words them (:func:`rollback_message`).
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

# Issue 41's bar: the last checkpoint laps within 1.05x of the best. An evaluation slower than
# that is the drift this schedule stops (docs/RACING.md measured 1.08-1.37x at a constant rate),
# while the 3-lap evaluations of a policy that kept its line vary by a few percent.
TOLERANCE = 1.05
# Evaluated iterations in a row that miss the pace before going back to the best: one or two slow
# evaluations are the noise of 3 laps (a wobble, a lap on a slightly wider line); three in a row
# are a policy that moved away. Fewer would roll back a run still finding its way to a faster
# line; more would leave the last checkpoint slower for longer.
STRIKES = 3
# The lowest the rate falls: 1/32 of the model's ``learning_rate`` (five halvings). Below that an
# update barely moves the policy, so a run that keeps missing the pace would only go on rolling
# back to the same weights.
FLOOR = 1.0 / 32.0
LAP_PROGRESS = 100.0  # [%] an evaluation whose episodes all completed the lap

# The checkpoint metadata's keys for AnnealState (also drx.train.run_state.RunState's fields).
META_KEYS = ("lr_factor", "anneal_strikes", "rollbacks")
# What an iteration's summary records of the schedule (IterationSummary.extra; the registry keeps
# them with the iteration's health figures): the factor after the iteration, and on a rollback
# the best's iteration, its lap time [s] and the rate from the next update on.
FIGURES = ("lr_factor", "rollback_to", "best_lap_time", "next_learning_rate")


@dataclass(frozen=True)
class AnnealState:
    """Where the schedule stands.

    :param factor: what the model's ``learning_rate`` is multiplied by (1, 1/2, ... :data:`FLOOR`).
    :param strikes: evaluated iterations in a row, up to the last, that did not hold the pace.
    :param rollbacks: how many times the run went back to its best checkpoint.
    """

    factor: float = 1.0
    strikes: int = 0
    rollbacks: int = 0

    def to_meta(self) -> dict[str, Any]:
        """The checkpoint metadata's keys (:data:`META_KEYS`)."""
        return {"lr_factor": self.factor, "anneal_strikes": self.strikes, "rollbacks": self.rollbacks}

    @classmethod
    def from_meta(cls, meta: Mapping[str, Any]) -> AnnealState:
        """The state a checkpoint's metadata records (a fresh one when it records none)."""
        return cls(
            factor=float(meta.get("lr_factor") or 1.0),
            strikes=int(meta.get("anneal_strikes") or 0),
            rollbacks=int(meta.get("rollbacks") or 0),
        )


@dataclass(frozen=True)
class Verdict:
    """What :func:`judge` made of an iteration.

    :param state: the schedule's state after it.
    :param held: whether it held the best's pace; ``None`` when it was not judged (no lapped best
        yet, or the iteration was not evaluated).
    :param rollback: go back to the best checkpoint now (``state.factor`` is the new factor).
    """

    state: AnnealState
    held: bool | None
    rollback: bool


def best_lap_time(best: Mapping[str, Any] | None) -> float | None:
    """[s] The best checkpoint's mean lap time when its evaluation completed every lap, else ``None``.

    :param best: the best checkpoint's metadata (``eval_progress``, ``eval_lap_time``).
    """
    if not best or best.get("eval_lap_time") is None:
        return None
    if float(best.get("eval_progress") or 0.0) < LAP_PROGRESS - 1e-6:
        return None
    return float(best["eval_lap_time"])


def judge(
    state: AnnealState,
    best: Mapping[str, Any] | None,
    *,
    evaluated: bool,
    lap_time: float | None,
    new_best: bool = False,
) -> Verdict:
    """Judge one iteration against the best checkpoint written before it.

    :param state: the schedule's state before the iteration.
    :param best: the best checkpoint's metadata before this iteration (``None``: none yet).
    :param evaluated: the iteration ran all its evaluation episodes (not cut by a limit or a stop).
    :param lap_time: [s] its evaluation's mean lap time when every episode completed the lap,
        else ``None`` (:attr:`drx.train.records.IterationSummary.eval_mean_lap_time`).
    :param new_best: the iteration beats the best (it holds, whatever the tolerance).
    """
    target = best_lap_time(best)
    if target is None or not evaluated:
        return Verdict(state, None, False)
    if new_best or (lap_time is not None and lap_time <= TOLERANCE * target):
        return Verdict(replace(state, strikes=0), True, False)
    if state.strikes + 1 < STRIKES:
        return Verdict(replace(state, strikes=state.strikes + 1), False, False)
    factor = max(FLOOR, state.factor / 2.0)
    return Verdict(AnnealState(factor=factor, strikes=0, rollbacks=state.rollbacks + 1), False, True)


def rollback_message(iteration: int, best_iteration: int, best_lap: float, learning_rate: float) -> str:
    """The sentence the log, the dashboard and ``drx jobs show`` print for a rollback, e.g.
    ``iteration 40: 3 evaluations slower than 1.05x the best lap (8.10 s); back to the best
    checkpoint (iteration 28), learning rate 0.00015``.

    :param iteration: the iteration after which the run went back.
    :param best_iteration: the best checkpoint's iteration it went back to.
    :param best_lap: [s] the best checkpoint's mean lap time.
    :param learning_rate: the rate from the next iteration on.
    """
    return (
        f"iteration {iteration}: {STRIKES} evaluations slower than {TOLERANCE:g}x the best lap "
        f"({best_lap:.2f} s); back to the best checkpoint (iteration {best_iteration}), "
        f"learning rate {learning_rate:.3g}"
    )


def summary_rollback(iteration: int, extra: Mapping[str, float] | None) -> str | None:
    """:func:`rollback_message` for an iteration whose summary's ``extra`` records a rollback
    (``rollback_to``, ``best_lap_time``, ``next_learning_rate``), else ``None``."""
    if not extra or "rollback_to" not in extra:
        return None
    best_iteration, best_lap = int(extra["rollback_to"]), float(extra["best_lap_time"])
    return rollback_message(iteration, best_iteration, best_lap, float(extra["next_learning_rate"]))


def latest_rollback(iterations: Sequence[tuple[int, Mapping[str, float] | None]]) -> str | None:
    """The newest rollback's sentence among ``(iteration, figures)`` in iteration order, with how
    many there were when more than one (``None`` when there was none).

    :param iterations: each iteration and its :data:`FIGURES` (a summary's ``extra``, or the
        registry's health figures; ``None`` when it has none).
    """
    said = [text for it, figures in iterations if (text := summary_rollback(it, figures)) is not None]
    if not said:
        return None
    return said[-1] + (f" ({len(said)} rollbacks so far)" if len(said) > 1 else "")


def wrap(text: str, width: int, indent: str = "  ") -> list[str]:
    """``text`` in lines of at most ``width`` characters, the later ones indented (a log's 80
    columns); a rollback's sentence breaks after its ``;`` first."""
    head, sep, tail = text.partition("; ")
    parts = [head + sep.rstrip(), tail] if sep else [text]
    lines: list[str] = []
    for part in parts:
        lines += textwrap.wrap(part, width, initial_indent=indent if lines else "", subsequent_indent=indent)
    return lines
