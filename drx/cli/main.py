"""The ``drx`` command line: one Typer app; each command group lives in its own module.

Adding a group is one line below (``app.add_typer(module.app, name="...")``),
adding a top-level command is one ``app.command(...)(function)`` line.
"""

import sys

import typer

from drx.cli import (
    analyze,
    export,
    garage,
    info,
    jobs,
    model,
    plot,
    reward,
    sim,
    sweep,
    track,
    train,
    watch,
    worker,
)  # fmt: skip
from drx.cli import best_lap as best_lap_cli
from drx.cli import evaluate as evaluate_cli
from drx.cli import leaderboard as leaderboard_cli
from drx.cli.app import DrxGroup
from drx.cli.flags import cli_sentence
from drx.cli.output import error
from drx.errors import DrxError

app = typer.Typer(
    name="drx",
    cls=DrxGroup,
    help="drx: a local, open-source replacement for the AWS DeepRacer console.",
    no_args_is_help=True,
    rich_markup_mode="markdown",
    pretty_exceptions_show_locals=False,
)

# ----- command groups and commands (one line each) ---------------------------
app.command("info")(info.info)
app.add_typer(garage.app, name="garage")
app.add_typer(track.app, name="track")
app.add_typer(reward.app, name="reward")
app.add_typer(model.app, name="model")
export.register(model.app)  # drx model path|export|import
app.command("plot")(plot.plot)
app.command("analyze")(analyze.analyze)
app.command("train")(train.train)
app.command("worker")(worker.worker)
app.add_typer(jobs.app, name="jobs")
app.add_typer(jobs.job_app, name="job")
app.command("evaluate")(evaluate_cli.evaluate)
app.add_typer(evaluate_cli.app, name="eval")
app.command("leaderboard")(leaderboard_cli.leaderboard)
app.command("watch")(watch.watch)
track.app.command("best-lap")(best_lap_cli.best_lap)
app.add_typer(sim.app, name="sim")
app.add_typer(sweep.app, name="sweep")


def run() -> None:
    """Console-script entry point: run the app; a :class:`DrxError` exits 2 with one sentence."""
    try:
        app()
    except DrxError as exc:  # raised outside a command (the group catches those inside)
        error(cli_sentence(exc))
        sys.exit(exc.exit_code)


if __name__ == "__main__":
    run()
