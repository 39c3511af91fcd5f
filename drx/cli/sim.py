"""``drx sim``: look inside the simulator (what the car's camera sees at a place on a track) and check
it against DeepRacer's own logs (``drx sim replay``).

Each command is one function registered on :data:`app`; add another with ``@app.command(...)``.
"""

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from drx.calibration.log_metadata import LogActionSpace
from drx.cli.app import group
from drx.cli.output import console, emit, json_mode, json_option
from drx.errors import DrxError, check_png
from drx.sim.car_calibration import DEFAULT_SIMULATOR

app = group("Look inside the simulator: what the car's camera sees; how its car compares with DeepRacer's.")


@app.command("camera")
@json_option
def camera(
    track: Annotated[
        str, typer.Argument(help="A track: route id or display name (`drx track list`), or a .npy route.")
    ],
    png: Annotated[Path, typer.Option("--png", help="Write the camera frame to this PNG file.")],
    progress: Annotated[float, typer.Option(help="Where the car stands: percent of the lap, 0-100.")] = 0.0,
    offset: Annotated[float, typer.Option(help="Metres left of the centre line (negative: right).")] = 0.0,
    heading: Annotated[float, typer.Option(help="Degrees turned left from the track's direction.")] = 0.0,
    stereo: Annotated[
        bool, typer.Option("--stereo", help="Both stereo cameras, left and right panels.")
    ] = False,
    domain_randomization: Annotated[
        bool,
        typer.Option(
            "--domain-randomization", help="A randomised look (lighting, colours), drawn with --seed."
        ),
    ] = False,
    seed: Annotated[int, typer.Option(help="Seed of the randomised look.")] = 0,
    scale: Annotated[int, typer.Option(help="Picture pixels per camera pixel (1-8).")] = 4,
) -> None:
    """Write what the car's camera sees at a place on a track: the 160x120 grey frame a model gets.

    The car's origin (the middle of its wheelbase) stands --progress percent along the centre
    line, --offset metres to its left, heading along the track (turned by --heading).

    Examples:

      drx sim camera reinvent_base --png start.png

      drx sim camera reinvent_base --progress 25 --offset 0.2 --stereo --png stereo.png

      drx sim camera "Smile Speedway" --progress 50 --png smile.png

      drx sim camera oval --domain-randomization --seed 3 --png random.png
    """
    from drx.services.tracks import load_track_by_name
    from drx.sim.camera_view import camera_picture, place_car

    check_png(png, "png")
    geometry = load_track_by_name(track)
    place = place_car(geometry, progress, offset, heading)
    frame, picture, scene = camera_picture(
        geometry, place, stereo=stereo, randomize=domain_randomization, seed=seed, scale=scale
    )
    png.parent.mkdir(parents=True, exist_ok=True)
    import cv2

    if not cv2.imwrite(str(png), picture):
        raise DrxError(f"Cannot write the picture to {png}; give a writable path ending in .png.")
    data = {
        "track": geometry.name,
        "png": str(png),
        "progress": progress,
        "offset": offset,
        "x": round(place.x, 4),
        "y": round(place.y, 4),
        "heading": round(place.heading, 2),
        "cameras": 2 if stereo else 1,
        "frame_shape": list(frame.shape),
        "mean_grey": round(float(frame.mean()), 1),
        "domain_randomization": {"seed": seed, "sun": list(scene.lighting.sun)}
        if domain_randomization
        else None,
    }

    def render() -> None:
        what = "stereo frames" if stereo else "camera frame"
        console.print(
            f"Wrote the {what} at {progress:g}% of {geometry.name} (x {place.x:.2f} m, y {place.y:.2f} m, "
            f"heading {place.heading:.1f} deg) to {png}."
        )

    emit(data, render)


@app.command("replay")
@json_option
def replay(
    logs: Annotated[
        list[Path],
        typer.Argument(
            help="DeepRacer sim-trace CSVs (N-iteration.csv) or robomaker logs (SIM_TRACE_LOG lines)."
        ),
    ],
    horizon: Annotated[
        int, typer.Option("--horizon", help="Steps to drive open-loop from each logged pose (15 = 1 s).")
    ] = 15,
    png: Annotated[
        Path | None, typer.Option("--png", help="Draw logged against simulated paths to this PNG file.")
    ] = None,
    simulator: Annotated[
        str | None,
        typer.Option(
            "--simulator",
            help="drx's car as fitted to this DeepRacer simulator version's logs (deepracer-simapp 5: "
            "deepracer-for-cloud 2023, what drx trains with; 4: the console in 2022). Default: the "
            f"version the logs' metadata names, else {DEFAULT_SIMULATOR}.",
            show_default=False,
        ),
    ] = None,
) -> None:
    """Replay DeepRacer logs through drx's car and report how far apart they end.

    From every logged pose (moving at the logged speed), drx's car drives
    the logged commands open-loop for HORIZON steps; the table gives the
    distance between drx's reference point and the log's, and the heading
    difference, at the end (median and 90th percentile), overall, by
    commanded speed and by steering, beside what extrapolating the car's
    last motion would give.

    The car is the one fitted to the DeepRacer simulator version that
    recorded the logs, as their metadata says: the robomaker log's
    simapp_version line, the console's sagemaker log beside it, a
    LOG.meta.json beside it (deepracer-log-guru), or the console's
    model/model_metadata.json a few folders up; --simulator overrides it.
    The logs' action space, from the same places, is printed beside it.

    Every layout DeepRacer has written reads: sim-trace CSVs with their
    header, robomaker logs of 16 to 19 fields a step, discrete or
    continuous actions. No track is needed: the car drives from the
    logged poses, whichever way round the track was driven.

    Examples:

      drx sim replay training-simtrace/*-iteration.csv

      drx sim replay robomaker.log --horizon 30 --png replay.png --json

      drx sim replay old-console-logs/*-iteration.csv --simulator 4
    """
    from drx.calibration.log_metadata import action_spaces_of_logs, choose_simulator
    from drx.calibration.logs import read_trace_files
    from drx.calibration.replay import replay as run_replay
    from drx.sim.dynamics import CarParams

    if not 1 <= horizon <= 150:
        raise DrxError(f"--horizon {horizon} is out of range; use 1 to 150 steps.")
    if png is not None:
        check_png(png, "png")
    choice = choose_simulator(logs, simulator)  # before reading the logs: a disagreement ends it at once
    car = CarParams.for_simulator(choice.version)
    traces = read_trace_files(logs)
    episodes = [episode for trace in traces for episode in trace.episodes]
    spaces = action_spaces_of_logs(logs)
    if not json_mode():  # which car, and why, on a line of its own (paths unbroken: no wrapping)
        said = choice.source
        if choice.chosen_by != "default":
            said = f"simulator {choice.version}'s car: {said}"
        lines = [f"{said[0].upper()}{said[1:]}."]
        if choice.note is not None:  # said of the car, so beside its line
            lines.append(f"Note: {choice.note}")
        lines += _action_space_lines(spaces)
        lines += [f"Note: {note}" for note in (trace.malformed_note() for trace in traces) if note]
        for line in lines:
            console.print(line, soft_wrap=True, markup=False)
    result = run_replay(episodes, car, horizon=horizon, keep_paths=12 if png else 0)
    if len(result) == 0:
        raise DrxError(
            f"the logs hold no stretch of {horizon} steps in progress to replay; give longer episodes "
            "or a shorter --horizon."
        )
    data = result.summary()
    data["logs"] = [str(p) for p in logs]
    data["simulator"] = choice.version
    data["simulator_chosen_by"] = choice.chosen_by
    data["simulator_source"] = choice.source
    data["simulator_in_logs"] = list(choice.in_logs)
    data["simulator_note"] = choice.note
    data["episodes"] = len(episodes)
    data["action_spaces"] = [space.to_dict() | {"logs": count} for space, count in _distinct_spaces(spaces)]
    data["logs_without_action_space"] = sum(space is None for space in spaces)
    data["malformed_rows"] = {trace.path: len(trace.malformed) for trace in traces if trace.malformed}
    if png is not None:
        from drx.calibration.replay_plot import draw_replay

        data["png"] = str(draw_replay(result, png))

    def render() -> None:
        table = Table(title=f"drx (simulator {choice.version} car) vs DeepRacer after {horizon} steps "
                      f"({len(result)} windows, {len(episodes)} episodes)")  # fmt: skip
        table.add_column("windows")
        for name in ("position cm\nmedian / p90", "heading deg\nmedian / p90", "extrapolation\ncm"):
            table.add_column(name, justify="right")
        rows = [("all", data["overall"]), ("speed >= 2.5 m/s", data["fast_commands"]),
                ("|steering| >= 20 deg", data["hard_steering"])]  # fmt: skip
        rows += [(f"speed {k}", v) for k, v in data["by_speed"].items()]
        rows += [(f"steering {k}", v) for k, v in data["by_steering"].items()]
        for label, st in rows:
            if not st.get("windows"):
                continue
            table.add_row(
                f"{label} ({st['windows']})",
                f"{st['position_median_cm']:.1f} / {st['position_p90_cm']:.1f}",
                f"{st['heading_median_deg']:.1f} / {st['heading_p90_deg']:.1f}",
                f"{st['extrapolation_median_cm']:.1f}",
            )
        console.print(table)
        if png is not None:
            console.print(f"paths: {png}")

    emit(data, render)


def _distinct_spaces(spaces: list[LogActionSpace | None]) -> list[tuple[LogActionSpace, int]]:
    """Each distinct action space the logs name (the first log's, for where it was found) and how many
    logs name it, in the logs' order."""
    groups: dict[tuple[object, ...], list[LogActionSpace]] = {}
    for space in spaces:
        if space is not None:
            groups.setdefault(space.key(), []).append(space)
    return [(members[0], len(members)) for members in groups.values()]


def _action_space_lines(spaces: list[LogActionSpace | None]) -> list[str]:
    """``Action space: continuous, steering -20 to 30 deg, ... (Action space from file in X).``, one
    line per distinct space, and how many logs name none."""
    total = len(spaces)
    lines = []
    for space, count in _distinct_spaces(spaces):
        whose = "Action space" if total == 1 else f"Action space of {count} of the {total} logs"
        more = f" for the first, the same for the other {count - 1}" if count > 1 else ""
        lines.append(f"{whose}: {space.describe()} ({space.source}{more}).")
    silent = sum(space is None for space in spaces)
    if silent:
        which = "the log's metadata" if total == 1 else f"the metadata of {silent} of the {total} logs"
        lines.append(f"Action space: not in {which}.")
    return lines
