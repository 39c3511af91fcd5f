"""``drx leaderboard``: the local leaderboard of a track and race type."""

from __future__ import annotations

from typing import Annotated

import typer

from drx.cli.output import console, emit, json_option
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.evaluate.leaderboard import leaderboard as build
from drx.evaluate.ranking import MODES

SCORE_TITLE = {"best-lap": "best lap s", "average-lap": "average lap s", "total-time": "total time s"}


@json_option
def leaderboard(
    track: Annotated[
        str | None,
        typer.Option(
            "--track", help="The track (route id or display name) [the one with the most evaluations]."
        ),
    ] = None,
    rank: Annotated[str, typer.Option("--rank", help="best-lap, average-lap or total-time.")] = "best-lap",
    reverse: Annotated[
        bool, typer.Option("--reverse", help="Races driven in the reverse direction.")
    ] = False,
    race_type: Annotated[
        str,
        typer.Option("--race-type", help="time-trial, object-avoidance or head-to-bot; each ranks apart."),
    ] = "time-trial",
    wide: Wide = False,
) -> None:
    """Rank the models evaluated on a track in a race type: one row per model, its best result.

    average-lap ranks the best mean over N consecutive complete laps (N = the
    race's laps); models that never completed a lap rank below all that did,
    by progress. "x best" is the fastest lap's ratio to the theoretical best
    lap of that car (`drx track best-lap`).

    Examples:

        drx leaderboard --track oval

        drx leaderboard --track oval --rank average-lap --json

        drx leaderboard --track oval --race-type object-avoidance
    """
    data = build(track, rank, "reverse" if reverse else "default", race_type)

    def render() -> None:
        if data["track"] is None:
            console.print(f"No {data['race_type']} evaluations yet; run `drx evaluate MODEL` first.")
            return
        if not data["rows"]:
            where = f"{data['track']}{' (reversed)' if reverse else ''}"
            console.print(
                f"No {data['race_type']} evaluations on {where} yet; race a model there with "
                f"`drx evaluate MODEL --track {data['track']}`."
            )
            return
        title = (
            f"Leaderboard {data['track']}{' (reversed)' if reverse else ''}, {data['race_type']}, "
            f"ranked by {rank}"
        )
        crashes = data["race_type"] != "time-trial"
        columns = [
            Column("#", 0, "right"),
            Column("model", 0, kind="name"),
            Column(SCORE_TITLE[rank], 0, "right"),
            Column("laps", 1, "right"),
            Column("x best", 2, "right"),
            Column("off-track", 3, "right"),
            *([Column("crashes", 3, "right")] if crashes else []),
            Column("car", 4, kind="name"),
            Column("race", 5),
            Column("date", 6),
            Column("action space", 7),
        ]
        rows = []
        for r in data["rows"]:
            score = f"{r['score']:.3f}" if r["score"] is not None else f"- ({r['progress']:.0f}%)"
            ratio = f"{r['best_lap_ratio']:.2f}" if r["best_lap_ratio"] is not None else "-"
            rows.append([
                str(r["rank"]), r["model"], score, r["laps"], ratio, str(r["off_track_count"]),
                *([str(r["crash_count"])] if crashes else []),
                str(r["car"]), str(r["race"]), r["date"].strftime("%Y-%m-%d"), str(r["action_space"]),
            ])  # fmt: skip
        print_table(fitted_table(columns, rows, console=console, wide=wide, title=title), console, wide)

    emit(data, render)


__all__ = ["MODES", "leaderboard"]
