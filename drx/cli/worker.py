"""``drx worker``: run queued jobs, each in its own process."""

from __future__ import annotations

from typing import Annotated

import typer

from drx.cli.output import console
from drx.errors import DrxError
from drx.queue.worker import Worker, available_cores
from drx.storage import get_store


def worker(
    concurrency: Annotated[int, typer.Option("--concurrency", "-c", help="Jobs to run at once.")] = 1,
    exit_when_idle: Annotated[
        bool, typer.Option("--exit-when-idle", help="Return once no job is queued or running.")
    ] = False,
) -> None:
    """Run queued jobs, oldest first, each in its own `drx job run ID` process.

    Torch gets cores / concurrency threads per job, so jobs never oversubscribe the
    machine. A job whose worker dies goes back to the queue when its lease runs
    out and resumes from its last checkpoint. Ctrl-C hands running jobs back to
    the queue.

    Examples:

        drx worker

        drx worker --concurrency 2 --exit-when-idle
    """
    if concurrency < 1:
        raise DrxError(f"--concurrency {concurrency} is out of range; use 1 or more.")
    if concurrency > available_cores():
        console.print(
            f"[yellow]Note:[/] {concurrency} jobs on {available_cores()} cores: each gets 1 torch thread "
            "and they share the cores."
        )
    get_store().check()  # an unreachable bucket stops the worker here, not each job
    Worker(concurrency=concurrency, exit_when_idle=exit_when_idle, on_event=lambda m: console.print(m)).run()
