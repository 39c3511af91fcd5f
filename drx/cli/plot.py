"""``drx plot``: the console's reward graph as a PNG, for one model or several."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from drx.cli.output import console, emit, fmt, json_option

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
    data = {"png": str(path), "models": [_summary(r) for r in runs]}

    def render() -> None:
        table = Table(title="Reward graph")
        for col in (
            "model",
            "iterations",
            "training episodes",
            "eval episodes",
            "best iteration",
            "best eval progress %",
            "last train progress %",
        ):
            table.add_column(col, justify="left" if col == "model" else "right")
        for s in data["models"]:
            table.add_row(
                s["model"],
                str(s["iterations"]),
                str(s["training_episodes"]),
                str(s["evaluation_episodes"]),
                "-" if s["best_iteration"] is None else str(s["best_iteration"]),
                _pct(s["best_eval_progress"]),
                _pct(s["last_train_mean_progress"]),
            )
        console.print(table)
        console.print(f"Wrote {path}")

    emit(data, render)
