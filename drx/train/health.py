"""Telling a user when a training run has gone wrong, from its evaluations.

A run whose evaluation once completed laps and then fell to almost nothing, and stayed there,
has collapsed: its policy no longer drives, and more training time rarely brings it back (the
runs in issue 23 stayed collapsed for hundreds of iterations). The dashboard, the plain-line
log and ``drx jobs show`` say so with :func:`collapse_warning`, rather than leaving the user to
find out after an hour.
"""

from __future__ import annotations

from collections.abc import Sequence

LAP_PROGRESS = 100.0  # [%] an evaluation whose episodes all completed the lap
COLLAPSED_PROGRESS = 25.0  # [%] evaluation progress below this is "almost nothing"
COLLAPSED_ITERATIONS = 10  # ... for this many evaluated iterations in a row


def collapse_warning(
    evaluations: Sequence[tuple[int, float | None]], model: str | None = None
) -> str | None:
    """One paragraph saying the run has collapsed, or ``None`` when it has not.

    :param evaluations: ``(iteration, evaluation mean progress [%])`` in iteration order; ``None``
        for an iteration that was not evaluated (skipped).
    :param model: the model's name, for the commands the warning suggests.
    """
    evaluated = [(it, p) for it, p in evaluations if p is not None]
    lapped = [it for it, p in evaluated if p >= LAP_PROGRESS]
    if not lapped or len(evaluated) < COLLAPSED_ITERATIONS:
        return None
    recent = evaluated[-COLLAPSED_ITERATIONS:]
    if recent[0][0] <= lapped[0] or any(p >= COLLAPSED_PROGRESS for _, p in recent):
        return None
    name = model or "MODEL"
    return (
        f"Training has collapsed: evaluation completed laps at iteration {lapped[-1]}, but the last "
        f"{COLLAPSED_ITERATIONS} iterations reached only {recent[-1][1]:.0f}% of the lap (at most "
        f"{max(p for _, p in recent):.0f}%). The best checkpoint is kept; stop this run and go on from "
        f"it with gentler updates, e.g. `drx model clone {name} {name}-2 --lr 0.0001` (or fewer "
        f"epochs, a larger batch)."
    )
