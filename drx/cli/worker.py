"""``drx worker``: run queued jobs, each in its own process."""

from __future__ import annotations

from typing import Annotated

import typer

from drx.cli.output import console
from drx.errors import DrxError
from drx.queue.worker import Worker, available_cores
from drx.settings.device import AUTO, DEVICE_HELP, check_device
from drx.storage import get_store


def worker(
    concurrency: Annotated[int, typer.Option("--concurrency", "-c", help="Jobs to run at once.")] = 1,
    exit_when_idle: Annotated[
        bool, typer.Option("--exit-when-idle", help="Return once no job is queued or running.")
    ] = False,
    device: Annotated[
        str | None,
        typer.Option(
            help=f"Train the jobs on {DEVICE_HELP}; a job's own --device beats it, it beats the "
            "model's [default: the job's or model's, else auto]."
        ),
    ] = None,
) -> None:
    """Run queued jobs, oldest first, each in its own `drx job run ID` process.

    Torch gets cores / concurrency threads per job, so jobs never oversubscribe the
    machine. A job whose worker dies goes back to the queue when its lease runs
    out and resumes from its last checkpoint. Ctrl-C hands running jobs back to
    the queue.

    Examples:

        drx worker

        drx worker --concurrency 2 --exit-when-idle

        drx worker --device cuda:1
    """
    if concurrency < 1:
        raise DrxError(f"--concurrency {concurrency} is out of range; use 1 or more.")
    if concurrency > available_cores():
        console.print(
            f"[yellow]Note:[/] {concurrency} jobs on {available_cores()} cores: each gets 1 torch thread "
            "and they share the cores."
        )
    if device is not None:  # a GPU this machine lacks stops the worker here, not each job
        device = check_device(device) or AUTO
        if device != AUTO:
            from drx.train.device import resolve_device

            resolve_device(device)
    get_store().check()  # an unreachable bucket stops the worker here, not each job
    Worker(
        concurrency=concurrency,
        exit_when_idle=exit_when_idle,
        on_event=lambda m: console.print(m),
        device=device,
    ).run()
