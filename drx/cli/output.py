"""Output helpers shared by every command: Rich for people, ``--json`` for programs.

Like sqlite-utils, one decorator adds the output option to a command::

    @app.command("list")
    @json_option
    def list_cars() -> None:
        emit([...], render=lambda: console.print(table))

With ``--json`` the command prints exactly one JSON document on stdout and
nothing else; without it, ``render`` draws tables. Errors go to stderr.
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import json
import sys
import typing
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from datetime import datetime
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

F = TypeVar("F", bound=Callable[..., Any])

console = Console(highlight=False)
_json_mode: ContextVar[bool] = ContextVar("drx_json_mode", default=False)

JSON_HELP = "Print one JSON document instead of tables."


def json_option(func: F) -> F:
    """Add a ``--json`` flag to a Typer command; :func:`emit` then prints JSON."""
    # Resolve the function's annotations in its own module: with ``from __future__ import
    # annotations`` they are strings, and Typer would drop their Option help once wrapped.
    try:
        hints = typing.get_type_hints(func, include_extras=True)
    except NameError:  # a name only imported under TYPE_CHECKING: leave the annotations to Typer
        hints = dict(func.__annotations__)
    signature = inspect.signature(func)
    resolved = [p.replace(annotation=hints.get(p.name, p.annotation)) for p in signature.parameters.values()]
    signature = signature.replace(parameters=resolved)
    param = inspect.Parameter(
        "json_output",
        inspect.Parameter.KEYWORD_ONLY,
        default=False,
        annotation=Annotated[bool, typer.Option("--json", help=JSON_HELP)],
    )

    @functools.wraps(func)
    def wrapper(*args: Any, json_output: bool = False, **kwargs: Any) -> Any:
        token = _json_mode.set(json_output)
        try:
            return func(*args, **kwargs)
        finally:
            _json_mode.reset(token)

    wrapper.__signature__ = signature.replace(parameters=[*signature.parameters.values(), param])  # type: ignore[attr-defined]
    wrapper.__annotations__ = {**hints, "json_output": param.annotation}
    return wrapper  # type: ignore[return-value]


def json_mode() -> bool:
    """Whether the running command was given ``--json``."""
    return _json_mode.get()


def _default(value: Any) -> Any:
    if isinstance(value, datetime):
        return value.isoformat()
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def print_json(data: Any) -> None:
    """Write ``data`` as one JSON document to stdout."""
    sys.stdout.write(json.dumps(data, indent=2, default=_default) + "\n")
    sys.stdout.flush()


def emit(data: Any, render: Callable[[], None]) -> None:
    """Print ``data`` as JSON under ``--json``, else call ``render`` to draw it for people."""
    if json_mode():
        print_json(data)
    else:
        render()


def note(message: str) -> None:
    """A remark for people (suppressed under ``--json``), e.g. what an import fixed."""
    if not json_mode():
        console.print(message)


def warn(message: str) -> None:
    """Write ``Warning: message`` to stderr (kept out of ``--json`` output on stdout)."""
    sys.stderr.write(f"Warning: {message}\n")
    sys.stderr.flush()


def error(message: str) -> None:
    """Write ``Error: message`` to stderr (one line, no Rich wrapping)."""
    sys.stderr.write(f"Error: {message}\n")
    sys.stderr.flush()


def fmt(value: float | None, digits: int = 3) -> str:
    """A number for tables (``-`` for ``None``)."""
    return "-" if value is None else f"{value:.{digits}g}" if abs(value) < 1e-3 and value else f"{value:g}"


@contextlib.contextmanager
def steps(title: str) -> Iterator[Callable[[str], None]]:
    """A long command's steps: a spinner line in a terminal, else ``title: step`` lines on stderr
    (never on stdout, which ``--json`` keeps for the result). Yields ``say(step)``."""
    if console.is_terminal and not json_mode():
        with console.status(f"{title}...") as status:
            yield lambda text: status.update(f"{title}: {text}...")
        return

    def say(text: str) -> None:
        sys.stderr.write(f"{title}: {text}\n")
        sys.stderr.flush()

    yield say
