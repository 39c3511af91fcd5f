"""``drx reward``: check reward functions before training."""

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.syntax import Syntax
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option
from drx.errors import DrxError
from drx.services import rewards as service

app = group("Reward functions: validate them as the console's Validate button does.")


@app.command("validate")
@json_option
def validate(
    file: Annotated[str, typer.Argument(help="A reward .py file, or a sample name from rewards/.")],
    track: Annotated[
        str | None, typer.Option(help="The track the sample states lie on [default: oval].")
    ] = None,
) -> None:
    """Call reward_function(params) on sample states (start line, mid-lap near each border, off
    track, lap complete) and report each value or error, with your file's line number.

    Fails (exit 2) on a missing function, an exception, or a value that is not a finite number
    within [-1e5, 1e5]; warns when a call takes over 1 ms.

    Example:

      drx reward validate rewards/follow_center_line.py --track kidney
    """
    report = service.validate_reward(file, track)

    def render() -> None:
        table = Table(title=f"{Path(report.path).name} on {report.track}")
        for col in ("case", "result", "ms"):
            table.add_column(col)
        for c in report.cases:
            result = f"{c.value:g}" if c.ok else f"[red]{escape(c.error or '')}[/]"
            ms = f"{c.seconds * 1e3:.3f}" + (" [yellow](slow)[/]" if c.warning else "")
            table.add_row(c.case, result, ms)
        console.print(table)
        slow = [c for c in report.cases if c.warning]
        if slow:
            worst = max(c.seconds for c in slow) * 1e3
            console.print(
                f"[yellow]Warning[/]: reward_function takes up to {worst:.1f} ms per call (over 1 ms) "
                f"in {len(slow)} of {len(report.cases)} states; it will slow training down."
            )
        if report.ok:
            console.print(f"[green]Valid[/]: reward_function passed {len(report.cases)} sample states.")

    emit(report.to_dict(), render)
    if not report.ok:
        sentence = service.failure_sentence(report)
        raise DrxError(sentence if sentence.endswith("?") else sentence + ".")


@app.command("list")
@json_option
def list_rewards() -> None:
    """List the reward functions stored in the registry (by content hash) and the models using them.

    Example:

      drx reward list
    """
    stored = service.list_stored_rewards()

    def render() -> None:
        if not stored:
            console.print("No reward functions stored yet; `drx model create` stores the one it is given.")
            return
        table = Table(title="Stored reward functions")
        for col in ("sha256", "file", "models"):
            table.add_column(col)
        for r in stored:
            table.add_row(r.sha256[:12], r.filename, ", ".join(r.models) or "-")
        console.print(table)

    emit([r.to_dict(with_code=False) for r in stored], render)


@app.command("show")
@json_option
def show(
    ref: Annotated[str, typer.Argument(help="A model name, or 6+ hex digits of the reward's sha256.")],
) -> None:
    """Print the exact reward code a model was made with (or stored under a hash).

    Example:

      drx reward show my-first-model
    """
    r = service.get_stored_reward(ref)

    def render() -> None:
        console.print(f"[bold]{r.filename}[/] sha256 {r.sha256}; models: {', '.join(r.models) or '-'}")
        console.print(Syntax(r.code, "python", line_numbers=True, word_wrap=True))

    emit(r.to_dict(), render)
