"""The Typer building blocks every command group uses: the error boundary, lazily loaded
commands and the app factory."""

from __future__ import annotations

import gc
import inspect
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import typer
from typer.core import TyperCommand, TyperGroup

from drx.cli.flags import cli_sentence
from drx.cli.output import error
from drx.errors import DrxError

# `drx --help` lists the commands in the order a new user needs them; commands not named here
# (a group added later) follow, in the order they were registered.
WORKFLOW_ORDER = (
    "garage", "track", "reward", "model", "train", "evaluate", "leaderboard",
    "watch", "eval", "plot", "analyze", "sweep", "jobs", "worker", "job", "sim", "info",
)  # fmt: skip


@dataclass(frozen=True)
class LazyCommand:
    """A command whose module is imported only when the command is needed.

    :param load: returns the command's function, or the ``typer.Typer`` app of a group.
    :param help: the one line ``drx --help`` lists for it (the first paragraph of its own help;
        a test checks they match).
    :param is_group: ``load`` returns a Typer app rather than a function.
    """

    load: Callable[[], Any]
    help: str
    is_group: bool

    def command(self, name: str) -> Any:
        """The Click command, built as ``app.add_typer``/``app.command`` on the root would build it."""
        holder = typer.Typer(rich_markup_mode="markdown", pretty_exceptions_show_locals=False)
        target = self.load()
        if self.is_group:
            holder.add_typer(target, name=name)
        else:
            holder.command(name)(target)
        holder.callback()(lambda: None)  # a group even with one command, so the command keeps its name
        return typer.main.get_group(holder).commands[name]

    def placeholder(self, name: str) -> TyperCommand:
        """What a help listing needs of the command (name and help) without importing it."""
        return TyperCommand(name, help=self.help, short_help=self.help)


class DrxGroup(TyperGroup):
    """The root command group: a :class:`DrxError` anywhere below ends the command with
    ``Error: <sentence>`` on stderr and exit code 2, without a traceback (a setting named by
    its flag: :func:`drx.cli.flags.cli_sentence`).

    Subclasses list :attr:`lazy_commands`: they are imported when one runs or shows its own help;
    the group's help lists them from their :class:`LazyCommand` line, importing none.
    """

    lazy_commands: ClassVar[Mapping[str, LazyCommand]] = {}
    _listing = False  # True while this group formats its own help

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """A subcommand, its help set for the terminal's width (:func:`fit_help`)."""
        command = super().get_command(ctx, cmd_name)
        lazy = self.lazy_commands.get(cmd_name)
        if command is None and lazy is not None:
            if self._listing:
                return lazy.placeholder(cmd_name)
            command = lazy.command(cmd_name)
            self.add_command(command, cmd_name)
        if command is not None:
            fit_help(command)
        return command

    def resolve_command(self, ctx: Any, args: list[str]) -> Any:
        """The subcommand to run (importing its module); then the garbage collector starts again, if
        :func:`drx.cli.main.run` held it back while the modules loaded (:func:`collect_garbage`)."""
        try:
            return super().resolve_command(ctx, args)
        finally:
            collect_garbage()

    def format_help(self, ctx: Any, formatter: Any) -> None:
        """``drx --help``, plain on a narrow terminal (:func:`fit_help`)."""
        fit_help(self, recurse=False)
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False

    def list_commands(self, ctx: Any) -> list[str]:
        """The commands in workflow order (:data:`WORKFLOW_ORDER`), then any others."""
        names = list(dict.fromkeys([*super().list_commands(ctx), *self.lazy_commands]))
        rank = {name: i for i, name in enumerate(WORKFLOW_ORDER)}
        return sorted(names, key=lambda n: (rank.get(n, len(rank)), names.index(n)))

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except DrxError as exc:
            error(cli_sentence(exc))
            raise typer.Exit(code=exc.exit_code) from None
        except Exception as exc:  # a full disk or a read-only home is the user's to fix
            if not _is_storage_error(exc):
                raise
            from drx.registry.engine import storage_error

            sentence = storage_error(exc)
            if sentence is None:
                raise
            error(str(sentence))
            raise typer.Exit(code=sentence.exit_code) from None


def collect_garbage() -> None:
    """Start Python's garbage collector again after start-up (idempotent).

    :func:`drx.cli.main.run` stops it while the command's modules import: importing makes many
    objects and no garbage, and the collections it triggers cost about 15% of a quick command's
    start-up. The objects made so far are frozen (never scanned again): collections stay cheap in
    long commands, and the exit skips them (what must be closed at exit closes itself then, e.g.
    :func:`drx.registry.engine.get_engine`'s connections).
    """
    if not gc.isenabled():
        gc.freeze()
        gc.enable()


def _is_storage_error(exc: BaseException) -> bool:
    """An ``OSError``, or SQLAlchemy's ``DBAPIError`` (checked only when SQLAlchemy is loaded,
    which it is whenever a database call failed)."""
    if isinstance(exc, OSError):
        return True
    sqlalchemy_exc = sys.modules.get("sqlalchemy.exc")
    return sqlalchemy_exc is not None and isinstance(exc, sqlalchemy_exc.DBAPIError)


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


def _plain_values() -> None:
    """Let ``str``, ``bool`` and ``int`` parameters take a value of that very type as it is (a default,
    or a flag's ``bool``), without Pydantic.

    Typer (0.29) checks every parameter's value with a Pydantic ``TypeAdapter``, so every command
    paid about 0.1 s for importing Pydantic, even for ``--help`` or a ``--json`` flag. For a value
    that already has the parameter's type (and no custom parser) that check returns the value
    unchanged, which is what this does; any other value goes to Typer's own check. It wraps
    Typer's internal coercion hook; with a Typer that lacks it nothing changes (commands only
    start slower, which tests/cli/test_info_and_help.py reports).
    """
    try:
        from typer._coercion import RuntimeParam, build_runtime_param
        from typer.core import _TyperParameter
    except ImportError:  # pragma: no cover - another Typer
        return
    if getattr(_TyperParameter, "_drx_plain_values", False):
        return

    @dataclass(frozen=True)
    class _SameType(RuntimeParam):
        descriptor: Any

        def _coerce_value(self, value: Any, param: Any, ctx: Any) -> Any:
            if type(value) is self.annotation:
                return value
            return build_runtime_param(self.descriptor)._coerce_value(value, param=param, ctx=ctx)

    typers_own = _TyperParameter.get_runtime_param

    def get_runtime_param(self: Any) -> Any:
        descriptor = self.type_descriptor
        if (
            self._runtime_param is None
            and descriptor.annotation in (str, bool, int)
            and descriptor.parameter_info.parser is None
            and descriptor.file_annotation is None
        ):
            self._runtime_param = _SameType(descriptor.parameter_info, descriptor.annotation, descriptor)
        return typers_own(self)

    _TyperParameter.get_runtime_param = get_runtime_param  # type: ignore[method-assign]
    _TyperParameter._drx_plain_values = True  # type: ignore[attr-defined]


_plain_values()


def group(help_text: str) -> typer.Typer:
    """A Typer app for one command group (``drx garage ...``)."""
    return typer.Typer(help=help_text, no_args_is_help=True, rich_markup_mode="markdown")
