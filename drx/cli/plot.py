"""``drx plot``: the console's reward graph as a PNG, for one model or several."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from drx.cli.output import console, emit, fmt, json_option, warn
from drx.cli.tables import Column, Wide, fitted_table, print_table

if TYPE_CHECKING:  # pandas and matplotlib load only when the command runs
    from drx.analysis.data import ModelRun


def _last_progress(train: Any) -> float | None:
    if train.empty:
        return None
    return float(train[train["iteration"] == train["iteration"].max()]["progress"].mean())


def _summary(run: ModelRun) -> dict[str, Any]:
    train, evals = run.phase("training"), run.phase("evaluation")
    best = run.best_iteration
    best_eval = (
        evals[evals["iteration"] == best]["progress"].mean() if best is not None and not evals.empty else None
    )
    return {
        "model": run.name,
        "iterations": int(train["iteration"].nunique()) if not train.empty else 0,
        "training_episodes": len(train),
        "evaluation_episodes": len(evals),
        "best_iteration": best,
        "best_eval_progress": None if best_eval is None or best_eval != best_eval else float(best_eval),
        "last_train_mean_progress": _last_progress(train),
    }


def _pct(value: float | None) -> str:
    return fmt(None if value is None else round(value, 1))


@json_option
def plot(
    models: Annotated[list[str], typer.Argument(help="One or more model names (several share one chart).")],
    out: Annotated[
        Path | None, typer.Option("--out", help="The PNG to write [default: analysis/ in the model folder].")
    ] = None,
    wide: Wide = False,
) -> None:
    """Draw the reward graph: reward and progress per episode, averages per iteration, the best checkpoint.

    Examples:

      drx plot my-model

      drx plot my-model my-clone --out compare.png
    """
    from drx.analysis.data import load_run, model_folder
    from drx.analysis.reward_graph import save_reward_graph

    runs = [load_run(name) for name in models]
    if out is None:
        stem = "-vs-".join(models) if len(models) > 1 else "reward-graph"
        out = model_folder(runs[0].model) / "analysis" / f"{stem}.png"
    path = save_reward_graph(runs, out)
    for run in runs:
        if run.episodes.empty:
            warn(f"model {run.name} has no episodes yet, so the chart names it but draws nothing for it.")
    summaries = [_summary(r) for r in runs]
    data = {"png": str(path), "models": summaries}

    def render() -> None:
        columns = [
            Column("model", 0, kind="name"),
            Column("iterations", 0, "right"),
            Column("best iteration", 1, "right"),
            Column("best eval %", 1, "right"),
            Column("last train %", 2, "right"),
            Column("train episodes", 3, "right"),
            Column("eval episodes", 3, "right"),
        ]
        rows = [
            [s["model"], str(s["iterations"]), fmt(s["best_iteration"]), _pct(s["best_eval_progress"]),
             _pct(s["last_train_mean_progress"]), str(s["training_episodes"]), str(s["evaluation_episodes"])]
            for s in summaries
        ]  # fmt: skip
        table = fitted_table(columns, rows, console=console, wide=wide, title="Reward graph")
        print_table(table, console, wide)
        console.print(f"Wrote {path}")

    emit(data, render)
