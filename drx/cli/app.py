"""The Typer building blocks every command group uses: the error boundary and app factory."""

from __future__ import annotations

import inspect
from typing import Any

import typer
from sqlalchemy.exc import DBAPIError
from typer.core import TyperGroup

from drx.cli.flags import cli_sentence
from drx.cli.output import error
from drx.errors import DrxError
from drx.registry.engine import storage_error

# `drx --help` lists the commands in the order a new user needs them; commands not named here
# (a group added later) follow, in the order they were registered.
WORKFLOW_ORDER = (
    "garage", "track", "reward", "model", "train", "evaluate", "leaderboard",
    "watch", "eval", "plot", "analyze", "sweep", "jobs", "worker", "job", "sim", "info",
)  # fmt: skip


class DrxGroup(TyperGroup):
    """The root command group: a :class:`DrxError` anywhere below ends the command with
    ``Error: <sentence>`` on stderr and exit code 2, without a traceback (a setting named by
    its flag: :func:`drx.cli.flags.cli_sentence`)."""

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """A subcommand, its help set for the terminal's width (:func:`fit_help`)."""
        command = super().get_command(ctx, cmd_name)
        if command is not None:
            fit_help(command)
        return command

    def format_help(self, ctx: Any, formatter: Any) -> None:
        """``drx --help``, plain on a narrow terminal (:func:`fit_help`)."""
        fit_help(self, recurse=False)
        super().format_help(ctx, formatter)

    def list_commands(self, ctx: Any) -> list[str]:
        """The commands in workflow order (:data:`WORKFLOW_ORDER`), then any others."""
        names = super().list_commands(ctx)
        rank = {name: i for i, name in enumerate(WORKFLOW_ORDER)}
        return sorted(names, key=lambda n: (rank.get(n, len(rank)), names.index(n)))

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except DrxError as exc:
            error(cli_sentence(exc))
            raise typer.Exit(code=exc.exit_code) from None
        except (OSError, DBAPIError) as exc:  # a full disk or a read-only home is the user's to fix
            sentence = storage_error(exc)
            if sentence is None:
                raise
            error(str(sentence))
            raise typer.Exit(code=sentence.exit_code) from None


RICH_HELP_MIN_WIDTH = 100  # [columns] Rich's boxed help needs this much not to cut option names


def fit_help(command: Any, recurse: bool = True) -> None:
    """Choose the help layout for the terminal: Rich's boxed panels when it is at least
    :data:`RICH_HELP_MIN_WIDTH` wide, else Click's plain layout, which wraps the descriptions
    and never cuts an option's name (Rich's panels do at 80 columns, and without a terminal)."""
    from drx.cli.output import console

    mode = "markdown" if console.width >= RICH_HELP_MIN_WIDTH else None
    stack = [command]
    while stack:
        cmd = stack.pop()
        if hasattr(cmd, "rich_markup_mode"):
            cmd.rich_markup_mode = mode
        if getattr(cmd, "short_help", "") is None and getattr(cmd, "help", None):
            # the whole first paragraph, wrapped (Click would cut it at about 45 characters with "...")
            cmd.short_help = " ".join(inspect.cleandoc(cmd.help).split("\n\n")[0].split())
        if recurse:
            stack.extend(getattr(cmd, "commands", {}).values())


def group(help_text: str) -> typer.Typer:
    """A Typer app for one command group (``drx garage ...``)."""
    return typer.Typer(help=help_text, no_args_is_help=True, rich_markup_mode="markdown")
