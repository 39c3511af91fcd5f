"""``drx sim ...``: look at drx's simulator next to DeepRacer's (``drx sim replay``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from drx.cli.output import console, emit, json_option
from drx.errors import DrxError

app = typer.Typer(help="Check drx's simulator against DeepRacer's and look at what the car sees.",
                  no_args_is_help=True)  # fmt: skip


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
        str,
        typer.Option(
            "--simulator",
            help="drx's car as fitted to this DeepRacer simulator version's logs (deepracer-simapp 5: "
            "deepracer-for-cloud 2023, what drx trains with; 4: the console in 2022).",
        ),
    ] = "5",
) -> None:
    """Replay DeepRacer logs through drx's car and report how far apart they end.

    From every logged pose (moving at the logged speed), drx's car drives
    the logged commands open-loop for HORIZON steps; the table gives the
    distance between drx's reference point and the log's, and the heading
    difference, at the end (median and 90th percentile), overall, by
    commanded speed and by steering, beside what extrapolating the car's
    last motion would give.

    Examples:

        drx sim replay training-simtrace/*-iteration.csv
        drx sim replay robomaker.log --horizon 30 --png replay.png --json
    """
    from drx.sim.deepracer_logs import read_traces
    from drx.sim.dynamics import CarParams
    from drx.sim.replay import replay as run_replay

    if not 1 <= horizon <= 150:
        raise DrxError(f"--horizon {horizon} is out of range; use 1 to 150 steps.")
    car = CarParams.for_simulator(simulator)
    episodes = read_traces(list(logs))
    result = run_replay(episodes, car, horizon=horizon, keep_paths=12 if png else 0)
    if len(result) == 0:
        raise DrxError(
            f"the logs hold no stretch of {horizon} steps in progress to replay; give longer episodes "
            "or a shorter --horizon."
        )
    data = result.summary()
    data["logs"] = [str(p) for p in logs]
    data["simulator"] = simulator
    data["episodes"] = len(episodes)
    if png is not None:
        from drx.sim.replay_plot import draw_replay

        data["png"] = str(draw_replay(result, png))

    def render() -> None:
        table = Table(title=f"drx (simulator {simulator} car) vs DeepRacer after {horizon} steps "
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
