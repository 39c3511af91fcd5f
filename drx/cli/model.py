"""``drx model``: create, clone, list, show, lineage and rm."""

import sys
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table
from rich.tree import Tree

from drx.cli.app import group
from drx.cli.model_options import ModelOptions, model_options
from drx.cli.output import console, emit, json_option
from drx.cli.tables import Column, Wide, fitted_table, print_table
from drx.settings.car import simulator_label
from drx.settings.device import device_label
from drx.settings.episodes import DIRECTION_NAMES, DIRECTIONS, OPTION_KEYS
from drx.settings.hyperparameters import LABELS, PPO_ONLY, SAC_ONLY

if TYPE_CHECKING:  # SQLAlchemy loads in the commands that write or show: `model list` reads at once
    from drx.registry import Model
    from drx.registry.model_settings import ModelRecord
    from drx.services import models as service

app = group("Models: a car, a track and a reward function, with hyperparameters and stop conditions.")

# ----- options whose help differs between create and clone (the rest: drx.cli.model_options) -----
Car = Annotated[str | None, typer.Option(help="A garage car [default: default].")]
TrackOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--track",
        help="A track's route id or display name (`drx track list`) [default: oval]. Repeat it to train on "
        "several tracks: episodes take the tracks in turn (deepracer-for-cloud's multi-config training); "
        "the first is the model's track for evaluation.",
    ),
]
Reward = Annotated[
    str | None, typer.Option(help="A reward .py file or a sample name [default: follow_center_line].")
]


def _warn_race(m: "Model") -> None:
    """Race types the car serves poorly: a warning on stderr (the model is still created)."""
    from drx.services import models as service

    for sentence in service.race_warnings(m):
        sys.stderr.write(f"Warning: {sentence}\n")


def model_dict(m: "Model | ModelRecord") -> dict[str, Any]:
    """A model as JSON."""
    car = m.car_settings()
    return {
        "id": m.id,
        "name": m.name,
        "status": m.status,
        "description": m.description,
        "car": m.vehicle_name,
        "vehicle": m.vehicle().to_model_metadata(m.algorithm, car.simulator),
        "track": m.track_name,
        "direction": _direction(m),
        "tracks": [t.to_dict() for t in m.episode_settings().tracks],
        "training_options": _episodes_dict(m),
        "track_sha256": m.track_sha256,
        "reward_file": m.reward_filename,
        "reward_sha256": m.reward_sha256,
        "algorithm": m.algorithm,
        "hyperparameters": m.hyperparameters,
        "stop_conditions": m.stop_conditions,
        "race": m.race,
        **({"opponents": _opponent_names(m)} if m.race_config().opponents else {}),
        "domain_randomization": bool(m.domain_randomization),
        "rollout_workers": m.rollout_workers,
        "device": device_label(m.device),
        "simulator": car.simulator,
        "car_randomization": car.car_randomization,
        "recipe": m.recipe,
        "parent": m.parent_name,
        "parent_checkpoint_id": m.parent_checkpoint_id,
        "created_at": m.created_at,
    }


def _opponent_names(m: "Model | ModelRecord") -> list[str]:
    """A head-to-model model's opponents by name (the registry loads only for such a model)."""
    from drx.services.opponents import opponent_names

    return opponent_names(m.race_config())


def _direction(m: "Model | ModelRecord") -> str | None:
    """The way the model drives its (first) track: ``cw``, ``ccw``, or ``None`` for an open track or
    a model from before directions were recorded (its route's own)."""
    first = m.episode_settings().first
    return first.direction if first is not None and first.direction in DIRECTIONS else None


def _episodes_dict(m: "Model | ModelRecord") -> dict[str, Any]:
    """Where the model's training episodes start, as JSON (DeepRacer's options, drx's names)."""
    starts = m.episode_settings()
    return {key: getattr(starts, key) for key in OPTION_KEYS} | {"direction_asked": starts.direction}


def _tracks_label(m: "Model") -> str:
    """The model's tracks with their direction: ``reinvent_base (clockwise, reversed)``."""
    labels = []
    for t in m.episode_settings().tracks:
        shown = _track_label(t.name)
        if t.direction in DIRECTIONS:
            way = DIRECTION_NAMES[t.direction or ""]
            shown += f", driven {way} (reversed)" if t.reverse else f", {way}"
        labels.append(shown)
    return "; ".join(labels)


def _track_label(name: str) -> str:
    """A model's track as people know it: ``reInvent2019_wide_cw (A to Z Speedway (clockwise))``."""
    from drx.sim.track_names import display_name

    named = display_name(name)
    return f"{name} ({named})" if named else name


def _created(m: "Model", verb: str) -> None:
    def render() -> None:
        console.print(
            f"{verb} model [bold]{m.name}[/]: car {m.vehicle_name} ({m.vehicle().summary()}), "
            f"track {_tracks_label(m)} ({m.race_config().summary()}), reward {m.reward_filename}, "
            f"{m.algorithm.upper()}, simulator {m.car_settings().simulator}'s car, "
            f"stops after {m.stop_settings().describe()}."
        )

    emit(model_dict(m), render)


@app.command("create")
@json_option
@model_options
def create(
    name: Annotated[str, typer.Argument(help="Model name: up to 64 letters, digits, '-' and '_'.")],
    car: Car = None,
    track: TrackOpt = None,
    reward: Reward = None,
    algo: Annotated[
        str | None, typer.Option(help="ppo, or sac (continuous cars only) [default: ppo].")
    ] = None,
    network: Annotated[
        str | None, typer.Option(help="Override the car's network: shallow, deep, compact.")
    ] = None,
    domain_randomization: Annotated[
        bool,
        typer.Option(
            "--domain-randomization",
            help="Vary lighting and colours every training episode (DeepRacer's domain randomization).",
        ),
    ] = False,
    recipe: Annotated[
        str | None,
        typer.Option(
            help="Build the car, reward, algorithm, hyperparameters and stop condition for one --track "
            "from drx's racing line: race-pace (or race-pace-discrete, race-pace-continuous). Any other "
            "option overrides its choice; `drx model show` lists them and why.",
        ),
    ] = None,
    *,
    options: ModelOptions,
) -> None:
    """Create a model from a car, a track and a reward function.

    Hyperparameters take DeepRacer's names, ranges and defaults. Training stops at the first
    stop condition reached (default: 60 minutes).

    Example:

      drx model create my-model --car default --track oval --reward follow_center_line --max-minutes 10

      drx model create m2 --track "A to Z Speedway" --direction cw --reward follow_center_line

      drx model create everywhere --track reInvent2019_wide_cw --track jyllandsringen_pro_ccw

      drx model create boxes --car stereo-lidar --race-type object-avoidance --objects 3 --randomize-objects

      drx model create bots --car stereo-lidar --race-type head-to-bot --bots 2 --bot-speed 1.0

      drx model create chaser --race-type head-to-model --opponent steady

      drx model create fast --track "A to Z Speedway" --direction cw --recipe race-pace
    """
    from drx.services import models as service

    chosen: dict[str, Any] = {
        "car": car or service.garage.BUILTIN_CAR,
        "reward": reward or service.rewards.DEFAULT_REWARD,
        "algorithm": algo or "ppo",
        "hyperparameters": options.hyperparameters,
        "stop_conditions": options.stop_conditions,
    }
    if recipe is not None:
        from drx.recipes.apply import recipe_arguments

        chosen = recipe_arguments(
            recipe, name, tracks=track or [service.tracks.DEFAULT_TRACK], direction=options.direction,
            simulator=options.simulator, car=car, reward=reward, algorithm=algo,
            hyperparameters=options.hyperparameters, stop_conditions=options.stop_conditions,
        )  # fmt: skip
    m = service.create_model(
        name,
        track=track or [service.tracks.DEFAULT_TRACK],
        network=network,
        **chosen,
        description=options.description,
        race=options.race,
        domain_randomization=domain_randomization,
        check_reward=options.check_reward,
        rollout_workers=options.rollout_workers,
        direction=options.direction,
        episodes=options.episodes,
        device=options.device,
        simulator=options.simulator,
        car_randomization=bool(options.car_randomization),
    )
    _warn_race(m)
    _created(m, "Created")


@app.command("clone")
@json_option
@model_options
def clone(
    source: Annotated[str, typer.Argument(help="The model to clone.")],
    name: Annotated[str, typer.Argument(help="The new model's name.")],
    car: Annotated[
        str | None,
        typer.Option(help="Another garage car with the same action space size, sensors and network."),
    ] = None,
    track: Annotated[
        list[str] | None,
        typer.Option(
            "--track", help="Train on another track, or several (repeat it) [default: the parent's tracks]."
        ),
    ] = None,
    reward: Annotated[str | None, typer.Option(help="Another reward file [default: the parent's].")] = None,
    domain_randomization: Annotated[
        bool | None,
        typer.Option(
            "--domain-randomization/--no-domain-randomization",
            help="Vary lighting and colours every training episode [default: the parent's].",
            show_default=False,
        ),
    ] = None,
    *,
    options: ModelOptions,
) -> None:
    """Clone a model: the clone starts from the parent's trained weights, keeps its action space
    and algorithm, and records its parent. Anything not given is the parent's (race options
    replace the parent's race as a whole).

    Example:

      drx model clone my-first-model my-second-model --track kidney --lr 0.0001 --max-minutes 20

      drx model clone my-first-model other-way --direction counter-clockwise
    """
    from drx.services import models as service

    m = service.clone_model(
        source,
        name,
        car=car,
        track=track,
        reward=reward,
        hyperparameters=options.hyperparameters,
        stop_conditions=options.stop_conditions,
        description=options.description,
        race=options.race,
        domain_randomization=domain_randomization,
        check_reward=options.check_reward,
        rollout_workers=options.rollout_workers,
        direction=options.direction,
        episodes=options.episodes,
        device=options.device,
        simulator=options.simulator,
        car_randomization=options.car_randomization,
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
    from drx.services.model_list import list_models as rows

    models = rows()

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


@app.command("show")
@json_option
def show(name: Annotated[str, typer.Argument(help="The model's name.")]) -> None:
    """Show a model: car, track, reward, hyperparameters, stop conditions and lineage.

    Example:

      drx model show my-first-model
    """
    from drx.registry import session_scope
    from drx.services import models as service

    m = service.get_model(name)
    children = [n.name for n in service.list_models() if n.parent_id == m.id]
    with session_scope() as session:
        counts = service.model_counts(session, m.id)
        per_track = service.track_figures(session, m)
    data = {**model_dict(m), "clones": children, **counts, "track_figures": per_track}

    def render() -> None:
        v = m.vehicle()
        table = Table(show_header=False, title=f"Model {m.name}")
        table.add_column(style="bold")
        table.add_column()
        table.add_row("status", m.status)
        if m.description:
            table.add_row("description", m.description)
        table.add_row("car", f"{m.vehicle_name}: {v.summary()}")
        starts = m.episode_settings()
        table.add_row("tracks" if len(starts.tracks) > 1 else "track", _tracks_label(m))
        if len(starts.tracks) > 1:
            table.add_row("", "episodes take the tracks in turn; evaluation drives the first")
        table.add_row("direction", DIRECTION_NAMES.get(_direction(m) or "", "the route's own"))
        table.add_row("episode starts", starts.describe_starts())
        table.add_row("reward", f"{m.reward_filename} (sha256 {m.reward_sha256[:12]})")
        table.add_row("algorithm", m.algorithm.upper())
        table.add_row("stop conditions", m.stop_settings().describe())
        table.add_row("race", m.race_config().summary())
        if m.race_config().opponents:
            table.add_row("opponents", ", ".join(_opponent_names(m)) + " (best checkpoints)")
        table.add_row("domain randomization", "on (training)" if m.domain_randomization else "off")
        table.add_row("rollout workers", str(m.rollout_workers) if m.rollout_workers else "automatic")
        table.add_row("device", device_label(m.device) + ("" if m.device else " (a GPU if torch has one)"))
        table.add_row("simulator", simulator_label(m.car_settings()))
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
        for key, label in LABELS.items():
            if key in m.hyperparameters and key not in skip:
                value = m.hyperparameters[key]
                hp.add_row(label, f"{value:g}" if isinstance(value, float) else str(value))
        console.print(hp)
        if m.recipe:
            console.print(_recipe_table(m.recipe))
        if per_track:
            console.print(_track_table(per_track))

    emit(data, render)


def _recipe_table(recipe: dict[str, Any]) -> Table:
    """What the model's recipe chose and why; a choice the user overrode says so."""
    table = Table(title=f"Recipe {recipe.get('name')}: its choices")
    table.add_column("setting", style="bold", max_width=18)
    table.add_column("choice", max_width=22, overflow="fold")
    table.add_column("why", ratio=1)
    for c in recipe.get("choices", []):
        setting = str(c.get("setting"))
        why = "yours (given as an option)" if c.get("overridden") else str(c.get("why", ""))
        table.add_row(LABELS.get(setting, setting), str(c.get("value")), why)
    return table


def _num(value: float | None, spec: str, unit: str = "") -> str:
    return "-" if value is None else f"{value:{spec}}{unit}"


def _track_table(per_track: list[dict[str, Any]]) -> Table:
    """Each track's training so far: its episodes and its latest iteration's reward and progress."""
    table = Table(title="Training per track")
    for name, justify in (("track", "left"), ("episodes", "right"), ("iteration", "right"),
                          ("reward", "right"), ("progress", "right")):  # fmt: skip
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    for row in per_track:
        table.add_row(
            row["track"], str(row["episodes"]), _num(row["iteration"], "d"),
            _num(row["mean_reward"], ".1f"), _num(row["mean_progress"], ".0f", "%"),
        )  # fmt: skip
    return table


def _label(node: "service.LineageNode", highlight: str | None) -> str:
    m = node.model
    text = f"{m.name} [dim]({m.status}, {m.track_name}, {m.algorithm})[/]"
    if m.parent_id is None and m.parent_name:
        text += f" [dim]cloned from {m.parent_name} (removed)[/]"
    return f"[bold yellow]{text}[/]" if m.name == highlight else text


def _tree(node: "service.LineageNode", parent: Tree, highlight: str | None) -> None:
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
    from drx.services import models as service

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
    from drx.services import models as service

    detached = service.remove_model(name, force=force)

    def render() -> None:
        console.print(f"Removed model [bold]{name}[/].")
        if detached:
            console.print(f"Detached clones: {', '.join(detached)}.")

    emit({"removed": name, "detached": detached}, render)
