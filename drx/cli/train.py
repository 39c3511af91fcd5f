"""``drx train MODEL``: queue a training job and (unless ``--detach``) run it here with a live dashboard."""

from __future__ import annotations

import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.live import Live
from sqlalchemy import select

from drx.cli.dashboard import DashboardData, LiveSink, render
from drx.cli.model_options import stop_options
from drx.cli.output import console, emit, json_mode, json_option
from drx.errors import not_a_file
from drx.queue import lifecycle
from drx.registry import Model, session_scope
from drx.services import rewards
from drx.settings.car import simulator_label
from drx.settings.device import DEVICE_HELP, check_device, job_device
from drx.settings.rollout import check_rollout_workers
from drx.settings.seed import check_seed
from drx.settings.stop import StopConditions

if TYPE_CHECKING:  # the runner (torch, SB3) loads only when a training runs here
    from drx.queue.dispatch import JobOutcome

Checkpoint = Annotated[
    Path | None, typer.Option(help="Start from this checkpoint .zip (a clone starts from its parent's best).")
]
Seed = Annotated[int | None, typer.Option(help="Random seed.")]
RolloutWorkersOpt = Annotated[
    int | None,
    typer.Option(help="Processes sampling training episodes for this job, 1-64 [model's setting]."),
]
DeviceOpt = Annotated[
    str | None, typer.Option(help=f"Train this job on {DEVICE_HELP} [model's setting, else auto].")
]
Detach = Annotated[bool, typer.Option("--detach", "-d", help="Only queue the job; `drx worker` runs it.")]
TrustReward = Annotated[
    bool,
    typer.Option(
        "--trust-reward",
        help="Run a reward function that came in an imported package (read it first: `drx reward show`).",
    ),
]


@json_option
@stop_options
def train(
    model: Annotated[str, typer.Argument(help="The model to train (see `drx model list`).")],
    checkpoint: Checkpoint = None,
    seed: Seed = None,
    rollout_workers: RolloutWorkersOpt = None,
    device: DeviceOpt = None,
    detach: Detach = False,
    trust_reward: TrustReward = False,
    *,
    stop: dict[str, Any],
) -> None:
    """Train a model: queue a job and run it here with a live dashboard.

    The stop options override the model's stop conditions for this job only.
    Ctrl-C stops after the current step and keeps a checkpoint (twice: stop at
    once, keeping the last checkpoint).

    Examples:

        drx train my-model --max-minutes 10

        drx train my-model --detach && drx worker

        drx train my-model --device cuda
    """
    StopConditions().overridden(stop)  # validates the overrides (DeepRacer's ranges)
    check_seed(seed)
    options: dict[str, Any] = {"stop": {k: v for k, v in stop.items() if v is not None}}
    if checkpoint is not None:
        path = checkpoint.expanduser().resolve()
        if not path.is_file():  # refused now, not in the worker after the job is queued
            raise not_a_file(checkpoint, "Checkpoint file", "give a checkpoint .zip that drx train wrote")
        options["checkpoint"] = str(path)
    if seed is not None:
        options["seed"] = seed
    if rollout_workers is not None:
        options["rollout_workers"] = check_rollout_workers(rollout_workers)
    if device is not None:
        options["device"] = check_device(device) or "auto"  # auto too: it overrides the model's
    with session_scope() as session:
        row = session.scalar(select(Model).where(Model.name == model))
        stored_device = row.device if row is not None else None
        _check_device_here(job_device(device, stored_device))  # before anything is stored or queued
        if row is not None and not trust_reward:
            rewards.check_trusted(session, row.reward_sha256, model)
    if trust_reward:
        rewards.trust_reward_of(model)
    job = lifecycle.enqueue_training(model, options)
    if detach:
        queued = f"Queued job [bold]{job.id}[/] for model {model}; run it with `drx worker`."
        emit({"job": job.id, "model": model, "status": job.status}, lambda: console.print(queued))
        return
    from drx.queue.dispatch import JobTakenError

    try:
        outcome, interrupted = run_foreground(job.id, model)
    except JobTakenError:  # a running `drx worker` claimed it first: follow it instead
        console.print(f"A worker took job {job.id}; following it (Ctrl-C leaves it running).")
        from drx.cli.jobs import logs

        logs(job.id, follow=True)
        return
    _report(outcome, job.id)
    if outcome.status == "failed":
        raise typer.Exit(code=1)
    if interrupted:
        raise typer.Exit(code=INTERRUPTED_EXIT)


def _check_device_here(setting: str | None) -> None:
    """Refuse a GPU this machine cannot use (torch is imported only when it might have one)."""
    if setting is None or setting == "cpu":
        return
    from drx.train.device import resolve_device

    resolve_device(setting)


INTERRUPTED_EXIT = 130  # 128 + SIGINT, what a shell expects of a program ended by Ctrl-C


def run_foreground(job_id: int, model_name: str, plain: bool | None = None) -> tuple[JobOutcome, bool]:
    """Run a queued job in this process; Ctrl-C stops it cleanly, keeping the last checkpoint.

    Progress is the live dashboard on a terminal, else plain lines (one per iteration and a
    heartbeat, :mod:`drx.cli.progress`) on stdout, or on stderr under ``--json``.

    :param plain: force plain lines (True) or the dashboard (False); ``None``: plain unless
        stdout is a terminal and ``--json`` is off.
    :return: the outcome, and whether Ctrl-C was pressed.
    """
    import time

    from drx.cli.progress import PlainProgress
    from drx.queue.dispatch import run_job
    from drx.queue.train_job import build_spec
    from drx.train.device import describe_device, device_label

    started = time.monotonic()
    job = lifecycle.get_job(job_id)
    with session_scope() as session:
        row = session.get_one(Model, job.model_id)
    spec = build_spec(job, row)
    hp = row.hyperparameter_settings()
    stop_flag = [False]
    if plain is None:
        plain = json_mode() or not sys.stdout.isatty()
    data = DashboardData(
        title=f"drx train {model_name} · job {job_id}",
        stop=spec.stop,
        episodes_per_iteration=hp.episodes_per_iteration,
        clock_origin=started,
        model=model_name,
        device=device_label(spec.device or "cpu"),
        car=simulator_label(row.car_settings()),
    )

    def on_sigint(signum: int, frame: Any) -> None:
        if stop_flag[0]:
            raise KeyboardInterrupt
        stop_flag[0] = True
        data.note = "Stopping: ending the update, keeping a checkpoint... (Ctrl-C again: stop now)"
        if plain:
            sys.stderr.write(data.note + "\n")

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        if plain:
            stream = sys.stderr if json_mode() else sys.stdout
            limit = f"{spec.stop.max_minutes:g} min" if spec.stop.max_minutes is not None else "no time limit"
            stream.write(f"Training {model_name} (job {job_id}, {limit}); a line per iteration.\n")
            described = f"{describe_device(spec.device or 'cpu')}; car: {simulator_label(row.car_settings())}"
            with PlainProgress(
                stream, spec.stop, stop_flag=stop_flag, model=model_name, device=described
            ) as progress:
                return run_job(job_id, extra_sink=progress, started=started), stop_flag[0]
        with Live(
            get_renderable=lambda: render(data), console=console, refresh_per_second=4, transient=False
        ):
            try:
                return run_job(job_id, extra_sink=LiveSink(data, stop_flag), started=started), stop_flag[0]
            finally:
                data.elapsed, data.finished = data.elapsed_now(), True
    except KeyboardInterrupt:  # the second Ctrl-C, outside the trainer's loop
        return jobs_outcome(job_id), True
    finally:
        signal.signal(signal.SIGINT, previous)


def jobs_outcome(job_id: int) -> JobOutcome:
    """The outcome of a job that ended by an interruption outside the trainer (read back from the queue)."""
    from drx.queue.dispatch import JobOutcome

    job = lifecycle.get_job(job_id)
    return JobOutcome(status=job.status, stop_reason=job.stop_reason or "interrupted", error=job.error)


def _report(outcome: JobOutcome, job_id: int) -> None:
    result = outcome.result
    data = {
        "job": job_id,
        "status": outcome.status,
        "stop_reason": outcome.stop_reason,
        "error": outcome.error,
        "iterations": result.iterations if result else 0,
        "steps": result.steps if result else 0,
        "episodes": result.episodes if result else 0,
        "best": result.best if result else None,
    }

    def show() -> None:
        # In a log (no terminal) the closing line stays whole, one line a reader can grep.
        whole = not console.is_terminal
        if outcome.status == "failed":
            console.print(f"[red]Job {job_id} failed:[/] {outcome.error}", soft_wrap=whole)
            return
        best = result.best if result else None
        best_text = "no checkpoint yet"
        if best:
            lap = best.get("eval_lap_time")
            best_text = (
                f"best: iteration {best['iteration']}, evaluation progress {best['eval_progress']:.0f}%"
                + (f", lap {lap:.2f} s" if lap else "")
            )
        console.print(f"Job {job_id} {outcome.status} ({outcome.stop_reason}); {best_text}.", soft_wrap=whole)

    emit(data, show)
