"""``drx sweep create|extend|show|list``: hyperparameter sweeps with Optuna (see :mod:`drx.sweep`).

Optuna, matplotlib and the trainer load inside the commands, so ``drx --help`` stays quick.
"""

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, fmt, json_option, note

app = group("Hyperparameter sweeps: many trials of one model, searched and pruned by Optuna.")

SweepName = Annotated[
    str, typer.Argument(help="The sweep's name (its trials are the models NAME-0, NAME-1...).")
]
ParamOption = Annotated[
    list[str],
    typer.Option(
        "--param",
        help="A hyperparameter to vary: NAME=LOW:HIGH, NAME=LOW:HIGH:log or NAME=A,B,C; names: lr, "
        "batch-size, epochs, entropy, discount, loss, episodes-per-iteration, sac-alpha, lr-schedule. "
        "Repeat it.",
    ),
]


@app.command("create")
@json_option
def create(
    name: SweepName,
    source: Annotated[str, typer.Option("--from", help="The model every trial is cloned from.")],
    trials: Annotated[int, typer.Option("--trials", help="How many trials to queue now.")],
    param: ParamOption,
    metric: Annotated[
        str, typer.Option(help="What to optimise: progress, reward (maximised) or best-lap (minimised).")
    ] = "progress",
    max_minutes_per_trial: Annotated[
        float | None, typer.Option(help="Each trial's training-time limit [default: the model's].")
    ] = None,
    pruner: Annotated[str, typer.Option(help="median (Optuna's MedianPruner) or none.")] = "median",
    startup_trials: Annotated[int, typer.Option(help="Trials that finish before any is pruned.")] = 2,
    warmup_iterations: Annotated[int, typer.Option(help="Iterations of each trial never pruned.")] = 1,
    seed: Annotated[int | None, typer.Option(help="Make the trials' draws repeatable.")] = None,
) -> None:
    """Create a sweep: queue TRIALS clones of a model with hyperparameters Optuna draws.

    Every trial is an ordinary model and training job; run them with `drx worker` on any host
    sharing the registry. Trials whose evaluation falls behind are pruned after an iteration.

    Example: drx sweep create s1 --from my-model --trials 8 --param lr=1e-5:1e-3:log --param batch-size=64,128
    """
    from drx.sweep.service import create_sweep, load_sweep, trial_rows

    spec = create_sweep(
        name,
        source,
        trials,
        param,
        metric=metric,
        max_minutes=max_minutes_per_trial,
        pruner=pruner,
        startup_trials=startup_trials,
        warmup_iterations=warmup_iterations,
        seed=seed,
    )
    spec, study = load_sweep(name)
    rows = trial_rows(spec, study)
    data: dict[str, Any] = {"sweep": name, "metric": spec.metric, "direction": spec.direction}
    data |= {"params": spec.params, "trials": [r.to_dict() for r in rows]}
    emit(data, lambda: _print_created(name, rows))


def _print_created(name: str, rows: list[Any]) -> None:
    console.print(
        f"Sweep [bold]{name}[/bold]: {len(rows)} trials queued ({', '.join(r.model for r in rows)})."
    )
    console.print(f"Run them with `drx worker` (on any host); follow them with `drx sweep show {name}`.")


@app.command("extend")
@json_option
def extend(
    name: SweepName,
    trials: Annotated[int, typer.Option("--trials", help="How many more trials to queue.")],
) -> None:
    """Queue more trials of a sweep (finished or not); they learn from the trials finished so far.

    Example: drx sweep extend lr-search --trials 4
    """
    from drx.sweep.service import extend_sweep, trial_model_name

    numbers = extend_sweep(name, trials)
    models = [trial_model_name(name, n) for n in numbers]
    emit(
        {"sweep": name, "added": [{"number": n, "model": m} for n, m in zip(numbers, models, strict=True)]},
        lambda: console.print(
            f"Sweep [bold]{name}[/bold]: queued {len(models)} more trials ({', '.join(models)})."
        ),
    )


@app.command("show")
@json_option
def show(
    name: SweepName,
    out: Annotated[
        Path | None, typer.Option("--out", help="The PNG to write [default: sweeps/NAME.png in DRX_HOME].")
    ] = None,
) -> None:
    """Rank a sweep's trials and draw its optimisation history and hyperparameter importances.

    The best trial is an ordinary model: evaluate, clone or export it by its name.

    Example: drx sweep show lr-search
    """
    from drx.config import data_home
    from drx.sweep.plot import param_importances, write_sweep_png
    from drx.sweep.service import best_trial, load_sweep, trial_rows

    spec, study = load_sweep(name)
    rows = trial_rows(spec, study)
    importances, why = param_importances(spec, study)
    png = write_sweep_png(spec, study, out or data_home() / "sweeps" / f"{name}.png", (importances, why))
    best = best_trial(rows)
    data = {
        "sweep": name,
        "source": spec.source,
        "metric": spec.metric,
        "direction": spec.direction,
        "params": spec.params,
        "pruner": spec.pruner,
        "best": best.to_dict() if best else None,
        "importances": importances,
        "png": str(png),
        "trials": [_json_row(r) for r in rows],
    }
    emit(data, lambda: _print_show(spec, rows, best, png))


def _json_row(row: Any) -> dict[str, Any]:
    d = row.to_dict()
    if d["value"] is not None and not math.isfinite(d["value"]):
        d["value"] = None  # JSON has no infinity: a best-lap trial without a complete lap
        d["no_complete_lap"] = True
    return d


def _print_show(spec: Any, rows: list[Any], best: Any, png: Path) -> None:
    names = [p.split("=", 1)[0] for p in spec.params]
    table = Table("rank", "trial", "model", "state", "iters", spec.metric, *names)
    for rank, r in enumerate(rows, 1):
        value = "no lap" if r.value is not None and math.isinf(r.value) else fmt(r.value)
        table.add_row(
            str(rank),
            str(r.number),
            r.model or "-",
            r.state,
            str(r.iterations),
            value,
            *(_fmt_param(r.params.get(n)) for n in names),
        )
    console.print(table)
    if best is not None:
        note(f"Best: trial {best.number}, model [bold]{best.model}[/bold] ({spec.metric} {fmt(best.value)}).")
    note(f"Wrote {png}")


def _fmt_param(value: Any) -> str:
    return fmt(value) if isinstance(value, float) else "-" if value is None else str(value)


@app.command("list")
@json_option
def list_sweeps() -> None:
    """List the sweeps in the registry.

    Example: drx sweep list
    """
    from drx.sweep.service import load_sweep, sweep_names, trial_rows

    data: list[dict[str, Any]] = []
    for name in sweep_names():
        spec, study = load_sweep(name)
        rows = trial_rows(spec, study)
        states = [r.state for r in rows]
        data.append(
            {
                "sweep": name,
                "source": spec.source,
                "metric": spec.metric,
                "trials": len(rows),
                "complete": states.count("complete"),
                "pruned": states.count("pruned"),
            }
        )

    def render() -> None:
        if not data:
            console.print("No sweeps yet; create one with `drx sweep create NAME --from MODEL ...`.")
            return
        table = Table("sweep", "from", "metric", "trials", "complete", "pruned")
        for d in data:
            table.add_row(
                d["sweep"], d["source"], d["metric"], *(str(d[k]) for k in ("trials", "complete", "pruned"))
            )
        console.print(table)

    emit(data, render)
