"""``drx sim``: look inside the simulator (what the car's camera sees at a place on a track).

Each command is one function registered on :data:`app`; add another with ``@app.command(...)``.
"""

from pathlib import Path
from typing import Annotated

import cv2
import typer

from drx.cli.app import group
from drx.cli.output import console, emit, json_option
from drx.errors import DrxError

app = group("Look inside the simulator: what the car's camera sees.")


@app.command("camera")
@json_option
def camera(
    track: Annotated[str, typer.Argument(help="A track name (see `drx track list`) or a .npy route file.")],
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

      drx sim camera oval --domain-randomization --seed 3 --png random.png
    """
    from drx.services.tracks import show_track
    from drx.sim.camera_view import camera_picture, place_car

    if png.suffix.lower() != ".png":
        raise DrxError(f"--png {png} must end in .png.")
    _, geometry = show_track(track)
    place = place_car(geometry, progress, offset, heading)
    frame, picture, scene = camera_picture(
        geometry, place, stereo=stereo, randomize=domain_randomization, seed=seed, scale=scale
    )
    png.parent.mkdir(parents=True, exist_ok=True)
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
