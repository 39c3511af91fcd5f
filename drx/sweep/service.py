"""Sweeps: an Optuna study whose trials are ordinary models with ordinary queued training jobs.

``create_sweep`` validates everything, creates the study (storage: the registry's database, see
:mod:`drx.sweep.optuna_storage`) and adds the trials; ``extend_sweep`` adds more later. A trial draws its
hyperparameters when it is added (``study.ask``), becomes the model ``SWEEP-N``, a clone of the
sweep's source model with those values (starting from the source's best checkpoint when it has
one, else from scratch), and a training job any ``drx worker`` on any host runs. The job reports
every iteration to the study and stops when Optuna's pruner says so (:mod:`drx.sweep.trial`).
Trials added together draw from what the study knew then, so a sweep extended in rounds learns
from the earlier rounds (Optuna's TPE sampler; its first 10 trials are random).
"""

from __future__ import annotations

import contextlib
from dataclasses import asdict, dataclass
from typing import Any

from sqlalchemy import select, update

from drx.errors import AlreadyExistsError, DrxError, NotFoundError, SettingError
from drx.queue import lifecycle
from drx.registry import Job, Model, session_scope
from drx.services.models import best_checkpoint, clone_model, get_model, remove_model
from drx.services.names import MODEL_NAME_RE, NAME_RULE, check_model_name
from drx.settings.seed import MAX_SEED, check_seed
from drx.settings.stop import MAX_MINUTES_RANGE
from drx.sweep.metric import METRICS, Direction, best_value, check_metric
from drx.sweep.optuna_storage import open_storage
from drx.sweep.param_specs import ParamSpec, apply_params, parse_params

ATTR = "drx"  # the study's user attribute holding its SweepSpec
MAX_TRIALS = 1000  # per create/extend call
PRUNERS = ("median", "none")
FINAL_JOB_STATUSES = ("succeeded", "stopped", "failed", "cancelled")


@dataclass
class SweepSpec:
    """How a sweep makes its trials (stored on the study, so any host can extend or run it).

    :param name: the sweep (= the Optuna study's name).
    :param source: the model every trial is cloned from.
    :param metric: ``progress``, ``reward`` or ``best-lap`` (:mod:`drx.sweep.metric`).
    :param params: the ``--param`` specifications.
    :param max_minutes: each trial's training-time limit (``None``: the source model's).
    :param pruner: ``median`` (Optuna's ``MedianPruner``) or ``none``.
    :param startup_trials: trials that finish before the pruner stops any.
    :param warmup_iterations: iterations of each trial the pruner never stops.
    :param seed: makes the trials' draws repeatable (``None``: random).
    """

    name: str
    source: str
    metric: str
    params: list[str]
    max_minutes: float | None = None
    pruner: str = "median"
    startup_trials: int = 2
    warmup_iterations: int = 1
    algorithm: str = "ppo"
    seed: int | None = None

    @property
    def direction(self) -> Direction:
        """``maximize`` or ``minimize``."""
        return METRICS[self.metric]

    def specs(self) -> list[ParamSpec]:
        """The parsed ``--param`` specifications."""
        return parse_params(self.params, self.algorithm)

    def make_sampler(self, trials_so_far: int) -> Any:
        """Optuna's TPE sampler; with a seed, offset by the trials so far so each round draws anew."""
        import optuna

        seed = None if self.seed is None else (self.seed + trials_so_far) % (MAX_SEED + 1)
        return optuna.samplers.TPESampler(seed=seed)

    def make_pruner(self) -> Any:
        """The Optuna pruner (pruners are not stored; every process builds the same one)."""
        import optuna

        if self.pruner == "none":
            return optuna.pruners.NopPruner()
        return optuna.pruners.MedianPruner(
            n_startup_trials=self.startup_trials, n_warmup_steps=self.warmup_iterations
        )


def load_sweep(name: str, storage: Any | None = None) -> tuple[SweepSpec, Any]:
    """A sweep's spec and its Optuna study (with the sweep's pruner).

    :raises NotFoundError: no such sweep.
    """
    import optuna

    storage = storage or open_storage()
    if name not in optuna.get_all_study_names(storage):
        raise NotFoundError(f"No sweep {name!r}; create it with `drx sweep create {name} --from MODEL ...`.")
    study = optuna.load_study(study_name=name, storage=storage)
    spec = SweepSpec(**study.user_attrs[ATTR])
    study.pruner = spec.make_pruner()
    return spec, study


def create_sweep(
    name: str,
    source: str,
    trials: int,
    params: list[str],
    metric: str = "progress",
    max_minutes: float | None = None,
    pruner: str = "median",
    startup_trials: int = 2,
    warmup_iterations: int = 1,
    seed: int | None = None,
) -> SweepSpec:
    """Create a sweep and queue its first ``trials`` trials.

    :raises DrxError: any bad input (nothing is stored then).
    """
    import optuna

    if not MODEL_NAME_RE.fullmatch(name):
        raise DrxError(
            f"Sweep name {name!r} is not allowed; use {NAME_RULE} (its trials become the models NAME-0, "
            "NAME-1...)."
        )
    model = get_model(source)
    _check_count(trials)
    check_seed(seed)
    if pruner not in PRUNERS:
        raise SettingError(
            "{field} {value} is unknown; use one of {allowed}.",
            "pruner",
            value=pruner,
            allowed=", ".join(PRUNERS),
        )
    if startup_trials < 0 or warmup_iterations < 0:
        raise SettingError(
            "{startup_trials} and {warmup_iterations} must be 0 or more.",
            "startup_trials",
            "warmup_iterations",
        )
    if max_minutes is not None:
        lo, hi = MAX_MINUTES_RANGE
        if not lo <= max_minutes <= hi:
            raise SettingError(
                "{field} {value:g} is out of range; use {lo} to {hi}.",
                "max_minutes_per_trial",
                value=max_minutes,
                lo=lo,
                hi=hi,
            )
    spec = SweepSpec(
        name=name,
        source=model.name,
        metric=check_metric(metric),
        params=[s.text() for s in parse_params(params, model.algorithm)],
        max_minutes=max_minutes,
        pruner=pruner,
        startup_trials=startup_trials,
        warmup_iterations=warmup_iterations,
        algorithm=model.algorithm,
        seed=seed,
    )
    storage = open_storage()
    if name in optuna.get_all_study_names(storage):
        raise AlreadyExistsError(f"Sweep {name!r} exists; add trials with `drx sweep extend {name}`.")
    _check_free_names(name, range(trials))
    study = optuna.create_study(
        study_name=name,
        storage=storage,
        direction=spec.direction,
        pruner=spec.make_pruner(),
        sampler=spec.make_sampler(0),
    )
    try:
        study.set_user_attr(ATTR, asdict(spec))
        _add_trials(study, spec, trials)
    except BaseException:
        with contextlib.suppress(Exception):
            optuna.delete_study(study_name=name, storage=storage)
        raise
    return spec


def extend_sweep(name: str, trials: int) -> list[int]:
    """Queue ``trials`` more trials of a sweep (finished or not); returns their numbers.

    :raises DrxError: unknown sweep, a bad count, or a trial's model name already taken.
    """
    _check_count(trials)
    spec, study = load_sweep(name)
    get_model(spec.source)  # the source must still exist
    reconcile(study)
    first = len(study.get_trials(deepcopy=False))
    _check_free_names(name, range(first, first + trials))
    study.sampler = spec.make_sampler(first)
    return _add_trials(study, spec, trials)


def _check_count(trials: int) -> None:
    if not 1 <= trials <= MAX_TRIALS:
        raise SettingError(
            "{field} {value} is out of range; use 1 to {hi}.", "trials", value=trials, hi=MAX_TRIALS
        )


def trial_model_name(sweep: str, number: int) -> str:
    """The model of trial ``number`` of ``sweep``."""
    return f"{sweep}-{number}"


def _check_free_names(sweep: str, numbers: range) -> None:
    names = [trial_model_name(sweep, n) for n in numbers]
    for name in names:
        check_model_name(name)  # a long sweep name leaves no room for "-N"
    with session_scope() as session:
        taken = session.scalar(select(Model.name).where(Model.name.in_(names)).limit(1))
    if taken is not None:
        raise AlreadyExistsError(
            f"Model {taken!r} exists, and sweep {sweep!r} would name a trial so; rename or remove it."
        )


def _add_trials(study: Any, spec: SweepSpec, count: int) -> list[int]:
    """Ask ``count`` trials, each a cloned model and a queued job; undo them all if one fails."""
    import optuna

    specs = spec.specs()
    distributions = {s.name: s.distribution() for s in specs}
    source = get_model(spec.source)
    with session_scope() as session:
        from_scratch = best_checkpoint(session, source.id) is None
    added: list[tuple[int, str]] = []
    try:
        for _ in range(count):
            trial = study.ask(distributions)
            name = trial_model_name(spec.name, trial.number)
            added.append((trial.number, name))
            _make_trial_model(spec, source.name, name, trial, apply_params(trial.params, specs), from_scratch)
            job = lifecycle.enqueue_training(name, {"sweep": {"study": spec.name, "trial": trial.number}})
            trial.set_user_attr("model", name)
            trial.set_user_attr("job", job.id)
    except BaseException:
        for number, name in added:
            with contextlib.suppress(Exception):
                _cancel_jobs(name)
                remove_model(name, force=True)
            with contextlib.suppress(Exception):
                study.tell(number, state=optuna.trial.TrialState.FAIL)
        raise
    return [number for number, _ in added]


def _make_trial_model(
    spec: SweepSpec, source: str, name: str, trial: Any, overrides: dict[str, Any], from_scratch: bool
) -> None:
    stop = {"max_minutes": spec.max_minutes} if spec.max_minutes is not None else None
    shown = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in trial.params.items())
    model = clone_model(
        source,
        name,
        hyperparameters=overrides,
        stop_conditions=stop,
        description=f"Trial {trial.number} of sweep {spec.name}: {shown}",
    )
    if from_scratch:  # an untrained source has no weights to start from: the trial trains from scratch
        with session_scope() as session:
            session.execute(
                update(Model).where(Model.id == model.id).values(parent_id=None, parent_checkpoint_id=None)
            )


def _cancel_jobs(model_name: str) -> None:
    for job, _ in lifecycle.list_jobs(model_name=model_name):
        if job.status in ("queued", "running"):
            lifecycle.request_stop(job.id)


@dataclass
class TrialRow:
    """One trial as ``drx sweep show`` lists it.

    :param state: ``complete``, ``pruned``, ``fail``, or the job's status while it has not ended.
    :param value: the trial's value (its best iteration's figure); ``None`` until it ends.
    :param iterations: iterations it reported.
    """

    number: int
    state: str
    model: str | None
    params: dict[str, Any]
    value: float | None
    iterations: int
    job: int | None
    job_status: str | None

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return asdict(self)


def trial_rows(spec: SweepSpec, study: Any) -> list[TrialRow]:
    """The sweep's trials, best first: complete by value, then pruned by value, then running, then failed."""
    reconcile(study)
    statuses = _job_statuses([t.user_attrs.get("job") for t in study.get_trials(deepcopy=False)])
    rows = []
    for t in study.get_trials(deepcopy=False):
        state = t.state.name.lower()
        job = t.user_attrs.get("job")
        if state == "running":
            state = statuses.get(job, "running")
        rows.append(
            TrialRow(
                number=t.number,
                state=state,
                model=t.user_attrs.get("model"),
                params=dict(t.params),
                value=t.value,
                iterations=len(t.intermediate_values),
                job=job,
                job_status=statuses.get(job),
            )
        )
    sign = 1 if spec.direction == "minimize" else -1
    order = {"complete": 0, "pruned": 1, "fail": 3}
    return sorted(
        rows,
        key=lambda r: (
            order.get(r.state, 2),
            sign * r.value if r.value is not None else 0.0,
            r.number,
        ),
    )


def _job_statuses(ids: list[int | None]) -> dict[int, str]:
    wanted = [i for i in ids if i is not None]
    if not wanted:
        return {}
    with session_scope() as session:
        rows = session.execute(select(Job.id, Job.status).where(Job.id.in_(wanted))).all()
    return {job_id: status for job_id, status in rows}


def reconcile(study: Any) -> None:
    """End the trials whose job ended without telling the study (stopped by hand, failed, lost).

    A succeeded job's trial completes with its best iteration; a job stopped or cancelled after
    some iterations counts as pruned by hand; anything else fails.
    """
    import optuna

    TrialState = optuna.trial.TrialState  # noqa: N806
    spec = SweepSpec(**study.user_attrs[ATTR])
    running = study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
    statuses = _job_statuses([t.user_attrs.get("job") for t in running])
    for t in running:
        job = t.user_attrs.get("job")
        status = statuses.get(job) if job is not None else None
        if job is not None and status not in FINAL_JOB_STATUSES and status is not None:
            continue  # queued or running: its worker will tell
        if "model" not in t.user_attrs:
            continue  # being added right now (the model and job come just after ask)
        values = list(t.intermediate_values.values())
        with contextlib.suppress(RuntimeError, ValueError):  # another process told it meanwhile
            if status == "succeeded" and values:
                study.tell(t.number, best_value(spec.metric, values))
            elif status in ("stopped", "cancelled") and values:
                study.tell(t.number, state=TrialState.PRUNED)
            else:
                study.tell(t.number, state=TrialState.FAIL)


def best_trial(rows: list[TrialRow]) -> TrialRow | None:
    """The best complete trial (rows as :func:`trial_rows` orders them)."""
    return next((r for r in rows if r.state == "complete" and r.value is not None), None)


def sweep_names() -> list[str]:
    """Every sweep in the registry."""
    import optuna

    return sorted(optuna.get_all_study_names(open_storage()))
