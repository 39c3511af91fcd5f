"""``drx evaluate MODEL`` (the model's race) and ``drx eval list|show`` (stored results)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option, note
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.errors import DrxError
from drx.evaluate import service
from drx.evaluate.leaderboard import read_count
from drx.evaluate.service import EvaluationRequest
from drx.settings.car import SIMULATOR_HELP
from drx.sim.episode_status import EpisodeStatus

app = group("Stored evaluations (races): list them, show one.")

Track = Annotated[str | None, typer.Option("--track", help="Track to race on [the model's training track].")]
Laps = Annotated[int, typer.Option("--laps", help="Laps to drive, 1-100.")]
CheckpointOpt = Annotated[str, typer.Option("--checkpoint", help="best, last, or an iteration number.")]
Penalty = Annotated[float, typer.Option("--off-track-penalty", help="Seconds added per off-track.")]
MaxResets = Annotated[int | None, typer.Option("--max-resets", help="Resets allowed [no limit].")]
TimeCap = Annotated[float, typer.Option("--time-cap-minutes", help="Stop the trial after this long.")]
Direction = Annotated[str | None, typer.Option("--direction", help="cw or ccw [the track's own].")]
Video = Annotated[Path | None, typer.Option("--video", help="Record the trial to this .mp4 or .gif file.")]
RaceType = Annotated[
    str | None,
    typer.Option("--race-type", help="time-trial, object-avoidance or head-to-bot [the model's race]."),
]
Objects = Annotated[int | None, typer.Option("--objects", help="Object avoidance: boxes, 1-6.")]
ObjectAt = Annotated[
    list[str] | None,
    typer.Option(
        "--object-at",
        help="Object avoidance: a box at PLACE:LANE, e.g. 25:inside (percent of the lap 7-90, "
        "inside|outside); repeat per box, at least 13% apart.",
    ),
]
Bots = Annotated[int | None, typer.Option("--bots", help="Head-to-bot: bot cars, 1-4.")]
BotSpeed = Annotated[float | None, typer.Option("--bot-speed", help="Head-to-bot: bot speed, 0.2-6 m/s.")]
BotLaneChange = Annotated[
    bool | None,
    typer.Option(
        "--bot-lane-change/--no-bot-lane-change", help="Head-to-bot: bots change lanes every 3-5 s."
    ),
]
CollisionPenalty = Annotated[
    float, typer.Option("--collision-penalty", help="Seconds added per crash into a box or bot.")
]
Seed = Annotated[
    int | None,
    typer.Option(
        "--seed",
        help="Seed of the simulator's noise (its steps vary in length as DeepRacer's do): the same seed "
        "repeats a trial exactly [a new seed each time, shown in the result].",
    ),
]
MinLaps = Annotated[
    str | None,
    typer.Option(
        "--min-laps",
        metavar="N",
        help="Complete laps in a row a result needs to qualify on the leaderboard, 1 to --laps "
        "(DeepRacer on AWS's minimum lap count) [none: every result qualifies].",
    ),
]
Simulator = Annotated[
    str | None,
    typer.Option(
        "--simulator",
        metavar="VERSION",
        help=f"The DeepRacer simulator whose car races: {SIMULATOR_HELP} [default: the model's].",
    ),
]
Detach = Annotated[
    bool, typer.Option("--detach", "-d", help="Only queue the evaluation; `drx worker` runs it.")
]


@json_option
def evaluate(
    model: Annotated[str, typer.Argument(help="The model to evaluate (see `drx model list`).")],
    track: Track = None,
    laps: Laps = 3,
    checkpoint: CheckpointOpt = "best",
    off_track_penalty: Penalty = 2.0,
    max_resets: MaxResets = None,
    time_cap_minutes: TimeCap = 20.0,
    direction: Direction = None,
    race_type: RaceType = None,
    objects: Objects = None,
    object_at: ObjectAt = None,
    bots: Bots = None,
    bot_speed: BotSpeed = None,
    bot_lane_change: BotLaneChange = None,
    collision_penalty: CollisionPenalty = 5.0,
    video: Video = None,
    seed: Seed = None,
    min_laps: MinLaps = None,
    simulator: Simulator = None,
    detach: Detach = False,
) -> None:
    """Race a model in its race type, store the result and print its summary.

    The car starts at the start line and drives the laps with its most probable
    action at every step. Off the road, the lap gets the off-track penalty and
    the car stands for the penalty, then restarts at rest where it left, on the
    nearer lane (as DeepRacer does; driving the wrong way costs the same); into
    a box or a bot, the lap gets the collision penalty and the car is put back
    at rest 0.5 m behind it; the lap goes on. Every lap starts from rest at the
    start line. A lap's time is simulated time plus its penalties; the
    simulator's steps vary in length as DeepRacer's do, so laps differ
    (--seed repeats a trial). The race is the model's (boxes at their fixed places,
    bots from their start places); the race options change it, as in
    `drx model create`. Ctrl-C stops the trial and stores nothing. --min-laps
    sets the race's minimum lap count: the trial still drives --laps, and a
    result with fewer complete laps in a row does not qualify on the leaderboard.

    Examples:

        drx evaluate my-model

        drx evaluate my-model --track kidney --laps 5 --video laps.mp4 --json

        drx evaluate my-model --laps 5 --min-laps 3

        drx evaluate my-model --simulator 5

        drx evaluate my-model --race-type object-avoidance --object-at 25:inside --object-at 60:outside
    """
    race = _race_changes(race_type, objects, object_at, bots, bot_speed, bot_lane_change)
    request = EvaluationRequest(
        model=model,
        track=track,
        checkpoint=checkpoint,
        laps=laps,
        off_track_penalty=off_track_penalty,
        max_resets=max_resets,
        time_cap_minutes=time_cap_minutes,
        direction=direction,
        race=race,
        collision_penalty=collision_penalty,
        seed=seed,
        min_laps=None if min_laps is None else read_count(min_laps, "min_laps"),
        simulator=simulator,
    )
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        raise DrxError(f"--video {video} must end in .mp4 or .gif.")
    prepared = service.prepare(request)
    if detach:
        from drx.queue.evaluate_job import enqueue_evaluation

        job = enqueue_evaluation(request, video)
        emit(
            {"job": job.id, "model": model, "kind": "evaluate", "status": job.status},
            lambda: console.print(
                f"Queued evaluation job [bold]{job.id}[/] for model {model}; `drx worker` runs it."
            ),
        )
        return
    qualify = f" (min {prepared.rules.min_laps} to qualify)" if prepared.rules.min_laps else ""
    note(
        f"Evaluating {model} (checkpoint {prepared.checkpoint.which}, iteration "
        f"{prepared.checkpoint.iteration}) on {prepared.track_name}, {prepared.rules.race.summary()}: "
        f"{laps} laps{qualify}, simulator {prepared.simulator}'s car; "
        f"{prepared.best_lap_text}."
    )
    try:
        result = service.run(prepared, video=video)
    except KeyboardInterrupt:
        console.print("Evaluation interrupted; nothing was stored.", style="yellow")
        raise typer.Exit(code=130) from None
    evaluation_id = service.store(prepared, result, video=video)
    data = service.get_evaluation(evaluation_id)
    emit(data, lambda: render_summary(data))


def _race_changes(
    race_type: str | None,
    objects: int | None,
    object_at: list[str] | None,
    bots: int | None,
    bot_speed: float | None,
    bot_lane_change: bool | None,
) -> dict[str, Any] | None:
    """The race options given on the command line (``None``: the model's race as it is)."""
    from drx.settings.race import parse_object_at

    changes = {
        "race_type": race_type,
        "objects": objects,
        "object_positions": [list(parse_object_at(p)) for p in object_at] if object_at else None,
        "bots": bots,
        "bot_speed": bot_speed,
        "bot_lane_change": bot_lane_change,
    }
    changes = {k: v for k, v in changes.items() if v is not None}
    return changes or None


STATUS_WORDS = {
    EpisodeStatus.LAP_COMPLETE: "complete",
    EpisodeStatus.OFF_TRACK: "off track",
    EpisodeStatus.TIME_UP: "time up",
}


def _t(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def render_summary(data: dict[str, Any]) -> None:
    """The console's evaluation summary: the totals, then a row per lap."""
    head = Table(show_header=False, title=f"Evaluation {data['id']}: {data['model']} on {data['track']}")
    head.add_column(style="bold")
    head.add_column()
    rules = data["rules"]
    resets = "no limit" if rules.get("max_resets") is None else str(rules["max_resets"])
    head.add_row("car", f"{data['car']} ({data['action_space']})")
    if data.get("simulator"):  # evaluations from before simulator 6 raced version 5's car unnamed
        head.add_row("simulator", f"DeepRacer simulator {data['simulator']}'s car")
    head.add_row("race", data.get("race") or "time-trial")
    head.add_row("checkpoint", f"{data['checkpoint']} (iteration {data['checkpoint_iteration']})")
    head.add_row(
        "rules",
        f"{rules['laps']} laps, off-track penalty {rules['off_track_penalty']:g} s, max resets {resets}, "
        f"time cap {rules['time_cap_minutes']:g} min"
        + (
            f", collision penalty {rules['collision_penalty']:g} s"
            if rules.get("collision_penalty") is not None and data.get("race") != "time-trial"
            else ""
        )
        + (", reversed" if data["direction"] == "reverse" else "")
        + (f", seed {data['seed']}" if data.get("seed") is not None else ""),
    )
    head.add_row("laps completed", f"{data['laps_completed']} of {rules['laps']} (ended: {data['ended']})")
    if rules.get("min_laps"):  # the race's minimum lap count: whether this result counts
        verdict = "qualified" if data.get("qualified") else "did not qualify"
        head.add_row("min laps", f"{rules['min_laps']} in a row to qualify: {verdict}")
    ratio = f"  ({data['fastest_lap_ratio']:.2f} x the best lap)" if data["fastest_lap_ratio"] else ""
    head.add_row("fastest lap", _t(data["fastest_lap"]) + " s" + ratio)
    head.add_row("average lap", _t(data["average_lap"]) + " s")
    head.add_row("total time", _t(data["total_time"]) + " s")
    head.add_row("off-track", f"{data['off_track_count']} (resets {data['resets']})")
    if data.get("race") != "time-trial":
        head.add_row("crashes", str(data.get("crash_count", 0)))
    if data["best_lap"] is None and data.get("best_lap_missing"):
        head.add_row("theoretical best lap", f"none: {data['best_lap_missing']}")
    else:
        head.add_row("theoretical best lap", _t(data["best_lap"]) + " s (`drx track best-lap`)")
    if data.get("video"):
        head.add_row("video", str(data["video"]))
    console.print(head)
    table = Table(title="Laps")
    cols = ["lap", "time s", "x best", "progress %", "status", "off-track", "penalty s", "resets"]
    crashes = data.get("race") != "time-trial"
    if crashes:
        cols.append("crashes")
    for col in cols:
        table.add_column(col, justify="left" if col == "status" else "right")
    for lap in data["laps"]:
        extra = [str(lap.get("crashes", 0))] if crashes else []
        table.add_row(
            str(lap["lap"]),
            _t(lap["time"]),
            _t(lap["ratio"], 2),
            f"{lap['progress']:.1f}",
            STATUS_WORDS.get(lap["status"], lap["status"]),
            str(lap["off_track_count"]),
            f"{lap['penalty_seconds']:g}",
            str(lap["resets"]),
            *extra,
        )
    console.print(table)


@app.command("list")
@json_option
def list_evaluations(
    model: Annotated[str | None, typer.Option("--model", help="Only this model's evaluations.")] = None,
    track: Annotated[str | None, typer.Option("--track", help="Only evaluations on this track.")] = None,
    limit: Annotated[int, typer.Option("--limit", help="At most this many, newest first.")] = 50,
    wide: Wide = False,
) -> None:
    """List stored evaluations, newest first.

    Example:

        drx eval list --model my-model
    """
    rows = service.list_evaluations(model=model, track=track, limit=limit)

    def render() -> None:
        if not rows:
            console.print("No evaluations yet; race a model with `drx evaluate MODEL`.")
            return
        races = any(r["race"] != "time-trial" for r in rows)  # race and crash columns only when needed
        columns = [
            Column("id", 0, "right"),
            Column("model", 0, kind="name"),
            Column("track", 1, kind="name"),
            Column("laps", 1, "right"),
            Column("fastest s", 0, "right"),
            Column("x best", 2, "right"),
            Column("average s", 3, "right"),
            Column("off-track", 4, "right"),
            *([Column("race", 4), Column("crashes", 4, "right")] if races else []),
            Column("checkpoint", 5),
            Column("date", 6),
        ]
        table_rows = [
            [
                str(r["id"]),
                r["model"],
                r["track"] + (" (rev)" if r["direction"] == "reverse" else ""),
                f"{r['laps_completed']}/{r['rules']['laps']}",
                _t(r["fastest_lap"]),
                _t(r["fastest_lap_ratio"], 2),
                _t(r["average_lap"]),
                str(r["off_track_count"]),
                *([r["race"], str(r["crash_count"])] if races else []),
                f"{r['checkpoint']} ({r['checkpoint_iteration']})",
                r["created_at"].strftime("%Y-%m-%d"),
            ]
            for r in rows
        ]
        table = fitted_table(columns, table_rows, console=console, wide=wide, title="Evaluations")
        print_table(table, console, wide)

    emit(rows, render)


@app.command("show")
@json_option
def show(
    evaluation: Annotated[int, typer.Argument(help="The evaluation's id (see `drx eval list`).")],
) -> None:
    """Show one evaluation's summary and laps.

    Example:

        drx eval show 3 --json
    """
    data = service.get_evaluation(evaluation)
    emit(data, lambda: render_summary(data))
