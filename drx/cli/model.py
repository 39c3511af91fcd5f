"""``drx model``: create, clone, list, show, lineage and rm."""

import sys
from typing import Annotated, Any

import typer
from rich.table import Table
from rich.tree import Tree

from drx.cli.app import group
from drx.cli.output import console, emit, json_option
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.registry import Model, session_scope
from drx.services import models as service
from drx.services.hyperparameters import describe_stop_conditions

app = group("Models: a car, a track and a reward function, with hyperparameters and stop conditions.")

# ----- shared options ----------------------------------------------------------
Car = Annotated[str | None, typer.Option(help="A garage car [default: default].")]
TrackOpt = Annotated[str | None, typer.Option("--track", help="A track name [default: oval].")]
Reward = Annotated[
    str | None, typer.Option(help="A reward .py file or a sample name [default: follow_center_line].")
]
BatchSize = Annotated[int | None, typer.Option(help="Gradient descent batch size: 32, 64, 128, 256 or 512.")]
Epochs = Annotated[int | None, typer.Option(help="PPO epochs per update, 3-10 [PPO default: 10].")]
Lr = Annotated[float | None, typer.Option(help="Learning rate, 1e-8 to 1e-3 [default: 3e-4].")]
Entropy = Annotated[float | None, typer.Option(help="PPO entropy (beta), 0-1 [default: 0.01].")]
Discount = Annotated[float | None, typer.Option(help="Discount factor, 0-1 [default: 0.99].")]
Loss = Annotated[str | None, typer.Option(help="Loss type: huber or mse [PPO: huber, SAC: mse].")]
Episodes = Annotated[
    int | None, typer.Option(help="Episodes between policy updates: PPO 5-100 [20], SAC 1-100 [1].")
]
SacAlpha = Annotated[float | None, typer.Option(help="SAC alpha, 0-1 [default: 0.2].")]
MaxMinutes = Annotated[float | None, typer.Option(help="Stop after this many minutes, 1-1440 [default: 60].")]
MaxSteps = Annotated[int | None, typer.Option(help="Stop after this many environment steps.")]
MaxEpisodes = Annotated[int | None, typer.Option(help="Stop after this many training episodes.")]
Target = Annotated[
    int | None,
    typer.Option(help="Stop once evaluation laps reach 100% progress for this many iterations in a row."),
]
Description = Annotated[str | None, typer.Option(help="A note about the model.")]
RolloutWorkers = Annotated[
    int | None,
    typer.Option(
        help="Processes sampling training episodes, 1-64 [default: as many as help where it trains]."
    ),
]
RaceType = Annotated[
    str | None, typer.Option(help="time-trial, object-avoidance or head-to-bot [default: time-trial].")
]
Objects = Annotated[int | None, typer.Option(help="Object avoidance: boxes on the track, 1-6 [default: 3].")]
ObjectAt = Annotated[
    list[str] | None,
    typer.Option(
        help="Object avoidance: a box at PLACE:LANE, e.g. 25:inside (percent of the lap 7-90, "
        "inside|outside); repeat per box, at least 13% apart."
    ),  # fmt: skip
]
RandomizeObjects = Annotated[
    bool, typer.Option(help="Object avoidance: new random box places every training episode.")
]
Bots = Annotated[int | None, typer.Option(help="Head-to-bot: bot cars, 1-4 [default: 3].")]
BotSpeed = Annotated[float | None, typer.Option(help="Head-to-bot: bot speed, 0.2-6 m/s [default: 0.2].")]
BotLaneChange = Annotated[bool, typer.Option(help="Head-to-bot: bots change lanes every 3-5 s.")]
RandomizeBots = Annotated[
    bool, typer.Option(help="Head-to-bot: new random bot places and lanes every training episode.")
]
Force = Annotated[
    bool,
    typer.Option(
        "--force",
        help="Keep a reward function that fails `drx reward validate`'s sample states (checked by "
        "default: training would fail on it).",
    ),
]


def _hyperparameters(
    batch_size: int | None,
    epochs: int | None,
    lr: float | None,
    entropy: float | None,
    discount: float | None,
    loss: str | None,
    episodes_per_iteration: int | None,
    sac_alpha: float | None,
) -> dict[str, Any]:
    """CLI hyperparameter options -> Hyperparameters fields (shared by ``create`` and ``clone``)."""
    return {
        "batch_size": batch_size,
        "num_epochs": epochs,
        "learning_rate": lr,
        "entropy": entropy,
        "discount_factor": discount,
        "loss_type": loss,
        "episodes_per_iteration": episodes_per_iteration,
        "sac_alpha": sac_alpha,
    }


def _stop_conditions(
    max_minutes: float | None, max_steps: int | None, max_episodes: int | None, target_iterations: int | None
) -> dict[str, Any]:
    """CLI stop-condition options -> stop conditions (shared by ``create`` and ``clone``)."""
    return {
        "max_minutes": max_minutes,
        "max_steps": max_steps,
        "max_episodes": max_episodes,
        "target_iterations": target_iterations,
    }


def _race(
    race_type: str | None,
    objects: int | None,
    object_at: list[str] | None,
    randomize_objects: bool,
    bots: int | None,
    bot_speed: float | None,
    bot_lane_change: bool,
    randomize_bots: bool = False,
) -> dict[str, Any] | None:
    """CLI race options -> RaceConfig fields; ``None`` when none was given."""
    from drx.settings.race import parse_object_at

    given = (race_type, objects, object_at or None, randomize_objects or None, bots, bot_speed,
             bot_lane_change or None, randomize_bots or None)  # fmt: skip
    if all(v is None for v in given):
        return None
    return {
        "race_type": race_type or "time-trial",
        "objects": objects,
        "object_positions": [parse_object_at(p) for p in object_at or ()],
        "randomize_objects": randomize_objects,
        "bots": bots,
        "bot_speed": bot_speed,
        "bot_lane_change": bot_lane_change,
        "randomize_bots": randomize_bots,
    }


def _warn_race(m: Model) -> None:
    """Race types the car serves poorly: a warning on stderr (the model is still created)."""
    for sentence in service.race_warnings(m):
        sys.stderr.write(f"Warning: {sentence}\n")


def model_dict(m: Model) -> dict[str, Any]:
    """A model as JSON."""
    return {
        "id": m.id,
        "name": m.name,
        "status": m.status,
        "description": m.description,
        "car": m.vehicle_name,
        "vehicle": m.vehicle().to_model_metadata(m.algorithm),
        "track": m.track_name,
        "track_sha256": m.track_sha256,
        "reward_file": m.reward_filename,
        "reward_sha256": m.reward_sha256,
        "algorithm": m.algorithm,
        "hyperparameters": m.hyperparameters,
        "stop_conditions": m.stop_conditions,
        "race": m.race,
        "domain_randomization": bool(m.domain_randomization),
        "rollout_workers": m.rollout_workers,
        "parent": m.parent_name,
        "parent_checkpoint_id": m.parent_checkpoint_id,
        "created_at": m.created_at,
    }


def _created(m: Model, verb: str) -> None:
    def render() -> None:
        console.print(
            f"{verb} model [bold]{m.name}[/]: car {m.vehicle_name} ({m.vehicle().summary()}), "
            f"track {m.track_name} ({m.race_config().summary()}), reward {m.reward_filename}, "
            f"{m.algorithm.upper()}, stops after {describe_stop_conditions(m.stop_conditions)}."
        )

    emit(model_dict(m), render)


@app.command("create")
@json_option
def create(
    name: Annotated[str, typer.Argument(help="Model name: up to 64 letters, digits, '-' and '_'.")],
    car: Car = None,
    track: TrackOpt = None,
    reward: Reward = None,
    algo: Annotated[str, typer.Option(help="ppo, or sac (continuous cars only).")] = "ppo",
    network: Annotated[
        str | None, typer.Option(help="Override the car's network: shallow, deep, compact.")
    ] = None,
    batch_size: BatchSize = None,
    epochs: Epochs = None,
    lr: Lr = None,
    entropy: Entropy = None,
    discount: Discount = None,
    loss: Loss = None,
    episodes_per_iteration: Episodes = None,
    sac_alpha: SacAlpha = None,
    max_minutes: MaxMinutes = None,
    max_steps: MaxSteps = None,
    max_episodes: MaxEpisodes = None,
    target_iterations: Target = None,
    description: Description = None,
    race_type: RaceType = None,
    objects: Objects = None,
    object_at: ObjectAt = None,
    randomize_objects: RandomizeObjects = False,
    bots: Bots = None,
    bot_speed: BotSpeed = None,
    bot_lane_change: BotLaneChange = False,
    randomize_bots: RandomizeBots = False,
    domain_randomization: Annotated[
        bool,
        typer.Option(
            "--domain-randomization",
            help="Vary lighting and colours every training episode (DeepRacer's domain randomization).",
        ),
    ] = False,
    force: Force = False,
    rollout_workers: RolloutWorkers = None,
) -> None:
    """Create a model from a car, a track and a reward function.

    Hyperparameters take DeepRacer's names, ranges and defaults. Training stops at the first
    stop condition reached (default: 60 minutes).

    Example:

      drx model create my-model --car default --track oval --reward follow_center_line --max-minutes 10

      drx model create boxes --car stereo-lidar --race-type object-avoidance --objects 3 --randomize-objects

      drx model create bots --car stereo-lidar --race-type head-to-bot --bots 2 --bot-speed 1.0
    """
    race = _race(
        race_type, objects, object_at, randomize_objects, bots, bot_speed, bot_lane_change, randomize_bots
    )
    m = service.create_model(
        name,
        car=car or service.garage.BUILTIN_CAR,
        track=track or service.tracks.DEFAULT_TRACK,
        reward=reward or service.rewards.DEFAULT_REWARD,
        algorithm=algo,
        network=network,
        hyperparameters=_hyperparameters(
            batch_size, epochs, lr, entropy, discount, loss, episodes_per_iteration, sac_alpha
        ),
        stop_conditions=_stop_conditions(max_minutes, max_steps, max_episodes, target_iterations),
        description=description,
        race=race,
        domain_randomization=domain_randomization,
        check_reward=not force,
        rollout_workers=rollout_workers,
    )
    _warn_race(m)
    _created(m, "Created")


@app.command("clone")
@json_option
def clone(
    source: Annotated[str, typer.Argument(help="The model to clone.")],
    name: Annotated[str, typer.Argument(help="The new model's name.")],
    car: Annotated[
        str | None,
        typer.Option(help="Another garage car with the same action space size, sensors and network."),
    ] = None,
    track: Annotated[str | None, typer.Option(help="Train on another track [default: the parent's].")] = None,
    reward: Annotated[str | None, typer.Option(help="Another reward file [default: the parent's].")] = None,
    batch_size: BatchSize = None,
    epochs: Epochs = None,
    lr: Lr = None,
    entropy: Entropy = None,
    discount: Discount = None,
    loss: Loss = None,
    episodes_per_iteration: Episodes = None,
    sac_alpha: SacAlpha = None,
    max_minutes: MaxMinutes = None,
    max_steps: MaxSteps = None,
    max_episodes: MaxEpisodes = None,
    target_iterations: Target = None,
    description: Description = None,
    race_type: RaceType = None,
    objects: Objects = None,
    object_at: ObjectAt = None,
    randomize_objects: RandomizeObjects = False,
    bots: Bots = None,
    bot_speed: BotSpeed = None,
    bot_lane_change: BotLaneChange = False,
    randomize_bots: RandomizeBots = False,
    domain_randomization: Annotated[
        bool | None,
        typer.Option(
            "--domain-randomization/--no-domain-randomization",
            help="Vary lighting and colours every training episode [default: the parent's].",
            show_default=False,
        ),
    ] = None,
    force: Force = False,
    rollout_workers: RolloutWorkers = None,
) -> None:
    """Clone a model: the clone starts from the parent's trained weights, keeps its action space
    and algorithm, and records its parent. Anything not given is the parent's (race options
    replace the parent's race as a whole).

    Example:

      drx model clone my-first-model my-second-model --track kidney --lr 0.0001 --max-minutes 20
    """
    m = service.clone_model(
        source,
        name,
        car=car,
        track=track,
        reward=reward,
        hyperparameters=_hyperparameters(
            batch_size, epochs, lr, entropy, discount, loss, episodes_per_iteration, sac_alpha
        ),
        stop_conditions=_stop_conditions(max_minutes, max_steps, max_episodes, target_iterations),
        description=description,
        race=_race(
            race_type, objects, object_at, randomize_objects, bots, bot_speed, bot_lane_change, randomize_bots
        ),
        domain_randomization=domain_randomization,
        check_reward=not force,
        rollout_workers=rollout_workers,
    )
    _warn_race(m)
    _created(m, f"Cloned {source} as")


@app.command("list")
@json_option
def list_models(wide: Wide = False) -> None:
    """List models.

    Example:

      drx model list --json
    """
    models = service.list_models()

    def render() -> None:
        if not models:
            console.print("No models yet; create one with `drx model create NAME`.")
            return
        columns = [
            Column("name", 0, kind="name"),
            Column("status", 0),
            Column("track", 1, kind="name"),
            Column("car", 2, kind="name"),
            Column("parent", 3, kind="name"),
            Column("algo", 4),
            Column("created", 5),
        ]
        rows = [
            [m.name, m.status, m.track_name, m.vehicle_name, m.parent_name or "-", m.algorithm,
             m.created_at.strftime("%Y-%m-%d %H:%M")]
            for m in models
        ]  # fmt: skip
        print_table(fitted_table(columns, rows, console=console, wide=wide, title="Models"), console, wide)

    emit([model_dict(m) for m in models], render)


HP_LABELS = {
    "batch_size": "gradient descent batch size",
    "num_epochs": "number of epochs",
    "learning_rate": "learning rate",
    "entropy": "entropy (beta)",
    "discount_factor": "discount factor",
    "loss_type": "loss type",
    "episodes_per_iteration": "episodes between policy updates",
    "sac_alpha": "SAC alpha",
    "network": "network",
}
PPO_ONLY, SAC_ONLY = ("num_epochs", "entropy"), ("sac_alpha",)


@app.command("show")
@json_option
def show(name: Annotated[str, typer.Argument(help="The model's name.")]) -> None:
    """Show a model: car, track, reward, hyperparameters, stop conditions and lineage.

    Example:

      drx model show my-first-model
    """
    m = service.get_model(name)
    children = [n.name for n in service.list_models() if n.parent_id == m.id]
    with session_scope() as session:
        counts = service.model_counts(session, m.id)
    data = {**model_dict(m), "clones": children, **counts}

    def render() -> None:
        v = m.vehicle()
        table = Table(show_header=False, title=f"Model {m.name}")
        table.add_column(style="bold")
        table.add_column()
        table.add_row("status", m.status)
        if m.description:
            table.add_row("description", m.description)
        table.add_row("car", f"{m.vehicle_name}: {v.summary()}")
        table.add_row("track", m.track_name)
        table.add_row("reward", f"{m.reward_filename} (sha256 {m.reward_sha256[:12]})")
        table.add_row("algorithm", m.algorithm.upper())
        table.add_row("stop conditions", describe_stop_conditions(m.stop_conditions))
        table.add_row("race", m.race_config().summary())
        table.add_row("domain randomization", "on (training)" if m.domain_randomization else "off")
        table.add_row("rollout workers", str(m.rollout_workers) if m.rollout_workers else "automatic")
        parent = m.parent_name or "-"
        if m.parent_name and m.parent_id is None:
            parent += " (removed)"
        elif m.parent_checkpoint_id is not None:
            parent += f" (checkpoint {m.parent_checkpoint_id})"
        table.add_row("parent", parent)
        table.add_row("clones", ", ".join(children) or "-")
        table.add_row("jobs / checkpoints", f"{counts['jobs']} / {counts['checkpoints']}")
        table.add_row("created", m.created_at.strftime("%Y-%m-%d %H:%M:%S UTC"))
        console.print(table)
        hp = Table(title="Hyperparameters")
        hp.add_column("name")
        hp.add_column("value", justify="right")
        skip = PPO_ONLY if m.algorithm == "sac" else SAC_ONLY
        for key, label in HP_LABELS.items():
            if key in m.hyperparameters and key not in skip:
                value = m.hyperparameters[key]
                hp.add_row(label, f"{value:g}" if isinstance(value, float) else str(value))
        console.print(hp)

    emit(data, render)


def _label(node: service.LineageNode, highlight: str | None) -> str:
    m = node.model
    text = f"{m.name} [dim]({m.status}, {m.track_name}, {m.algorithm})[/]"
    if m.parent_id is None and m.parent_name:
        text += f" [dim]cloned from {m.parent_name} (removed)[/]"
    return f"[bold yellow]{text}[/]" if m.name == highlight else text


def _tree(node: service.LineageNode, parent: Tree, highlight: str | None) -> None:
    branch = parent.add(_label(node, highlight))
    for child in node.children:
        _tree(child, branch, highlight)


@app.command("lineage")
@json_option
def lineage(
    name: Annotated[str | None, typer.Argument(help="Show only the clone tree holding this model.")] = None,
) -> None:
    """Draw the clone tree: which model was cloned from which.

    Example:

      drx model lineage my-second-model
    """
    roots = service.lineage(name)

    def render() -> None:
        if not roots:
            console.print("No models yet; create one with `drx model create`.")
            return
        for root in roots:
            tree = Tree(_label(root, name))
            for child in root.children:
                _tree(child, tree, name)
            console.print(tree)

    emit([r.to_dict() for r in roots], render)


@app.command("rm")
@json_option
def remove(
    name: Annotated[str, typer.Argument(help="The model's name.")],
    force: Annotated[
        bool, typer.Option("--force", help="Also remove a model that has clones (the clones are detached).")
    ] = False,
) -> None:
    """Remove a model with its jobs, checkpoints, metrics, evaluations and files.

    Refused while the model has a queued or running job, and while clones depend on it unless
    --force (the clones then keep their own settings and the parent's name for the record).

    Example:

      drx model rm my-first-model --force
    """
    detached = service.remove_model(name, force=force)

    def render() -> None:
        console.print(f"Removed model [bold]{name}[/].")
        if detached:
            console.print(f"Detached clones: {', '.join(detached)}.")

    emit({"removed": name, "detached": detached}, render)
