"""The Typer building blocks every command group uses: the error boundary and app factory."""

from __future__ import annotations

from typing import Any

import typer
from sqlalchemy.exc import DBAPIError
from typer.core import TyperGroup

from drx.cli.output import error
from drx.errors import DrxError
from drx.registry.engine import storage_error


class DrxGroup(TyperGroup):
    """The root command group: a :class:`DrxError` anywhere below ends the command with
    ``Error: <sentence>`` on stderr and exit code 2, without a traceback."""

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except DrxError as exc:
            error(str(exc))
            raise typer.Exit(code=exc.exit_code) from None
        except (OSError, DBAPIError) as exc:  # a full disk or a read-only home is the user's to fix
            sentence = storage_error(exc)
            if sentence is None:
                raise
            error(str(sentence))
            raise typer.Exit(code=sentence.exit_code) from None


def group(help_text: str) -> typer.Typer:
    """A Typer app for one command group (``drx garage ...``)."""
    return typer.Typer(help=help_text, no_args_is_help=True, rich_markup_mode="markdown")
