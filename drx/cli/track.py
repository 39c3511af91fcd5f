"""``drx track``: built-in and imported race tracks."""

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option, note
from drx.services import tracks as service
from drx.services.tracks import TrackInfo

app = group("Race tracks: the built-in ones and DeepRacer routes you import.")

DIRECTION = {"ccw": "counter-clockwise", "cw": "clockwise", "-": "open (point to point)"}


@app.command("list")
@json_option
def list_tracks() -> None:
    """List built-in and imported tracks.

    Example:

      drx track list
    """
    infos = service.list_tracks()

    def render() -> None:
        table = Table(title="Tracks")
        for col, justify in (
            ("name", "left"),
            ("length m", "right"),
            ("width m", "right"),
            ("direction", "left"),
            ("source", "left"),
        ):
            table.add_column(col, justify=justify)  # type: ignore[arg-type]
        for t in infos:
            table.add_row(t.name, f"{t.length:.2f}", f"{t.width:.2f}", t.direction, t.source)
        console.print(table)

    emit([t.to_dict() for t in infos], render)


def _render_info(info: TrackInfo) -> None:
    table = Table(show_header=False, title=f"Track {info.name}")
    table.add_column(style="bold")
    table.add_column()
    table.add_row("source", f"{info.source} ({info.path})")
    table.add_row("length", f"{info.length:.3f} m (centre line)")
    width = f"{info.width:.3f} m"
    if info.width_min is not None and info.width_max is not None and info.width_max - info.width_min > 0.01:
        width += f" (from {info.width_min:.3f} to {info.width_max:.3f})"
    table.add_row("width", width)
    table.add_row("direction", DIRECTION.get(info.direction, info.direction))
    table.add_row("loop", "yes" if info.closed else "no")
    table.add_row("waypoints", str(info.n_waypoints))
    table.add_row("turns", str(info.turns))
    for n in info.notes:
        table.add_row("note", n)
    console.print(table)
    if info.corners:
        corners = Table(title="Turns")
        for col in ("#", "apex at m", "angle deg", "tightest radius m"):
            corners.add_column(col, justify="right")
        for i, c in enumerate(info.corners, 1):
            corners.add_row(str(i), f"{c['apex']:.2f}", f"{c['angle_deg']:+.0f}", f"{c['radius']:.2f}")
        console.print(corners)


@app.command("show")
@json_option
def show(
    name: Annotated[str, typer.Argument(help="A track name (see `drx track list`) or a .npy route file.")],
    png: Annotated[Path | None, typer.Option("--png", help="Also draw the track to this PNG file.")] = None,
) -> None:
    """Show a track's length, width, direction and turns; --png draws it.

    Example:

      drx track show oval --png oval.png
    """
    info, geometry = service.show_track(name)
    data = info.to_dict()
    if png is not None:
        data["png"] = str(service.write_track_png(geometry, png))

    def render() -> None:
        _render_info(info)
        if png is not None:
            console.print(f"Wrote {png}.")

    emit(data, render)


@app.command("import")
@json_option
def import_track(
    file: Annotated[Path, typer.Argument(help="A DeepRacer route file (.npy, shape (N, 6)).")],
    name: Annotated[str | None, typer.Option(help="The track's name [default: the file name].")] = None,
) -> None:
    """Import a DeepRacer route file, fixing its quirks (open or nearly closed loops, repeated
    points, skewed borders, swapped inner/outer borders) and saying what was fixed.

    Example:

      drx track import ~/routes/reinvent_base.npy --name reinvent
    """
    info = service.import_track(file, name)

    def render() -> None:
        console.print(
            f"Imported track [bold]{info.name}[/]: {info.length:.2f} m, {info.width:.2f} m wide, "
            f"{DIRECTION.get(info.direction, info.direction)}."
        )
        for n in info.notes:
            note(f"  fixed/noted: {n}")

    emit(info.to_dict(), render)


@app.command("rm")
@json_option
def remove(name: Annotated[str, typer.Argument(help="An imported track's name.")]) -> None:
    """Remove an imported track (refused while a model uses it; built-in tracks stay).

    Example:

      drx track rm reinvent
    """
    service.remove_track(name)
    emit({"removed": name}, lambda: console.print(f"Removed track [bold]{name}[/]."))
