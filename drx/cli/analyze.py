"""``drx analyze``: paths, heat maps and action breakdown over the track, and a per-iteration table."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.table import Table

from drx.cli.output import console, emit, json_option

if TYPE_CHECKING:  # pandas and matplotlib load only when the command runs
    import pandas as pd

    from drx.analysis.report import AnalysisReport


def _num(value: object, digits: int = 1) -> str:
    if value is None or (isinstance(value, float) and value != value):
        return "-"
    return f"{float(value):.{digits}f}"  # type: ignore[arg-type]


def _render(report: AnalysisReport) -> None:
    o = report.overall
    its = report.iterations
    span = f"iteration {its[0]}" if len(its) == 1 else f"iterations {its[0]}-{its[-1]}"
    console.print(
        f"[bold]{report.model}[/] ({span}): {o['episodes']} training episodes, "
        f"{_num(o['completion_rate'])}% laps complete, mean progress {_num(o['mean_progress'])}%, "
        f"best progress {_num(o['best_progress'])}%, best lap {_num(o['best_lap_time'], 2)} s"
    )
    table = Table(title="Per iteration")
    for col in (
        "iteration",
        "episodes",
        "complete %",
        "mean progress %",
        "mean reward",
        "best lap s",
        "mean lap s",
        "eval progress %",
        "eval best lap s",
    ):
        table.add_column(col, justify="right")
    for _, r in report.table.iterrows():
        table.add_row(
            str(int(r["iteration"])),
            str(int(r["episodes"])),
            _num(r["completion_rate"]),
            _num(r["mean_progress"]),
            _num(r["mean_reward"]),
            _num(r["best_lap_time"], 2),
            _num(r["mean_lap_time"], 2),
            _num(r["eval_mean_progress"]),
            _num(r["eval_best_lap_time"], 2),
        )
    console.print(table)
    if not report.tracks:
        _render_part("", report.best, report.breakdown, report.pictures)
        return
    for part in report.tracks:  # a model trained on several tracks: each track's figures apart
        o = part.overall
        console.print(
            f"\n[bold]on {part.track}[/]: {o['episodes']} training episodes, "
            f"{_num(o['completion_rate'])}% laps complete, mean progress {_num(o['mean_progress'])}%, "
            f"best lap {_num(o['best_lap_time'], 2)} s"
        )
        _render_part(f" on {part.track}", part.best, part.breakdown, part.pictures)


def _render_part(where: str, top: pd.DataFrame, breakdown: pd.DataFrame, pictures: dict[str, Path]) -> None:
    """The best episodes, the actions per section and the pictures (of the model, or of one track)."""
    best = Table(title=f"Best episodes{where} (drawn in the paths picture)")
    for col in ("iteration", "episode", "progress %", "steps", "reward", "status", "lap s"):
        best.add_column(col, justify="left" if col == "status" else "right")
    for _, r in top.iterrows():
        best.add_row(
            str(int(r["iteration"])),
            str(int(r["episode"])),
            _num(r["progress"]),
            str(int(r["steps"])),
            _num(r["reward"]),
            str(r["status"]),
            _num(r["lap_time"], 2),
        )
    console.print(best)
    actions = Table(title=f"Most chosen actions per section{where}")
    for col in ("section", "1st", "2nd", "3rd"):
        actions.add_column(col)
    for section, row in breakdown.iterrows():
        chosen = row[row > 0].sort_values(ascending=False).head(3)
        cells = [f"{label} ({share:.0f}%)" for label, share in chosen.items()]
        actions.add_row(str(section), *(cells + ["-"] * (3 - len(cells))))
    console.print(actions)
    for key, path in pictures.items():
        console.print(f"Wrote {key}{where}: {path}")


@json_option
def analyze(
    model: Annotated[str, typer.Argument(help="The model's name.")],
    iteration: Annotated[int | None, typer.Option("--iteration", help="Analyse this iteration only.")] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Folder for the PNGs [default: the model folder's analysis/]."),
    ] = None,
) -> None:
    """Analyse a model's training trace: best paths, reward and speed heat maps, actions per section.

    Examples:

      drx analyze my-model

      drx analyze my-model --iteration 12 --out ./pictures
    """
    from drx.analysis.report import analyze_model

    report = analyze_model(model, iteration=iteration, out=out)
    emit(report.to_dict(), lambda: _render(report))
