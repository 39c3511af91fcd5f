"""The ``drx`` command line: one Typer app; each command group lives in its own module.

A command's module is imported only when that command runs (or its own ``--help`` is asked for):
``drx --help`` lists the commands from :data:`COMMANDS`, which holds each one's loader and the
one-line help the listing shows, so that every command starts without importing the others
(and their SQLAlchemy, NumPy, torch...). A test checks that each line matches the command's own help.

Adding a group or a top-level command is one :data:`COMMANDS` entry.
"""

from __future__ import annotations

import functools
import gc
import importlib
import sys
from collections.abc import Callable
from typing import Any

import typer

from drx.cli.app import DrxGroup, LazyCommand, collect_garbage
from drx.cli.flags import cli_sentence
from drx.cli.output import error
from drx.errors import DrxError


def _attr(module: str, name: str) -> Callable[[], Any]:
    """A loader returning ``module.name`` (imported on the first call)."""
    return lambda: getattr(importlib.import_module(module), name)


@functools.cache
def _model_app() -> typer.Typer:
    """``drx model``, with ``path``, ``export`` and ``import`` (:mod:`drx.cli.export`)."""
    from drx.cli import export, model

    export.register(model.app)
    return model.app


@functools.cache
def _track_app() -> typer.Typer:
    """``drx track``, with ``best-lap`` (:mod:`drx.cli.best_lap`)."""
    from drx.cli import best_lap, track

    track.app.command("best-lap")(best_lap.best_lap)
    return track.app


def _group(load: Callable[[], Any], help_line: str) -> LazyCommand:
    return LazyCommand(load, help_line, is_group=True)


def _command(load: Callable[[], Any], help_line: str) -> LazyCommand:
    return LazyCommand(load, help_line, is_group=False)


# ----- command groups and commands (one line each; the help is what `drx --help` lists) -------
COMMANDS: dict[str, LazyCommand] = {
    "info": _command(
        _attr("drx.cli.info", "info"),
        "Show drx's version, data home, database, schema revision, what the registry holds and the device.",
    ),
    "garage": _group(
        _attr("drx.cli.garage", "app"), "Design cars: action space, sensors and network (DeepRacer's garage)."
    ),
    "track": _group(
        _track_app, "Race tracks: DeepRacer's and drx's own, by route id or display name; import your own."
    ),
    "reward": _group(
        _attr("drx.cli.reward", "app"),
        "Reward functions: validate them as the console's Validate button does.",
    ),
    "model": _group(
        _model_app,
        "Models: a car, a track and a reward function, with hyperparameters and stop conditions.",
    ),
    "plot": _command(
        _attr("drx.cli.plot", "plot"),
        "Draw the reward graph: reward and progress per episode, averages per iteration, "
        "the best checkpoint.",
    ),
    "analyze": _command(
        _attr("drx.cli.analyze", "analyze"),
        "Analyse a model's training trace: best paths, reward and speed heat maps, actions per section.",
    ),
    "train": _command(
        _attr("drx.cli.train", "train"), "Train a model: queue a job and run it here with a live dashboard."
    ),
    "worker": _command(
        _attr("drx.cli.worker", "worker"),
        "Run queued jobs, oldest first, each in its own `drx job run ID` process.",
    ),
    "jobs": _group(_attr("drx.cli.jobs", "app"), "Training jobs: list, show, stop, follow."),
    "job": _group(
        _attr("drx.cli.jobs", "job_app"), "Run one job (what `drx worker` launches; any executor can)."
    ),
    "evaluate": _command(
        _attr("drx.cli.evaluate", "evaluate"),
        "Race a model in its race type, store the result and print its summary.",
    ),
    "eval": _group(_attr("drx.cli.evaluate", "app"), "Stored evaluations (races): list them, show one."),
    "race": _command(
        _attr("drx.cli.race", "race"),
        "Race two to four of your models against each other on one track, and store the race.",
    ),
    "leaderboard": _command(
        _attr("drx.cli.leaderboard", "leaderboard"),
        "Rank the models evaluated on a track in a race type: one row per model, its best result.",
    ),
    "watch": _command(
        _attr("drx.cli.watch", "watch"),
        "Watch a job train or race in the browser: the car from above and through its camera, live, "
        "the reward graph growing per iteration, the job's phase and figures.",
    ),
    "sim": _group(
        _attr("drx.cli.sim", "app"),
        "Look inside the simulator: what the car's camera sees; how its car compares with DeepRacer's.",
    ),
    "sweep": _group(
        _attr("drx.cli.sweep", "app"),
        "Hyperparameter sweeps: many trials of one model, searched and pruned by Optuna.",
    ),
}


class DrxRootGroup(DrxGroup):
    """``drx``: the commands of :data:`COMMANDS`, each loaded when it is first needed."""

    lazy_commands = COMMANDS


app = typer.Typer(
    name="drx",
    cls=DrxRootGroup,
    help="drx: a local, open-source replacement for the AWS DeepRacer console.",
    no_args_is_help=True,
    rich_markup_mode="markdown",
    pretty_exceptions_show_locals=False,
)


@app.callback()
def _root() -> None:
    # Typer needs a callback (or a command) to make a group; the commands come from COMMANDS.
    pass


def run() -> None:
    """Console-script entry point: run the app; a :class:`DrxError` exits 2 with one sentence.

    The garbage collector waits until the command's modules are imported (:func:`collect_garbage`).
    """
    gc.disable()
    try:
        app()
    except DrxError as exc:  # raised outside a command (the group catches those inside)
        error(cli_sentence(exc))
        sys.exit(exc.exit_code)
    finally:
        collect_garbage()


if __name__ == "__main__":
    run()
