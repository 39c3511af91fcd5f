"""``drx leaderboard``: the local leaderboard of a track."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.table import Table

from drx.cli.output import console, emit, json_option
from drx.evaluate.leaderboard import leaderboard as build
from drx.evaluate.ranking import MODES

SCORE_TITLE = {"best-lap": "best lap s", "average-lap": "average lap s", "total-time": "total time s"}


@json_option
def leaderboard(
    track: Annotated[
        str | None, typer.Option("--track", help="The track [the one with the most evaluations].")
    ] = None,
    rank: Annotated[str, typer.Option("--rank", help="best-lap, average-lap or total-time.")] = "best-lap",
    reverse: Annotated[
        bool, typer.Option("--reverse", help="Races driven in the reverse direction.")
    ] = False,
) -> None:
    """Rank the models evaluated on a track: one row per model, its best result.

    average-lap ranks the best mean over N consecutive complete laps (N = the
    race's laps); models that never completed a lap rank below all that did,
    by progress. "x best" is the fastest lap's ratio to the theoretical best
    lap of that car (`drx track best-lap`).

    Examples:

        drx leaderboard --track oval

        drx leaderboard --track oval --rank average-lap --json
    """
    data = build(track, rank, "reverse" if reverse else "default")

    def render() -> None:
        if data["track"] is None:
            console.print("No evaluations yet; run `drx evaluate MODEL` first.")
            return
        title = f"Leaderboard {data['track']}{' (reversed)' if reverse else ''}, ranked by {rank}"
        table = Table(title=title)
        cols = ("#", "model", "car", "action space", SCORE_TITLE[rank], "x best", "laps", "off-track", "date")
        for col in cols:
            table.add_column(
                col, justify="left" if col in ("model", "car", "action space", "date") else "right"
            )
        for r in data["rows"]:
            score = f"{r['score']:.3f}" if r["score"] is not None else f"- ({r['progress']:.0f}%)"
            ratio = f"{r['best_lap_ratio']:.2f}" if r["best_lap_ratio"] is not None else "-"
            table.add_row(
                str(r["rank"]),
                r["model"],
                str(r["car"]),
                str(r["action_space"]),
                score,
                ratio,
                r["laps"],
                str(r["off_track_count"]),
                r["date"].strftime("%Y-%m-%d"),
            )
        console.print(table)

    emit(data, render)


__all__ = ["MODES", "leaderboard"]
