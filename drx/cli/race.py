"""``drx race A B [C D] --track T``: the user's models race each other, DeepRacer's multi-car rules."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any

import typer

from drx.cli.output import console, emit, json_option, note
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.errors import SettingError

RULES = "DeepRacer's multi-car rules"


def _rule(flag: str, text: str) -> Any:
    return typer.Option(flag, help=text, rich_help_panel=RULES)


Models = Annotated[list[str], typer.Argument(help="Two to four models (with --bracket: 2 to 16).")]
TrackOpt = Annotated[str | None, typer.Option("--track", help="The track every model trained on.")]
Laps = Annotated[int, typer.Option("--laps", help="Laps each car drives, 1-100.")]
OffTrack = Annotated[
    float, _rule("--off-track-penalty", "OFF_TRACK_PENALTY: s stood after leaving the road.")
]
Collision = Annotated[
    float, _rule("--collision-penalty", "COLLISION_PENALTY: s the car behind stands after a collision.")
]
Reverse = Annotated[
    float | None,
    _rule("--reverse-penalty", "REVERSE_PENALTY: s after driving the wrong way [the off-track penalty]."),
]
Immobilized = Annotated[float, _rule("--immobilized-penalty", "IMMOBILIZED_PENALTY: s after standing still.")]
Done = Annotated[
    str, _rule("--done-condition", "DONE_CONDITION: any (the first car home ends the race) or all.")
]
Offset = Annotated[
    float, _rule("--start-position-offset", "START_POS_OFFSET: m between consecutive cars at the start, 0-1.")
]
TimeCap = Annotated[float, typer.Option("--time-cap-minutes", help="The race ends at this race time.")]
Seed = Annotated[
    int | None,
    typer.Option(
        "--seed", help="Seed of the simulator's noise: the same seed repeats a race [a new one, shown]."
    ),
]
Video = Annotated[Path | None, typer.Option("--video", help="Record the race to this .mp4 or .gif file.")]
Bracket = Annotated[
    bool, typer.Option("--bracket", help="A single-elimination bracket of 1-against-1 races.")
]


@json_option
def race(
    models: Models,
    track: TrackOpt = None,
    laps: Laps = 3,
    off_track_penalty: OffTrack = 2.0,
    collision_penalty: Collision = 5.0,
    reverse_penalty: Reverse = None,
    immobilized_penalty: Immobilized = 0.0,
    done_condition: Done = "any",
    start_position_offset: Offset = 0.75,
    time_cap_minutes: TimeCap = 20.0,
    seed: Seed = None,
    video: Video = None,
    bracket: Bracket = False,
    wide: Wide = False,
) -> None:
    """Race two to four of your models against each other on one track, and store the race.

    Each car drives with its own network, sensors and action space; the other
    cars are objects its camera and lidar see, and a collision is one for both.
    DeepRacer's multi-car rules apply (each an option with its simapp name):
    racecar_0 starts on the line in the outer lane, the next 0.75 m behind in
    the inner lane, and so on; off the road a car is put back and stands the
    off-track penalty; in a collision the car behind stands the collision
    penalty where it is; the race ends when the first car has driven its laps
    (--done-condition all: when every car has). A car's time is the race clock
    at its finish, penalties stood included. Each car's steps go to an
    evaluation trace in its model's folder (`drx analyze` reads it), and
    `drx leaderboard --race-type head-to-head` ranks the models by Elo rating.

    --bracket races 2 to 16 models two at a time, seeded by their fastest
    time-trial laps on the track (models without one last), the winner of each
    match going on (DeepRacer's Bracket of 16), and prints the tree.

    Examples:

        drx race fast-one steady-one --track oval --laps 3

        drx race a b c d --track oval --json --seed 7 --video race.mp4

        drx race --bracket m1 m2 m3 m4 m5 m6 m7 m8 --track oval --laps 1
    """
    from drx.evaluate.head_to_head import HeadToHeadRules

    if track is None:
        raise SettingError("A race needs {field}: name the track every model trained on.", "track")
    rules = HeadToHeadRules(
        laps=laps, off_track_penalty=off_track_penalty, collision_penalty=collision_penalty,
        reverse_penalty=reverse_penalty, immobilized_penalty=immobilized_penalty,
        done_condition=done_condition, start_position_offset=start_position_offset,
        time_cap_minutes=time_cap_minutes,
    )  # fmt: skip
    if video is not None:
        from drx.evaluate.race_video import check_video_path

        check_video_path(video)
    if bracket:
        _bracket(models, track, rules, seed, wide)
        return
    from drx.evaluate import race_service, race_store

    prepared = race_service.prepare(models, track, rules, seed)
    cars = ", ".join(f"{r.name} (iteration {r.checkpoint.iteration})" for r in prepared.racers)
    note(f"Racing {cars} on {prepared.track_name} ({prepared.direction}): {laps} laps, done condition "
         f"{rules.done_condition}, seed {prepared.seed}.")  # fmt: skip
    try:
        result = race_service.run(prepared, video=video)
    except KeyboardInterrupt:
        console.print("Race interrupted; nothing was stored.", style="yellow")
        raise typer.Exit(code=130) from None
    race_id = race_store.store_race(prepared, result, video=None if video is None else str(video))
    data = {"id": race_id, "track": prepared.track_name, "direction": prepared.direction, **result.to_dict()}
    for car in data["cars"]:
        trace = prepared.traces.get(car["name"])
        car["trace"] = None if trace is None else str(trace)
    data["video"] = None if video is None else str(video)
    emit(data, lambda: _render(data, wide))


def _render(data: dict[str, Any], wide: bool) -> None:
    """The race for people: who won, the table, how it ended."""
    cars = data["cars"]
    rules = data["rules"]
    console.print(
        f"[bold]Race {data['id']}[/] on {data['track']} ({data['direction']}), {rules['laps']} "
        f"lap{'s' if rules['laps'] != 1 else ''}, seed {data['seed']}", highlight=False
    )
    columns = [
        Column("#", 0, "right"),
        Column("model", 0, kind="name"),
        Column("laps", 0, "right"),
        Column("time s", 0, "right"),
        Column("penalty s", 1, "right"),
        Column("coll.", 1, "right"),
        Column("off-track", 2, "right"),
        Column("lap times", 3, kind="prose", min_width=12),
    ]
    rows = []
    for car in cars:
        time = f"{car['time']:.3f}" if car["time"] is not None else f"- ({car['progress']:.0f}%)"
        coll = f"{car['collisions']}" + (f" ({car['crashes']})" if car["crashes"] else "")
        laps = " ".join(f"{t:.2f}" for t in car["lap_times"]) or "-"
        rows.append([str(car["place"]), car["name"], str(car["laps"]), time, f"{car['penalty_seconds']:g}",
                     coll, str(car["off_tracks"]), laps])  # fmt: skip
    print_table(fitted_table(columns, rows, console=console, wide=wide), console, wide)
    ended = {"any_finished": "the first car finished (done condition any)",
             "all_finished": "every car finished (done condition all)",
             "time_cap": "the time cap"}[data["ended"]]  # fmt: skip
    note = "coll.: collisions (in brackets, those it stood the collision penalty for, being the car behind)."
    console.print(f"Ended by {ended} at {data['race_time']:.2f} s. {note}", highlight=False)
    if data.get("video"):
        console.print(f"Video: {data['video']}", highlight=False, soft_wrap=True)


def _bracket(models: list[str], track: str, rules: Any, seed: int | None, wide: bool) -> None:
    """Run a bracket (every match a stored race) and print its tree."""
    from drx.evaluate import race_service, race_store
    from drx.evaluate.bracket import BRACKET_RANGE, Match, first_round, seeds
    from drx.evaluate.service import default_seed
    from drx.settings.seed import check_seed

    lo, hi = BRACKET_RANGE
    if not lo <= len(models) <= hi:
        raise SettingError("A bracket takes {lo} to {hi} models, not {n}.", "models",
                           lo=lo, hi=hi, n=len(models))  # fmt: skip
    check_seed(seed)
    entry, _route, _racers, _direction = race_service.check_models(models, track)  # before any match
    track_name = entry.name
    seeded = seeds(models, race_store.best_time_trial_laps(track_name, models))
    base_seed = seed if seed is not None else default_seed()
    name = f"bracket-{datetime.now(UTC):%Y%m%d-%H%M%S}"
    rounds = [first_round(seeded)]
    k = 0
    while True:
        for match in rounds[-1]:
            if match.bye:
                match.winner = match.a or match.b
                continue
            assert match.a is not None and match.b is not None
            prepared = race_service.prepare([match.a, match.b], track, rules, seed=base_seed + k)
            k += 1
            result = race_service.run(prepared)
            match.race_id = race_store.store_race(prepared, result, bracket=name, bracket_round=match.round)
            match.winner = result.winner.name
            match.result = result.to_dict()
        winners = [m.winner for m in rounds[-1]]
        if len(winners) == 1:
            break
        r = rounds[-1][0].round + 1
        rounds.append([Match(r, winners[i], winners[i + 1]) for i in range(0, len(winners), 2)])
    data = {
        "bracket": name, "track": track_name, "seeds": seeded, "winner": rounds[-1][0].winner,
        "rounds": [[{"a": m.a, "b": m.b, "winner": m.winner, "race": m.race_id, "result": m.result}
                    for m in matches] for matches in rounds],
    }  # fmt: skip
    emit(data, lambda: _render_bracket(data, rounds))


def _render_bracket(data: dict[str, Any], rounds: list[Any]) -> None:
    """The seeds, the tree (when it fits the terminal) and every match with its race."""
    from drx.evaluate.bracket import tree_diagram, tree_lines

    console.print(f"[bold]Bracket {data['bracket']}[/] on {data['track']}", highlight=False)
    console.print("Seeds: " + ", ".join(f"{i}. {m}" for i, m in enumerate(data["seeds"], start=1)),
                  highlight=False)  # fmt: skip
    tree = tree_diagram(rounds)
    if tree and max(len(line) for line in tree) <= console.width:
        console.print("\n".join(tree), highlight=False, soft_wrap=True)
    for line in tree_lines(rounds):
        console.print(line, highlight=False)
