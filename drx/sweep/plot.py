"""The picture ``drx sweep show`` writes: optimisation history, each trial's iterations, importances.

Importances are Optuna's (``optuna.importance.get_param_importances``, fANOVA) over the complete
trials with a finite value; they need at least two such trials with different values.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from drx.sweep.service import SweepSpec

METRIC_LABELS = {
    "progress": "evaluation progress (%)",
    "reward": "evaluation reward",
    "best-lap": "best evaluation lap (s)",
}


def param_importances(spec: SweepSpec, study: Any) -> tuple[dict[str, float], str | None]:
    """Optuna's importances of the swept hyperparameters and the trials they rest on, or ``({}, why not)``."""
    import optuna

    done = [
        t
        for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
        if t.value is not None and math.isfinite(t.value)
    ]
    if len({t.value for t in done}) < 2:
        return {}, "importances need two complete trials with different values"
    scratch = optuna.create_study(direction=spec.direction)  # in memory: only the usable trials
    scratch.add_trials(done)
    try:
        evaluator = optuna.importance.FanovaImportanceEvaluator(seed=0)  # the same picture every time
        importances = optuna.importance.get_param_importances(scratch, evaluator=evaluator)
        return dict(importances), f"over {len(done)} complete trials"
    except (RuntimeError, ValueError) as exc:
        return {}, f"importances unavailable ({exc})"


def write_sweep_png(
    spec: SweepSpec, study: Any, path: Path, importances: tuple[dict[str, float], str | None] | None = None
) -> Path:
    """Draw the sweep to ``path`` (a PNG) and return it.

    :param importances: :func:`param_importances`'s answer when the caller has it already.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import optuna
    from matplotlib.ticker import MaxNLocator

    states = optuna.trial.TrialState
    trials = study.get_trials(deepcopy=False)
    label = METRIC_LABELS[spec.metric]
    fig, (hist, curves, imp) = plt.subplots(1, 3, figsize=(15, 4.6))
    fig.suptitle(f"Sweep {spec.name}: {len(trials)} trials of {spec.source}, {spec.direction} {spec.metric}")

    complete = [t for t in trials if t.state == states.COMPLETE and t.value is not None]
    pruned = [t for t in trials if t.state == states.PRUNED and t.value is not None]
    finite = [t for t in complete if math.isfinite(t.value)]
    hist.scatter([t.number for t in finite], [t.value for t in finite], color="tab:blue", label="complete")
    pruned_finite = [t for t in pruned if math.isfinite(t.value)]
    hist.scatter(
        [t.number for t in pruned_finite],
        [t.value for t in pruned_finite],
        color="tab:grey",
        marker="x",
        label="pruned (last iteration)",
    )
    best_x, best_y, best = [], [], None
    pick = min if spec.direction == "minimize" else max
    for t in sorted(finite, key=lambda t: t.number):
        best = t.value if best is None else pick(best, t.value)
        best_x.append(t.number)
        best_y.append(best)
    if best_x:
        hist.step(best_x, best_y, where="post", color="tab:red", label="best so far")
    hist.set(title="Optimisation history", xlabel="trial", ylabel=label)
    hist.legend(loc="best", fontsize=8)

    for t in trials:
        steps = sorted(t.intermediate_values)
        values = [t.intermediate_values[s] for s in steps]
        if not any(math.isfinite(v) for v in values):
            continue
        style = "--" if t.state == states.PRUNED else "-"
        curves.plot(steps, values, style, marker=".", label=f"{t.number} ({t.state.name.lower()})")
    curves.set(title="Each trial's iterations (dashed: pruned)", xlabel="iteration", ylabel=label)
    if curves.lines:
        curves.legend(loc="best", fontsize=7, ncol=2)

    for axis in (hist, curves):
        axis.xaxis.set_major_locator(MaxNLocator(integer=True))

    ranked, why = importances or param_importances(spec, study)
    if ranked:
        names = list(ranked)[::-1]
        bars = imp.barh(names, [ranked[n] for n in names], color="tab:green")
        imp.bar_label(bars, fmt="%.2f", padding=3)
        imp.set(title=f"Hyperparameter importance\n(fANOVA {why})", xlabel="importance", xlim=(0, 1.1))
    else:
        imp.set(title="Hyperparameter importance")
        imp.text(0.5, 0.5, why or "", ha="center", va="center", wrap=True, transform=imp.transAxes)
        imp.set_axis_off()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=90)
    plt.close(fig)
    tmp.replace(path)
    return path
