"""``drx leaderboard``: the local leaderboard of a track under one set of race rules."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from drx.cli.output import console, emit, json_option
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.evaluate.leaderboard import leaderboard as build
from drx.evaluate.leaderboard import parse_filters, read_count
from drx.evaluate.ranking import MODES

SCORE_TITLE = {"best-lap": "best lap s", "average-lap": "average lap s", "total-time": "total time s"}
MODE_WORDS = {"best-lap": "best lap", "average-lap": "average lap", "total-time": "total time"}
RULES = "Rules (default: the most recent evaluation's)"  # the help panel of the rule filters
MAX_SHOWN = 6  # other rule sets listed under the table; --json lists them all


def _rule(flag: str, metavar: str, text: str) -> Any:
    return typer.Option(flag, metavar=metavar, help=text, rich_help_panel=RULES)


@json_option
def leaderboard(
    track: Annotated[
        str | None,
        typer.Option(
            "--track", help="The track (route id or display name) [the track of the most recent evaluation]."
        ),
    ] = None,
    rank: Annotated[str, typer.Option("--rank", help="best-lap, average-lap or total-time.")] = "best-lap",
    race_type: Annotated[
        str | None,
        _rule("--race-type", "TYPE", "time-trial, object-avoidance, head-to-bot or head-to-head."),
    ] = None,
    reverse: Annotated[
        bool | None,
        typer.Option(
            "--reverse/--no-reverse",
            help="Races driven against the track's own direction (--no-reverse: with it).",
            rich_help_panel=RULES,
        ),
    ] = None,
    laps: Annotated[str | None, _rule("--laps", "N", "Races of N laps.")] = None,
    min_laps: Annotated[
        str | None,
        _rule("--min-laps", "N", "Races that qualify results with N complete laps in a row, or none."),
    ] = None,
    off_track_penalty: Annotated[
        str | None, _rule("--off-track-penalty", "SECONDS", "Races with this off-track penalty.")
    ] = None,
    max_resets: Annotated[
        str | None, _rule("--max-resets", "N", "Races allowing N resets, or none (no limit).")
    ] = None,
    time_cap_minutes: Annotated[
        str | None, _rule("--time-cap-minutes", "MINUTES", "Races with this time cap.")
    ] = None,
    collision_penalty: Annotated[
        str | None,
        _rule("--collision-penalty", "SECONDS", "Races with boxes or bots and this collision penalty."),
    ] = None,
    rules_of: Annotated[
        str | None,
        _rule("--rules-of", "EVALUATION", "Every rule from this evaluation (an id from `drx eval list`)."),
    ] = None,
    wide: Wide = False,
) -> None:
    """Rank the models evaluated on a track in a race type: one row per model, its best result.

    A leaderboard is one race: results raced under other rules (race type,
    direction, laps, minimum laps, off-track penalty, resets, time cap) are never
    ranked together. It shows the rules of the track's most recent evaluation;
    the rule options pick another board (the most recent evaluation that has
    them gives the rest), and the lines under the table list the other rules
    raced there with the options that show each.

    A race with a minimum lap count (`drx evaluate --min-laps N`) ranks only the
    results with N complete laps in a row; the others follow, marked DNQ. average-lap
    ranks the best mean over N consecutive complete laps (N = the minimum laps, else
    the race's laps); models that never completed a lap rank below all that did,
    by progress. "x best" is the fastest lap's ratio to the theoretical best
    lap of that car (`drx track best-lap`).

    Examples:

        drx leaderboard --track oval

        drx leaderboard --track oval --laps 5 --rank average-lap --json

        drx leaderboard --track oval --race-type object-avoidance

    --race-type head-to-head ranks the models raced against each other
    (`drx race`) by Elo rating, with their wins, races and last result.
    """
    if race_type is not None and race_type.strip().lower().replace("_", "-") == "head-to-head":
        _head_to_head(track, wide)
        return
    filters = parse_filters(
        {
            "laps": laps,
            "min_laps": min_laps,
            "off_track_penalty": off_track_penalty,
            "max_resets": max_resets,
            "time_cap_minutes": time_cap_minutes,
            "collision_penalty": collision_penalty,
        }
    )
    direction = None if reverse is None else ("reverse" if reverse else "default")
    evaluation = None if rules_of is None else read_count(rules_of, "rules_of", none_ok=False)
    data = build(track, rank, direction, race_type, filters, evaluation)
    given = {
        "--race-type": race_type,
        "--reverse" if reverse else "--no-reverse": "" if reverse is not None else None,
        "--laps": laps,
        "--min-laps": min_laps,
        "--off-track-penalty": off_track_penalty,
        "--max-resets": max_resets,
        "--time-cap-minutes": time_cap_minutes,
        "--collision-penalty": collision_penalty,
        "--rules-of": rules_of,
    }
    asked = " ".join(f"{flag} {text}".strip() for flag, text in given.items() if text is not None)
    emit(data, lambda: _render(data, rank, wide, asked))


def _head_to_head(track: str | None, wide: bool) -> None:
    """The head-to-head board: models by Elo rating from their `drx race` results."""
    from drx.evaluate.race_store import head_to_head_board

    data = head_to_head_board(track)
    emit(data, lambda: _render_head_to_head(data, wide))


def _render_head_to_head(data: dict[str, Any], wide: bool) -> None:
    if not data["rows"]:
        where = f" on {data['track']}" if data["track"] else ""
        console.print(f"No head-to-head races{where} yet; race models with `drx race A B --track T`.")
        return
    n = data["races"]
    races = f"{n} race{'' if n == 1 else 's'}"
    console.print(f"[bold]Head-to-head {data['track']}[/], ranked by Elo rating ({races})")
    columns = [
        Column("#", 0, "right"),
        Column("model", 0, kind="name"),
        Column("rating", 0, "right"),
        Column("wins", 0, "right"),
        Column("races", 0, "right"),
        Column("last result", 1, kind="prose", min_width=16),
        Column("date", 2),
    ]
    rows = [
        [str(r["rank"]), r["model"], f"{r['rating']:.0f}", str(r["wins"]), str(r["races"]), r["last"],
         r["last_date"].strftime("%Y-%m-%d") if r["last_date"] else "-"]
        for r in data["rows"]
    ]  # fmt: skip
    print_table(fitted_table(columns, rows, console=console, wide=wide), console, wide)
    console.print(
        f"Elo: every model starts at {data['start_rating']:.0f}; each pair of cars in a race is a game the "
        f"one placed higher won (K {data['k_factor']:.0f}, shared over the field).", highlight=False
    )


def _render(data: dict[str, Any], rank: str, wide: bool, asked: str = "") -> None:
    """The board for people: its rules, the table, what DNQ means, the other rules raced there.

    :param asked: the rule options given, to name them when no result has those rules.
    """
    track, kind = data["track"], data["race_type"]
    if track is None:
        console.print(f"No {kind} evaluations yet; run `drx evaluate MODEL` first.")
        return
    if not data["rows"]:
        if data["other_rules"]:
            console.print(f"No results on {track} under {asked or 'these rules'}.", highlight=False)
        else:
            where = f"{track}{' (reversed)' if data['direction'] == 'reverse' else ''}"
            console.print(
                f"No {kind} evaluations on {where} yet; race a model there with "
                f"`drx evaluate MODEL --track {track}`."
            )
        _others(data)
        return
    console.print(f"[bold]Leaderboard {track}[/], ranked by {MODE_WORDS[rank]}")
    console.print(_wrapped("Rules: ", data["rules"]["text"]), highlight=False)
    crashes = kind != "time-trial"
    columns = [
        Column("#", 0, "right"),
        Column("model", 0, kind="name"),
        Column(SCORE_TITLE[rank], 0, "right"),
        Column("laps", 1, "right"),
        Column("x best", 2, "right"),
        Column("off-track", 3, "right"),
        *([Column("crashes", 3, "right")] if crashes else []),
        Column("car", 4, kind="name"),
        Column("date", 5),
        Column("action space", 6),
    ]
    rows = []
    for r in data["rows"]:
        score = f"{r['score']:.3f}" if r["score"] is not None else f"- ({r['progress']:.0f}%)"
        ratio = f"{r['best_lap_ratio']:.2f}" if r["best_lap_ratio"] is not None else "-"
        rows.append([
            "DNQ" if r["rank"] is None else str(r["rank"]), r["model"], score, r["laps"], ratio,
            str(r["off_track_count"]), *([str(r["crash_count"])] if crashes else []),
            str(r["car"]), r["date"].strftime("%Y-%m-%d"), str(r["action_space"]),
        ])  # fmt: skip
    print_table(fitted_table(columns, rows, console=console, wide=wide), console, wide)
    if any(r["rank"] is None for r in data["rows"]):
        need = data["rules"]["min_laps"]
        console.print(f"DNQ: did not qualify, fewer than {need} complete laps in a row (the rules' minimum).")
    _others(data)


def _others(data: dict[str, Any]) -> None:
    """The other rule sets raced on the track: how each differs from this board, its models, and
    the options that show it."""
    others = data["other_rules"]
    if not others:
        return
    console.print(f"Also raced on {data['track']}, each its own leaderboard:")
    for other in others[:MAX_SHOWN]:
        n = other["models"]
        head = f"{other['differs']}: {n} model{'' if n == 1 else 's'}"
        console.print(_wrapped("- ", head), highlight=False)
        shown = f"drx leaderboard --track {data['track']} {other['options']}".rstrip()
        console.print(f"    {shown}", highlight=False, soft_wrap=True)
    if len(others) > MAX_SHOWN:
        console.print(f"- and {len(others) - MAX_SHOWN} more (`--json` lists them all).")


def _wrapped(prefix: str, text: str) -> str:
    """``prefix`` + ``text`` wrapped at the console's width between its comma-separated parts (never
    inside one: ``2 s`` stays whole), later lines indented under the first part."""
    width = max(console.width, 40)
    lines = [prefix]
    parts = text.split(", ")
    for i, part in enumerate(parts):
        piece = part + ("," if i < len(parts) - 1 else "")
        line = lines[-1]
        if line.strip() and len(line) + 1 + len(piece) > width:
            lines.append(" " * len(prefix) + piece)
        else:
            lines[-1] = line + ("" if line == prefix else " ") + piece
    return "\n".join(lines)


__all__ = ["MODES", "leaderboard"]
