"""``drx garage``: cars (action space, sensors, network)."""

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option
from drx.services import garage as service
from drx.services.garage import GarageEntry
from drx.vehicle import Action, Vehicle

app = group("Design cars: action space, sensors and network (DeepRacer's garage).")


def _entry_dict(entry: GarageEntry) -> dict:
    v = entry.vehicle
    return {
        "name": v.name,
        "source": entry.source,
        "summary": v.summary(),
        **service.vehicle_metadata(v),
        "created_at": entry.created_at,
    }


def _sensors(v: Vehicle) -> str:
    return ("stereo camera" if v.sensor == "stereo" else "camera") + (" + lidar" if v.lidar else "")


@app.command("add")
@json_option
def add(
    name: Annotated[str, typer.Argument(help="The car's name (letters, digits, '-', '_').")],
    from_file: Annotated[
        Path | None, typer.Option("--from", help="Load the car from a TOML file (see garage/*.toml).")
    ] = None,
    max_steering: Annotated[
        float | None, typer.Option(help="Largest steering angle, 1-30 deg [default: 30].")
    ] = None,
    steering_levels: Annotated[
        int | None, typer.Option(help="Steering values: 3, 5 or 7 [default: 5].")
    ] = None,
    max_speed: Annotated[
        float | None, typer.Option(help="Top speed, 0.1-4 m/s [default: 1; 4 with --from-racing-line].")
    ] = None,
    speed_levels: Annotated[int | None, typer.Option(help="Speed values: 1, 2 or 3 [default: 2].")] = None,
    actions_file: Annotated[
        Path | None,
        typer.Option(help="A custom action list (2-30 actions): JSON [{steering_angle, speed}] or CSV."),
    ] = None,
    continuous: Annotated[
        bool, typer.Option("--continuous", help="A continuous action space (ranges instead of a list).")
    ] = False,
    min_steering: Annotated[
        float | None, typer.Option(help="Continuous: lowest steering, deg [default: -max-steering].")
    ] = None,
    min_speed: Annotated[
        float | None, typer.Option(help="Continuous: lowest speed, 0.5-4 m/s [default: 0.5].")
    ] = None,
    sensor: Annotated[
        str | None, typer.Option(help="camera (front camera) or stereo [default: camera].")
    ] = None,
    lidar: Annotated[bool, typer.Option("--lidar", help="Add a lidar.")] = False,
    network: Annotated[
        str | None,
        typer.Option(
            help="Network: compact (drx's, for CPUs), shallow or deep (DeepRacer's) [default: compact]."
        ),
    ] = None,
    from_racing_line: Annotated[
        str | None,
        typer.Option(
            "--from-racing-line",
            metavar="TRACK",
            help="Cluster the actions from the commands of drx's racing line on this track "
            "(route id, display name or .npy route).",
        ),
    ] = None,
    actions: Annotated[
        int | None,
        typer.Option(
            help=f"With --from-racing-line: how many actions, 2-30 [default: {service.RACING_LINE_ACTIONS}]."
        ),
    ] = None,
) -> None:
    """Add a car to the garage.

    Defaults are DeepRacer's, 10 actions (30 deg x 5, 1 m/s x 2) and a front camera, with drx's
    compact network (trains ~10x faster on a CPU; --network shallow for DeepRacer's).

    --from-racing-line TRACK derives a custom action list from the track, as the fastest racers
    do: the steering and speed drx's car needs at each point of the best lap's racing line
    (`drx track best-lap`), clustered into --actions actions, keeping a straight-ahead action at
    the top speed and the sharpest steering each way the line turns. --max-speed and
    --max-steering cap them.

    Examples:

      drx garage add racer --max-speed 3 --speed-levels 3 --steering-levels 7

      drx garage add smooth --continuous --max-steering 20 --min-speed 1 --max-speed 3

      drx garage add fast --from garage/fast-discrete.toml

      drx garage add liner --from-racing-line reInvent2019_wide_cw --actions 15 --max-speed 4
    """
    derived: dict[str, Any] = {}  # what the racing line left, for the table and --json

    def line_actions(count: int, lock: float, top: float) -> tuple[Action, ...]:
        from drx.evaluate.action_space import racing_line_actions  # NumPy and the solver load here only
        from drx.services.tracks import load_track_by_name

        geometry = load_track_by_name(str(from_racing_line))
        space = racing_line_actions(geometry, count, lock, top, car_name=name)
        derived.update(track=geometry.name, space=space)
        return space.actions

    vehicle = service.vehicle_from_options(
        name,
        from_file=from_file,
        actions_file=actions_file,
        continuous=continuous,
        max_steering=max_steering,
        steering_levels=steering_levels,
        max_speed=max_speed,
        speed_levels=speed_levels,
        min_steering=min_steering,
        min_speed=min_speed,
        sensor=sensor,
        lidar=lidar,
        network=network,
        from_racing_line=line_actions if from_racing_line is not None else None,
        actions=actions,
    )
    source = str(from_file) if from_file else (str(actions_file) if actions_file else "options")
    if derived:
        source = f"racing line of {derived['track']}"
    entry = service.add_vehicle(vehicle, source=source)
    data = _entry_dict(entry)
    if derived:
        data["racing_line"] = derived["space"].to_dict()

    def render() -> None:
        console.print(
            f"Added car [bold]{entry.name}[/]: {vehicle.summary()}, {_sensors(vehicle)}, {vehicle.network}."
        )
        if derived:
            line = data["racing_line"]
            steer, speed = line["steering_range"], line["speed_range"]
            console.print(
                f"From the racing line of {line['track']}: {line['points']} points over "
                f"{line['line_length']:.2f} m (best lap {line['lap_time']:.2f} s), steering {steer[0]:g} "
                f"to {steer[1]:g} deg, speed {speed[0]:g} to {speed[1]:g} m/s; the point farthest from its "
                f"action misses it by {line['largest_steering_miss']:g} deg and "
                f"{line['largest_speed_miss']:g} m/s."
            )
            console.print(_action_table(vehicle))

    emit(data, render)


@app.command("list")
@json_option
def list_cars() -> None:
    """List the cars in the garage.

    Example:

      drx garage list --json
    """
    entries = service.list_vehicles()

    def render() -> None:
        table = Table(title="Garage")
        for col in ("name", "action space", "sensors", "network", "source"):
            table.add_column(col)
        for e in entries:
            v = e.vehicle
            table.add_row(e.name, v.summary(), _sensors(v), v.network, e.source)
        console.print(table)

    emit([_entry_dict(e) for e in entries], render)


@app.command("show")
@json_option
def show(name: Annotated[str, typer.Argument(help="The car's name.")]) -> None:
    """Show a car and its action table, as DeepRacer does (action number, steering, speed).

    --json prints model_metadata.json's keys (action_space, sensor, neural_network...).

    Example:

      drx garage show default
    """
    entry = service.get_entry(name)
    v = entry.vehicle

    def render() -> None:
        console.print(f"[bold]{v.name}[/] ({entry.source}): {v.summary()}")
        console.print(f"Sensors: {_sensors(v)}; network: {v.network}")
        console.print(_action_table(v))

    emit(_entry_dict(entry), render)


def _action_table(v: Vehicle) -> Table:
    """The car's action space as the console shows it: ranges, or action number, steering and speed.

    :param v: the car.
    """
    if v.continuous:
        table = Table(title="Action space (continuous)")
        for col in ("", "low", "high"):
            table.add_column(col)
        table.add_row("steering angle (deg)", f"{v.steering_range[0]:g}", f"{v.steering_range[1]:g}")
        table.add_row("speed (m/s)", f"{v.speed_range[0]:g}", f"{v.speed_range[1]:g}")
        return table
    table = Table(title="Action space")
    table.add_column("action", justify="right")
    table.add_column("steering angle (deg)", justify="right")
    table.add_column("speed (m/s)", justify="right")
    for i, a in enumerate(v.actions):
        table.add_row(str(i), f"{a.steering_angle:g}", f"{a.speed:g}")
    return table


@app.command("rm")
@json_option
def remove(name: Annotated[str, typer.Argument(help="The car's name.")]) -> None:
    """Remove a car from the garage. Models made with it keep their own copy of it.

    Example:

      drx garage rm racer
    """
    service.remove_vehicle(name)
    emit({"removed": name}, lambda: console.print(f"Removed car [bold]{name}[/]."))
