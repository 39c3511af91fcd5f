"""``drx track best-lap TRACK --car CAR``: the theoretical best lap of a car on a track."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from drx.cli.output import console, emit, json_option
from drx.errors import DrxError, check_png


@json_option
def best_lap(
    track: Annotated[
        str, typer.Argument(help="A track: route id or display name (`drx track list`), or a .npy route.")
    ],
    car: Annotated[str | None, typer.Option("--car", help="A garage car [DeepRacer's default car].")] = None,
    png: Annotated[Path | None, typer.Option("--png", help="Draw the racing line to this PNG file.")] = None,
    reverse: Annotated[bool, typer.Option("--reverse", help="Drive the loop the other way.")] = False,
    line: Annotated[
        bool, typer.Option("--line", help="With --json: include the line's points and speeds.")
    ] = False,
    simulator: Annotated[
        str | None,
        typer.Option(
            "--simulator",
            metavar="VERSION",
            help="The car of DeepRacer simulator 5 (the console's) or 6 (DeepRacer on AWS and "
            "deepracer-for-cloud since 2026) [default: 6].",
        ),
    ] = None,
) -> None:
    """The theoretical best lap of a car on a track, in drx's simulator.

    A minimum-curvature racing line inside the borders (keeping the car's
    half-width clear) driven with a forward-backward speed profile under the
    limits of drx's car model, calibrated to DeepRacer's logs: top speed,
    grip, a steering lock whose effect shrinks with speed, motor lag,
    acceleration and braking. The lap starts from rest at the start line, as
    every DeepRacer evaluation lap does; the flying lap is already at speed.
    A scripted driver then follows the line in drx's simulator, and where it
    laps faster, its lap is the best lap.

    Examples:

        drx track best-lap reinvent_base --car fast --png best.png

        drx track best-lap "A to Z Speedway (clockwise)" --json

        drx track best-lap reinvent_base --simulator 5
    """
    from drx.settings.car import DEFAULT_SIMULATOR, check_simulator

    version = check_simulator(simulator if simulator is not None else DEFAULT_SIMULATOR)
    if png is not None:
        check_png(png, "png")  # before the solve and the drive, not after them
    from drx.evaluate.theoretical_lap import best_lap as compute  # NumPy and the geometry load here only
    from drx.services import garage
    from drx.services.tracks import load_track_by_name
    from drx.vehicle import default_vehicle

    vehicle = garage.get_vehicle(car) if car else default_vehicle()
    geometry = load_track_by_name(track)
    if reverse:
        if not geometry.closed:
            raise DrxError(f"Track {geometry.name!r} is not a loop; --reverse applies to loops only.")
        geometry = geometry.reversed()
    from drx.sim.dynamics import CarParams

    result = compute(geometry, vehicle, CarParams.for_simulator(version))
    data = result.to_dict(with_line=line)
    data["track"] = geometry.name  # the route id, whatever name was typed
    data["simulator"] = version
    if png is not None:
        from drx.evaluate.theoretical_lap_plot import draw_best_lap

        data["png"] = str(draw_best_lap(geometry, result, png))

    def render() -> None:
        table = Table(show_header=False, title=f"Best lap: {vehicle.name} on {geometry.name}")
        table.add_column(style="bold")
        table.add_column()
        table.add_row("lap time", f"{result.lap_time:.3f} s (from rest at the start line)")
        table.add_row("car", f"DeepRacer simulator {version}'s")
        driven = result.driven_time
        table.add_row(
            "how",
            f"speed profile {result.estimate_time:.3f} s; a scripted driver on the line "
            + ("left the road" if driven is None else f"{driven:.3f} s in the simulator"),
        )
        if result.line.closed:
            table.add_row("flying lap", f"{result.flying_lap_time:.3f} s (already at speed, speed profile)")
        table.add_row("racing line", f"{result.line.length:.2f} m (centre line {geometry.length:.2f} m)")
        table.add_row("line", result.line_kind)
        table.add_row("speeds", f"{result.speeds.min():.2f} to {result.speeds.max():.2f} m/s, "
                      f"average {result.line.length / result.lap_time:.2f}")  # fmt: skip
        lim = result.limits
        table.add_row(
            "limits",
            f"top speed {lim.top_speed:.2f} m/s, grip {lim.lateral_accel:.2f} m/s²"
            + (" (less while the wheels slip), " if lim.grip_slip > 0 else ", ")
            + f"acceleration {lim.max_acceleration:.2f} m/s², braking {lim.max_braking:.2f} m/s²",
        )
        if png is not None:
            table.add_row("picture", str(png))
        console.print(table)

    emit(data, render)
