"""``drx jobs list|show|stop|logs`` and ``drx job run ID`` (the entrypoint every executor launches)."""

from __future__ import annotations

import json
import time
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from drx.cli.app import group
from drx.cli.output import console, emit, json_option
from drx.cli.tables import Column, Wide, fitted_table, print_table, short_paths

if TYPE_CHECKING:  # SQLAlchemy, the queue and the dashboard load in the commands that use them
    from drx.cli.dashboard import DashboardData
    from drx.registry import Job
    from drx.registry.quick import Record
    from drx.train.records import TrackFigures

app = group("Training jobs: list, show, stop, follow.")
job_app = group("Run one job (what `drx worker` launches; any executor can).")

JobId = Annotated[int, typer.Argument(help="The job's id (see `drx jobs list`).")]


def job_dict(job: Job | Record, model_name: str) -> dict[str, Any]:
    """A job as JSON."""
    return {
        "id": job.id,
        "model": model_name,
        "kind": job.kind,
        "status": job.status,
        "options": job.options,
        "created_at": job.created_at,
        "started_at": job.started_at,
        "finished_at": job.finished_at,
        "heartbeat_at": job.heartbeat_at,
        "worker": job.worker_id,
        "attempts": job.attempts,
        "max_attempts": job.max_attempts,
        "stop_requested": job.stop_requested,
        "stop_reason": job.stop_reason,
        "error": job.error,
        "log_path": job.log_path,
        "device": job.device,
        "attempt_log": list(job.attempt_log or []),
    }


@app.command("list")
@json_option
def list_jobs(
    status: Annotated[str | None, typer.Option(help="Only jobs with this status.")] = None,
    model: Annotated[str | None, typer.Option(help="Only this model's jobs.")] = None,
    limit: Annotated[int, typer.Option(help="How many, newest first.")] = 50,
    wide: Wide = False,
) -> None:
    """List jobs, newest first.

    Example: drx jobs list --status running
    """
    from drx.queue.listing import list_jobs as rows_of

    rows = rows_of(status=status, model_name=model, limit=limit)

    def show() -> None:
        if not rows:
            console.print("No jobs yet; start one with `drx train MODEL`.")
            return
        columns = [
            Column("id", 0, "right"),
            Column("model", 0, kind="name"),
            Column("status", 0),
            Column("reason / error", 0, kind="prose"),
            Column("created", 1),
            Column("finished", 2),
            Column("attempts", 3, "right"),
            Column("kind", 4),
        ]
        table_rows = [
            [str(job.id), name, job.status, _reason(job), f"{job.created_at:%m-%d %H:%M}",
             f"{job.finished_at:%H:%M:%S}" if job.finished_at else "-", f"{job.attempts}/{job.max_attempts}",
             job.kind]
            for job, name in rows
        ]  # fmt: skip
        table = fitted_table(columns, table_rows, console=console, wide=wide)
        print_table(table, console, wide)
        if any(job.error for job, _ in rows):
            console.print("The whole error, with the reward's params: `drx jobs show ID`.")

    emit([job_dict(j, n) for j, n in rows], show)


def _reason(job: Job | Record) -> str:
    """A job's stop reason, or the first line of its error with paths cut to their file names."""
    if job.stop_reason:
        return job.stop_reason
    first = next(iter((job.error or "").splitlines()), "")
    return short_paths(first) or "-"


@app.command("show")
@json_option
def show_job(job_id: JobId) -> None:
    """Show a job: status, attempts, stop reason or error, progress.

    Example: drx jobs show 3
    """
    from sqlalchemy import func, select

    from drx.queue import lifecycle as queue
    from drx.registry import Checkpoint, Episode, IterationMetric, Model, session_scope
    from drx.train.anneal import latest_rollback
    from drx.train.health import collapse_warning

    job = queue.get_job(job_id)
    with session_scope() as session:
        name = session.get_one(Model, job.model_id).name
        metrics = list(
            session.execute(
                select(IterationMetric.iteration, IterationMetric.eval_mean_progress, IterationMetric.health)
                .where(IterationMetric.job_id == job_id)
                .order_by(IterationMetric.iteration)
            )
        )
        evaluations = [(int(it), progress) for it, progress, _ in metrics]
        iterations = len(evaluations)
        episodes = session.scalar(
            select(func.count(Episode.id)).where(Episode.job_id == job_id, Episode.phase == "training")
        )
        best = session.scalar(
            select(Checkpoint)
            .where(Checkpoint.model_id == job.model_id, Checkpoint.is_best.is_(True))
            .limit(1)
        )
    data = job_dict(job, name) | {"iterations": iterations, "training_episodes": episodes}
    data["warning"] = collapse_warning(evaluations, name)
    data["rollback"] = latest_rollback([(int(it), health) for it, _, health in metrics])
    if best is not None:
        data["best_checkpoint"] = {
            "iteration": best.iteration,
            "path": best.path,
            "eval_progress": best.eval_progress,
            "eval_lap_time": best.eval_lap_time,
        }

    def show() -> None:
        table = Table.grid(padding=(0, 2))
        table.add_column(style="dim")
        table.add_column()
        for key in (
            "id",
            "model",
            "status",
            "worker",
            "attempts",
            "created_at",
            "started_at",
            "finished_at",
            "stop_reason",
            "iterations",
            "training_episodes",
            "device",
            "log_path",
        ):
            value = data.get(key)
            if isinstance(value, datetime):
                value = f"{value:%Y-%m-%d %H:%M:%S}"
            table.add_row(key.replace("_", " "), "-" if value is None else str(value))
        if job.options:
            table.add_row("options", json.dumps(job.options))
        if best is not None:
            lap = f", lap {best.eval_lap_time:.2f} s" if best.eval_lap_time else ""
            table.add_row(
                "best", f"iteration {best.iteration}: {best.eval_progress or 0:.0f}%{lap} ({best.path})"
            )
        console.print(table)
        if data["rollback"]:  # the anneal schedule went back to the best checkpoint
            console.print(data["rollback"], markup=False)
        if data["warning"]:
            console.print(f"warning: {data['warning']}", style="yellow", markup=False)
        for entry in job.attempt_log or []:
            console.print(
                f"attempt {entry.get('attempt')}: {entry.get('ended')} at {entry.get('at')}"
                + (f" on {entry['worker']}" if entry.get("worker") else "")
                + (f": {str(entry['reason']).splitlines()[0]}" if entry.get("reason") else ""),
                markup=False,
            )
        if job.error:
            console.print(f"[red]error:[/] {job.error}")

    emit(data, show)


@app.command("stop")
@json_option
def stop_job(job_id: JobId) -> None:
    """Stop a job: a queued one is cancelled, a running one stops at its next step.

    A training keeps its last checkpoint; an evaluation stores nothing.

    Example: drx jobs stop 3
    """
    from drx.queue import lifecycle as queue
    from drx.queue.kinds import trains_model

    status = queue.request_stop(job_id)
    keeps = ", keeping a checkpoint" if trains_model(queue.get_job(job_id).kind) else ", storing nothing"
    message = {
        "cancelled": f"Job {job_id} cancelled.",
        "running": f"Job {job_id} will stop at its next step{keeps}.",
    }.get(status, f"Job {job_id} is already {status}.")
    emit({"id": job_id, "status": status}, lambda: console.print(message))


def _track_figures(rows: dict[str, tuple[int, float, float]]) -> dict[str, TrackFigures]:
    """An iteration's per-track figures from the registry (only when it drove several tracks)."""
    from drx.train.records import TrackFigures

    if len(rows) < 2:
        return {}
    return {name: TrackFigures(count, reward, progress) for name, (count, reward, progress) in rows.items()}


def _dashboard_data(job_id: int) -> tuple[DashboardData, Job]:
    """The dashboard's data for a job, read from the registry."""
    from sqlalchemy import func, select

    from drx.cli.dashboard import DashboardData
    from drx.queue import lifecycle as queue
    from drx.registry import Episode, Model, session_scope
    from drx.registry.metrics import iterations_so_far, training_by_track
    from drx.sim.episode_status import EpisodeStatus
    from drx.train.anneal import FIGURES as ANNEAL_FIGURES
    from drx.train.records import IterationSummary

    job = queue.get_job(job_id)
    with session_scope() as session:
        model = session.get_one(Model, job.model_id)
        stop = model.stop_settings((job.options or {}).get("stop"))
        hp = model.hyperparameter_settings()
        rows, current = iterations_so_far(session, job.model_id)
        by_track = training_by_track(session, job.model_id)
        last_it = rows[-1].iteration if rows else -1
        laps = session.scalar(
            select(func.min(Episode.lap_time)).where(
                Episode.model_id == job.model_id,
                Episode.phase == "evaluation",
                Episode.status == EpisodeStatus.LAP_COMPLETE,
            )
        )
        name = model.name
    summaries = [
        IterationSummary(
            iteration=r.iteration,
            steps=r.steps,
            episodes=r.episodes,
            elapsed_seconds=r.elapsed_seconds or 0.0,
            steps_per_second=r.steps_per_second or 0.0,
            train_mean_reward=r.train_mean_reward,
            train_mean_progress=r.train_mean_progress,
            eval_mean_reward=r.eval_mean_reward,
            eval_mean_progress=r.eval_mean_progress,
            policy_loss=r.policy_loss,
            value_loss=r.value_loss,
            entropy=r.entropy,
            kl=r.kl,
            learning_rate=r.learning_rate,
            extra={k: v for k, v in (r.health or {}).items() if k in ANNEAL_FIGURES},
            by_track=_track_figures(by_track.get(r.iteration, {})),
        )
        for r in rows
    ]
    last = summaries[-1] if summaries else None
    data = DashboardData(
        title=f"drx jobs logs {job_id} · {name}",
        stop=stop,
        model=name,
        status=job.status + (f" ({job.stop_reason})" if job.stop_reason else ""),
        iterations=summaries,
        steps=last.steps if last else 0,
        episodes=(last.episodes if last else 0) + (current or 0),
        iteration=last_it + 1,
        iteration_episodes=current or 0,
        episodes_per_iteration=hp.episodes_per_iteration,
        elapsed=last.elapsed_seconds if last else 0.0,
        steps_per_second=last.steps_per_second if last else None,
        best_lap=laps,
        best_progress=max((s.eval_mean_progress or 0.0 for s in summaries), default=None),
        note=(job.error or "").splitlines()[0] if job.error else "",
        finished=job.status not in ("queued", "running"),
        device=job.device,
    )
    if job.status == "running" and job.started_at is not None:  # the clock: wall time since the job started
        started = job.started_at if job.started_at.tzinfo else job.started_at.replace(tzinfo=UTC)
        data.clock_origin = time.monotonic() - (datetime.now(UTC) - started).total_seconds()
    return data, job


@app.command("logs")
def logs(
    job_id: JobId,
    follow: Annotated[
        bool, typer.Option("--follow", "-f", help="Keep the dashboard live until the job ends.")
    ] = False,
) -> None:
    """Show a job's dashboard (iterations, reward and progress chart); `-f` follows it live.

    Example: drx jobs logs 3 -f
    """
    from rich.live import Live

    from drx.cli.dashboard import render

    data, job = _dashboard_data(job_id)
    if not follow:
        console.print(render(data))
        if job.log_path:
            console.print(f"[dim]process log: {job.log_path}[/]")
        return
    with Live(render(data), console=console, refresh_per_second=2) as live:
        try:
            while True:
                data, job = _dashboard_data(job_id)
                live.update(render(data))
                if job.status not in ("queued", "running"):
                    break
                time.sleep(1.0)
        except KeyboardInterrupt:
            pass


@job_app.command("run")
def run(
    job_id: JobId,
    claimed_by: Annotated[
        str | None, typer.Option(help="The worker that claimed the job (set by `drx worker`).", hidden=True)
    ] = None,
    parent_pid: Annotated[int | None, typer.Option(help="The launching worker's pid.", hidden=True)] = None,
) -> None:
    """Run one job in this process (claiming it unless a worker already did), whatever its kind.

    Example: drx job run 3
    """
    import sys

    from drx.cli.progress import PlainProgress
    from drx.queue.dispatch import run_job  # the job's runner (torch, SB3) loads only in this process
    from drx.settings.stop import StopConditions
    from drx.sweep.trial import SweepTrial

    def progress(stop: StopConditions, device: str) -> PlainProgress:  # the job's log: a line per iteration
        return PlainProgress(sys.stdout, stop, device=device)

    outcome = run_job(
        job_id, worker_id=claimed_by, parent_pid=parent_pid, progress=progress, trial_for=SweepTrial.of
    )
    detail = outcome.stop_reason or outcome.error or ""
    console.print(f"job {job_id} {outcome.status}" + (f": {detail}" if detail else ""))
    if outcome.status == "failed":
        raise typer.Exit(code=1)
