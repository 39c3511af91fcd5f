"""Models: create, clone, list, show, remove, and their clone lineage.

A model row snapshots its car (``vehicle_spec``), names its track, and points
at its reward code by content hash. A clone keeps its parent's car (a different
garage car is accepted only when its action space has the same type and size
and the same sensors and network, since the clone starts from the parent's
weights), its algorithm, and, unless overridden, its tracks, their direction,
where episodes start, its reward, hyperparameters and stop conditions.
``parent_checkpoint_id`` is the parent's best checkpoint at clone time (``None``
when the parent has not trained yet: the trainer then takes the parent's best
checkpoint when the clone starts).

``drx model rm`` refuses while the model has a queued or running job, and while
clones depend on it unless ``force``: then the clones are detached (they keep
``parent_name`` for the record) and the model, its jobs, checkpoints, metrics,
evaluations and artifacts folder are removed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from drx.errors import AlreadyExistsError, DrxError, NotFoundError, SettingError
from drx.registry import JOB_ACTIVE_STATUSES, MODEL_STATUSES, Checkpoint, Job, Model, session_scope
from drx.services import garage, rewards, tracks
from drx.services.names import check_model_name
from drx.services.opponents import checked_race
from drx.settings.car import DEFAULT_SIMULATOR, CarSettings
from drx.settings.device import check_device
from drx.settings.episodes import EpisodeSettings, parse_direction
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.race import RaceConfig, sensor_warnings
from drx.settings.rollout import RolloutSettings
from drx.settings.stop import StopConditions
from drx.sim.catalogue import TrackEntry
from drx.storage import artifacts_dir, get_store
from drx.vehicle import Vehicle


def model_artifacts_dir(name: str) -> Path:
    """The folder holding a model's files (checkpoints, traces, logs): ``artifacts/models/<name>``."""
    return artifacts_dir() / "models" / name


def _find(session: Session, name: str) -> Model:
    model = session.scalar(select(Model).where(Model.name == name))
    if model is None:
        names = list(session.scalars(select(Model.name).order_by(Model.name).limit(12)))
        hint = f"known models: {', '.join(names)}" if names else "there are no models yet"
        raise NotFoundError(f"No model named {name!r}; {hint} (see `drx model list`).")
    return model


def get_model(name: str) -> Model:
    """The model named ``name`` (detached from its session; attributes stay readable).

    :raises NotFoundError: no such model.
    """
    with session_scope() as session:
        return _find(session, name)


def list_models() -> list[Model]:
    """Every model, oldest first."""
    with session_scope() as session:
        return list(session.scalars(select(Model).order_by(Model.created_at, Model.id)))


def _check_algorithm(algorithm: str, vehicle: Vehicle) -> str:
    algorithm = algorithm.lower()
    if algorithm not in ("ppo", "sac"):
        raise SettingError("{field} {value} is unknown; use ppo or sac.", "algorithm", value=algorithm)
    if algorithm == "sac" and not vehicle.continuous:
        raise SettingError(
            "{field} sac needs a continuous car, and {car!r} is discrete; "
            "use {field} ppo or a car added with {continuous}.",
            "algorithm",
            "continuous",
            car=vehicle.name,
        )
    return algorithm


def _with_network(vehicle: Vehicle, network: str | None) -> Vehicle:
    if network is None or network == vehicle.network:
        return vehicle
    return Vehicle.from_dict({**vehicle.to_dict(), "network": network})


def usable_device(device: str | None) -> str | None:
    """A device setting as stored (``None``: auto), once this machine can use it: a model is not
    made to train on a GPU that is not here (torch loads only when the machine might have one).

    :raises SettingError: not a device, or a GPU torch cannot use here.
    """
    setting = check_device(device)
    if setting is not None and setting != "cpu":
        from drx.train.device import resolve_device

        resolve_device(setting)
    return setting


def _insert(session: Session, model: Model) -> Model:
    if session.scalar(select(Model.id).where(Model.name == model.name)) is not None:
        raise AlreadyExistsError(f"Model {model.name!r} already exists; choose another name.")
    session.add(model)
    try:
        session.flush()
    except IntegrityError as exc:  # a concurrent writer took the name or removed the parent
        raise DrxError(
            f"Model {model.name!r} could not be saved because the registry changed meanwhile "
            f"({type(exc.orig).__name__}); run the command again."
        ) from None
    return model


def _store_reward(session: Session, reward_fn: rewards.RewardFunction) -> tuple[str, str]:
    """Store the reward's code: its sha256 and the file name the model records."""
    source = rewards.store_reward(session, reward_fn)
    return source.sha256, Path(reward_fn.source_path or source.filename).name


def _draft(
    name: str,
    description: str | None,
    vehicle: Vehicle,
    track: TrackEntry,
    reward: tuple[str, str],
    algorithm: str,
    hyperparameters: Hyperparameters,
    stop_conditions: StopConditions,
    race_config: RaceConfig,
    rollout: RolloutSettings,
    episodes: EpisodeSettings,
    device: str | None = None,
    car_settings: CarSettings | None = None,
    **parent: Any,
) -> Model:
    """A new draft model row. ``track``: the resolved first track (the row stores its canonical
    name); ``reward``: its code's sha256 and file name; ``episodes``: the tracks and where episodes
    start; ``device``: the checked device setting (``None``: auto); ``car_settings``: the simulator whose
    car it trains on and car randomization (default: :class:`CarSettings`'s); ``parent``: a clone's
    ``parent_*`` columns."""
    car_settings = car_settings or CarSettings()
    return Model(
        name=name,
        description=description,
        vehicle_name=vehicle.name,
        vehicle_spec=vehicle.to_dict(),
        track_name=track.name,
        track_sha256=tracks.file_sha256(track.path),
        reward_sha256=reward[0],
        reward_filename=reward[1],
        algorithm=algorithm,
        hyperparameters=hyperparameters.to_model_json(vehicle.network),
        stop_conditions=stop_conditions.to_dict(),
        race=race_config.to_dict(),
        domain_randomization=rollout.domain_randomization,
        rollout_workers=rollout.rollout_workers,
        episode_options=episodes.to_dict(),
        device=device,
        simulator=car_settings.simulator,
        car_randomization=car_settings.car_randomization,
        status="draft",
        **parent,
    )


def episode_settings(
    track_names: Sequence[str],
    direction: str | None,
    options: dict[str, Any] | None,
    base: EpisodeSettings | None = None,
) -> tuple[EpisodeSettings, TrackEntry]:
    """A model's tracks, their direction and its starts, every track resolved once; and the first
    track's entry (the row's ``track_name``).

    :param track_names: route ids or display names, the model's own track first.
    :param direction: ``cw``/``ccw`` (or ``clockwise``...); ``None``: each route's own.
    :param options: :data:`drx.settings.episodes.OPTION_KEYS` given (``None`` values: not given).
    :param base: the settings to start from (a clone's parent's); ``None``: DeepRacer's defaults.
    :raises SettingError: an unknown direction, a direction for an open track, a track given twice,
        open tracks with loops, options out of range or that do not fit.
    :raises NotFoundError: an unknown track.
    """
    base = base or EpisodeSettings()
    wanted = parse_direction(direction)
    if not track_names:
        raise SettingError("Give at least one {field}.", "track")
    directed = [tracks.find_directed(name, wanted) for name in track_names]
    first_given: dict[str, str] = {}
    for name, d in zip(track_names, directed, strict=True):
        if d.entry.name in first_given:
            same = first_given[d.entry.name]
            both = f"{same!r} and {name!r} are both {d.entry.name}"
            what = f"{name!r} is given twice" if same == name else both
            raise SettingError("{field} {what}; give each track once.", "track", what=what)
        first_given[d.entry.name] = name
    tracks_ = tuple(d.training_track() for d in directed)
    return base.overridden(options, tracks=tracks_, direction=wanted), directed[0].entry


def create_model(
    name: str,
    *,
    car: str = garage.BUILTIN_CAR,
    track: str | Sequence[str] = tracks.DEFAULT_TRACK,
    reward: str | Path = rewards.DEFAULT_REWARD,
    algorithm: str = "ppo",
    network: str | None = None,
    hyperparameters: dict[str, Any] | None = None,
    stop_conditions: dict[str, Any] | None = None,
    description: str | None = None,
    race: dict[str, Any] | None = None,
    domain_randomization: bool = False,
    check_reward: bool = False,
    rollout_workers: int | None = None,
    direction: str | None = None,
    episodes: dict[str, Any] | None = None,
    device: str | None = None,
    simulator: str | None = None,
    car_randomization: bool = False,
    vehicle: Vehicle | None = None,
    reward_code: tuple[str, str] | None = None,
    recipe: dict[str, Any] | None = None,
) -> Model:
    """Create a model, validating everything before anything is written (one transaction).

    :param name: 1-64 letters, digits, '-' and '_' (:data:`drx.services.names.NAME_RULE`).
    :param car: a garage car (its spec is copied onto the model).
    :param track: a track's route id, display name or imported name (:func:`tracks.find_track`), or
        several: episodes spread over them in turn, the first is the model's track (evaluated).
    :param reward: a reward file or sample name (its code is stored by hash).
    :param algorithm: ``ppo`` or ``sac`` (continuous cars only).
    :param network: override the car's policy network (``shallow``, ``deep``, ``compact``).
    :param hyperparameters: :class:`drx.settings.hyperparameters.Hyperparameters` fields to override.
    :param stop_conditions: :class:`~drx.settings.stop.StopConditions` fields to override
        (:data:`~drx.settings.stop.STOP_KEYS`).
    :param race: :class:`~drx.settings.race.RaceConfig` fields (``race_type``, ``objects``,
        ``object_positions``, ``randomize_objects``, ``bots``, ``bot_speed``, ``bot_lane_change``,
        ``opponents``: names of trained models, :mod:`drx.services.opponents`); ``None`` for a time
        trial. See :func:`race_warnings` for sensors that serve it poorly.
    :param domain_randomization: training episodes vary lighting and colours (DeepRacer's
        ``ENABLE_DOMAIN_RANDOMIZATION``); evaluations do not.
    :param check_reward: call the reward on ``drx reward validate``'s sample states first and refuse
        it when a call fails (the CLI does, unless ``--force``); off by default, since it runs the code.
    :param rollout_workers: processes sampling training episodes (``None``: as many as help).
    :param direction: ``cw`` or ``ccw``: drive the tracks that way (a two-way track's route for it,
        else the route reversed); ``None``: each route's own (:func:`episode_settings`).
    :param episodes: where episodes start (:class:`~drx.settings.episodes.EpisodeSettings` fields of
        :data:`~drx.settings.episodes.OPTION_KEYS`; ``None`` values: DeepRacer's defaults).
    :param device: the torch device it trains on: ``auto`` (``None``), ``cpu``, ``cuda``, ``cuda:N``
        or ``mps``; a GPU must be one this machine can use (:func:`usable_device`).
    :param simulator: the DeepRacer simulator whose car it trains and races on (``"5"`` or ``"6"``;
        ``None``: 6, the car DeepRacer on AWS and deepracer-for-cloud race on).
    :param car_randomization: training episodes draw a car between versions 5 and 6
        (:mod:`drx.sim.car_randomization`), so the model holds on either.
    :param vehicle: a car built for the model (a recipe's) instead of the garage's ``car``.
    :param reward_code: ``(code, file name)`` of a reward written for the model (a recipe's) instead of
        the file ``reward``; stored trusted (drx wrote it) and checked like a file.
    :param recipe: the recipe the model was built by and its choices (:mod:`drx.recipes`), as stored.
    :raises DrxError: any bad input; the registry is unchanged then.
    """
    check_model_name(name)
    device = usable_device(device)
    car_settings = CarSettings(simulator or DEFAULT_SIMULATOR, car_randomization)
    rollout = RolloutSettings(rollout_workers, domain_randomization)
    vehicle = _with_network(vehicle or garage.get_vehicle(car), network)
    algorithm = _check_algorithm(algorithm, vehicle)
    hp = Hyperparameters.build(algorithm, hyperparameters or {})
    stop = StopConditions().overridden(stop_conditions)
    names = [track] if isinstance(track, str) else list(track)
    # resolved once; the model stores the canonical names (route ids)
    starts, track_entry = episode_settings(names, direction, episodes)
    race_config = checked_race(race, name, starts, track_entry)  # head-to-model: its opponents (by id)
    reward_fn = rewards.load_reward(reward) if reward_code is None else rewards.compile_reward(*reward_code)
    if check_reward:
        rewards.require_valid_reward(reward_fn, tracks.load_entry(track_entry))
    get_store().check()  # a model whose files cannot be stored is not made
    with session_scope() as session:
        stored = _store_reward(session, reward_fn)
        model = _draft(
            name,
            description,
            vehicle,
            track_entry,
            stored,
            algorithm,
            hp,
            stop,
            race_config,
            rollout,
            starts,
            device,
            car_settings,
        )
        model.recipe = recipe
        return _insert(session, model)


def race_warnings(model: Model) -> list[str]:
    """Sentences about the model's car serving its race type poorly (e.g. head-to-bot without a
    lidar); empty when it suits. Allowed, so the CLI prints them as warnings."""
    vehicle = model.vehicle()
    return sensor_warnings(model.race_config(), vehicle.sensor, vehicle.lidar)


def _check_same_action_space(parent: Vehicle, car: Vehicle) -> None:
    if car.continuous != parent.continuous or car.n_actions != parent.n_actions:
        want = "a continuous action space" if parent.continuous else f"{parent.n_actions} discrete actions"
        raise DrxError(
            f"Car {car.name!r} has {car.summary()}; a clone must keep its parent's action space size "
            f"({want})."
        )
    for attr in ("sensor", "lidar", "network"):
        if getattr(car, attr) != getattr(parent, attr):
            raise DrxError(
                f"Car {car.name!r} has {attr} {getattr(car, attr)!r} but the parent has "
                f"{getattr(parent, attr)!r}; a clone starts from the parent's weights, so they must match."
            )


def _check_towers(parent: str, clone: str) -> None:
    """A clone may split its parent's shared trunk into two towers (each starts as the trunk), but
    not merge two towers into one trunk: there is no one trunk to start from."""
    if parent == "separate" and clone == "shared":
        raise SettingError(
            "{field} shared cannot start from a parent with separate towers; keep {value} (the parent's).",
            "towers",
            value="separate",
        )


def best_checkpoint(session: Session, model_id: int) -> Checkpoint | None:
    """The model's best checkpoint (else its latest), or ``None`` when it has none."""
    return session.scalar(
        select(Checkpoint)
        .where(Checkpoint.model_id == model_id)
        .order_by(Checkpoint.is_best.desc(), Checkpoint.iteration.desc())
        .limit(1)
    )


def clone_model(
    source: str,
    name: str,
    *,
    car: str | None = None,
    track: str | Sequence[str] | None = None,
    reward: str | Path | None = None,
    hyperparameters: dict[str, Any] | None = None,
    stop_conditions: dict[str, Any] | None = None,
    description: str | None = None,
    race: dict[str, Any] | None = None,
    domain_randomization: bool | None = None,
    check_reward: bool = False,
    rollout_workers: int | None = None,
    direction: str | None = None,
    episodes: dict[str, Any] | None = None,
    device: str | None = None,
    simulator: str | None = None,
    car_randomization: bool | None = None,
) -> Model:
    """Clone ``source`` as ``name``: same action space and algorithm, starting from its weights.

    Unset options inherit the parent's values (its tracks, their direction and its starts too: a
    ``direction`` alone turns the parent's tracks round; new tracks are driven ``direction``, or
    without it their own way, as the console asks for a new track's direction anew).
    See :func:`create_model` for the parameters; ``check_reward`` checks a new ``reward`` (the
    parent's passed when it was made).

    :raises DrxError: bad input (including a car whose action space differs); nothing is written then.
    """
    check_model_name(name)
    parent = get_model(source)
    # the parent's device unless one is given (only a given one is checked against this machine)
    device = parent.device if device is None else usable_device(device)
    parent_car = parent.car_settings()  # the parent's car unless another is given
    car_settings = CarSettings(
        parent_car.simulator if simulator is None else simulator,
        parent_car.car_randomization if car_randomization is None else car_randomization,
    )
    inherited = parent.rollout_settings()
    rollout = RolloutSettings(
        inherited.rollout_workers if rollout_workers is None else rollout_workers,
        inherited.domain_randomization if domain_randomization is None else domain_randomization,
    )
    parent_vehicle = parent.vehicle()
    vehicle = parent_vehicle
    if car is not None:
        vehicle = garage.get_vehicle(car)
        _check_same_action_space(parent_vehicle, vehicle)
    hp = Hyperparameters.build(parent.algorithm, hyperparameters or {}, base=parent.hyperparameters)
    _check_towers(parent.hyperparameters.get("towers") or "shared", hp.towers)
    stop = parent.stop_settings().overridden(stop_conditions)
    inherited_starts = parent.episode_settings()
    if track:  # new tracks: their own way unless a direction is given
        names = [track] if isinstance(track, str) else list(track)
    else:  # the parent's tracks, its direction unless another is given
        names, direction = inherited_starts.track_names, direction or inherited_starts.direction
    starts, track_entry = episode_settings(names, direction, episodes, base=inherited_starts)
    race_config = checked_race(race if race is not None else parent.race, name, starts, track_entry)
    reward_fn = rewards.load_reward(reward) if reward is not None else None
    if check_reward and reward_fn is not None:
        rewards.require_valid_reward(reward_fn, tracks.load_entry(track_entry))
    get_store().check()
    with session_scope() as session:
        if reward_fn is not None:
            stored = _store_reward(session, reward_fn)
        else:
            stored = parent.reward_sha256, parent.reward_filename
        checkpoint = best_checkpoint(session, parent.id)
        return _insert(
            session,
            _draft(
                name,
                description,
                vehicle,
                track_entry,
                stored,
                parent.algorithm,
                hp,
                stop,
                race_config,
                rollout,
                starts,
                device,
                car_settings,
                parent_id=parent.id,
                parent_name=parent.name,
                parent_checkpoint_id=checkpoint.id if checkpoint else None,
            ),
        )


def remove_model(name: str, force: bool = False) -> list[str]:
    """Remove a model, its rows (jobs, checkpoints, metrics, evaluations) and its artifacts folder.

    :param force: also remove a model that has clones; the clones are detached.
    :return: the names of the detached clones.
    :raises DrxError: unknown model, an active job, or clones without ``force``, an unreachable store.
    """
    store = get_store()
    store.check()  # the rows go only when the files can go too
    with session_scope() as session:
        model = _find(session, name)
        active = session.scalar(
            select(Job.id).where(Job.model_id == model.id, Job.status.in_(JOB_ACTIVE_STATUSES)).limit(1)
        )
        if active is not None:
            raise DrxError(f"Model {name!r} has a queued or running job ({active}); stop it before removing.")
        children = list(
            session.scalars(select(Model).where(Model.parent_id == model.id).order_by(Model.name))
        )
        if children and not force:
            names = ", ".join(c.name for c in children)
            raise SettingError(
                "Model {model!r} has clones ({names}); remove them first, or use {field} to detach them.",
                "force",
                model=name,
                names=names,
            )
        for child in children:
            child.parent_id = None
            child.parent_checkpoint_id = None
        session.flush()
        session.delete(model)
    store.remove_model(name)
    return [c.name for c in children]


@dataclass
class LineageNode:
    """A model in a clone tree."""

    model: Model
    children: list[LineageNode] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (nested)."""
        return {
            "name": self.model.name,
            "status": self.model.status,
            "track": self.model.track_name,
            "algorithm": self.model.algorithm,
            "parent_name": self.model.parent_name,
            "created_at": self.model.created_at.isoformat(),
            "children": [c.to_dict() for c in self.children],
        }


def lineage(name: str | None = None) -> list[LineageNode]:
    """Clone trees: the one holding model ``name`` (from its root), or every tree.

    :raises NotFoundError: ``name`` is not a model.
    """
    models = list_models()
    nodes = {m.id: LineageNode(m) for m in models}
    roots = []
    for m in models:
        if m.parent_id is not None and m.parent_id in nodes:
            nodes[m.parent_id].children.append(nodes[m.id])
        else:
            roots.append(nodes[m.id])
    if name is None:
        return roots
    by_name = {m.name: m for m in models}
    if name not in by_name:
        get_model(name)  # raises NotFoundError
    current = by_name[name]
    while current.parent_id is not None and current.parent_id in nodes:
        current = nodes[current.parent_id].model
    return [nodes[current.id]]


def set_status(session: Session, model_id: int, status: str) -> Model:
    """Set a model's status inside the caller's transaction (the trainer and the queue call this).

    :param status: one of :data:`drx.registry.MODEL_STATUSES`.
    """
    if status not in MODEL_STATUSES:
        raise ValueError(f"model status {status!r} is not one of {', '.join(MODEL_STATUSES)}")
    model = session.get_one(Model, model_id)
    model.status = status
    return model


def model_counts(session: Session, model_id: int) -> dict[str, int]:
    """How many jobs and checkpoints a model has."""
    jobs = session.scalar(select(func.count(Job.id)).where(Job.model_id == model_id)) or 0
    cps = session.scalar(select(func.count(Checkpoint.id)).where(Checkpoint.model_id == model_id)) or 0
    return {"jobs": jobs, "checkpoints": cps}


def track_figures(session: Session, model: Model) -> list[dict[str, Any]]:
    """A model's training on each of its tracks, for a model that trains on several: per track its
    training episodes so far and the latest iteration that drove it (its number, mean reward and
    mean progress [%]). Empty for a one-track model (its figures are the iterations' own)."""
    names = model.episode_settings().track_names
    if len(names) < 2:
        return []
    from drx.registry.metrics import training_by_track

    def empty(name: str) -> dict[str, Any]:
        return {"track": name, "episodes": 0, "iteration": None, "mean_reward": None, "mean_progress": None}

    out = {name: empty(name) for name in names}
    for iteration, per_track in training_by_track(session, model.id).items():
        for name, (count, reward, progress) in per_track.items():
            row = out.setdefault(name, empty(name))
            row.update(episodes=row["episodes"] + count, iteration=iteration)
            row.update(mean_reward=reward, mean_progress=progress)
    return list(out.values())
