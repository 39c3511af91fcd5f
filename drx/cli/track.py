"""``drx track``: DeepRacer's tracks and drx's own (shipped with drx), and the routes users import."""

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option, note
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.services import tracks as service
from drx.services.tracks import TrackInfo

app = group("Race tracks: DeepRacer's and drx's own, by route id or display name; import your own.")

DIRECTION = {"ccw": "counter-clockwise", "cw": "clockwise", "-": "open (point to point)"}
SOURCE_HELP = "Only one source's tracks: deepracer (DeepRacer's), drx (drx's own) or imported."


def _display(info: TrackInfo) -> str:
    """The display name cell: the console's name, else what the track is."""
    if info.display_name:
        return info.display_name
    return {"deepracer": "no public display name", "drx": "drx's own track"}.get(
        info.source, f"{info.source} track"
    )


@app.command("list")
@json_option
def list_tracks(
    search: Annotated[
        str | None, typer.Option("--search", "-s", help="Only tracks whose name or display name holds this.")
    ] = None,
    source: Annotated[str | None, typer.Option("--source", help=SOURCE_HELP)] = None,
    wide: Wide = False,
) -> None:
    """List the tracks you can train on: DeepRacer's, drx's own and the ones you imported.

    A track is named by its route id (DeepRacer's file name, as its logs and tools use it) or by
    its display name, as the DeepRacer console lists it; every command that takes a track takes
    either.

    Examples:

      drx track list --search speedway

      drx track list --source deepracer --json
    """
    infos = service.list_tracks(search, source)

    def render() -> None:
        if not infos:
            what = f" matching {search!r}" if search else ""
            console.print(f"No tracks{what}; `drx track list` lists every track.")
            return
        # at 80 columns the source and the width go first (the rows are grouped by source), so
        # that "A to Z Speedway (clockwise)" keeps one line beside the longest route id
        columns = [
            Column("name", 0, kind="name"),
            Column("display name", 0, kind="prose", min_width=28),
            Column("source", 4),
            Column("length", 2, "right"),
            Column("width", 3, "right"),
            Column("dir", 1),
        ]
        rows = [
            [t.name, _display(t), t.source_label, f"{t.length:.2f}", f"{t.width:.2f}", t.direction]
            for t in infos
        ]
        table = fitted_table(columns, rows, console=console, wide=wide, title="Tracks (length, width in m)")
        print_table(table, console, wide)

    emit([t.to_dict() for t in infos], render)


def _render_info(info: TrackInfo) -> None:
    table = Table(show_header=False, title=f"Track {info.name}")
    table.add_column(style="bold")
    table.add_column()
    table.add_row("display name", _display(info))
    table.add_row("source", f"{info.source_label} ({info.path})")
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
    name: Annotated[
        str, typer.Argument(help="A track: route id or display name (`drx track list`), or a .npy route.")
    ],
    png: Annotated[Path | None, typer.Option("--png", help="Also draw the track to this PNG file.")] = None,
) -> None:
    """Show a track's length, width, direction and turns; --png draws it.

    Examples:

      drx track show reInvent2019_wide_cw --png a-to-z.png

      drx track show "Smile Speedway"
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
    """Import a route file (a new DeepRacer track, a custom one, your own), fixing its quirks (open
    or nearly closed loops, repeated points, skewed borders, swapped inner/outer borders) and
    saying what was fixed.

    DeepRacer's tracks that drx ships need no import; a name one of them answers to is refused
    (give --name). A DeepRacer route keeps its display name, whatever its --name.

    Example:

      drx track import ~/routes/Austin.npy

      drx track import my-track.npy --name my-track
    """
    info = service.import_track(file, name)

    def render() -> None:
        console.print(
            f"Imported track [bold]{info.name}[/]"
            + (f" ({info.display_name})" if info.display_name else "")
            + f": {info.length:.2f} m, {info.width:.2f} m wide, "
            f"{DIRECTION.get(info.direction, info.direction)}."
        )
        for n in info.notes:
            note(f"  fixed/noted: {n}")

    emit(info.to_dict(), render)


@app.command("rm")
@json_option
def remove(name: Annotated[str, typer.Argument(help="An imported track's name.")]) -> None:
    """Remove an imported track (refused while a model uses it; shipped tracks stay).

    Example:

      drx track rm reinvent
    """
    service.remove_track(name)
    emit({"removed": name}, lambda: console.print(f"Removed track [bold]{name}[/]."))
