"""The small files of DeepRacer's model folder, written from a drx model and read back.

The layout is the one deepracer-for-cloud uploads (``scripts/upload/upload-model.sh``) and
DeepRacer on AWS imports (aws-solutions/deepracer-on-aws ``source/docs/import/README.md``),
checked against the real console folder in ``../shared/deepracer-models/``::

    model_metadata.json            the car (DeepRacer on AWS reads the root copy)
    reward_function.py             the reward, as the user wrote it
    training_params.yaml           track, direction, race type, start positions
    hyperparameters.json           deepracer-for-cloud's importer reads the root copy
    ip/hyperparameters.json        the console's and DeepRacer on AWS's copy
    metrics/training/training-<time>-<name>.json   per-episode training metrics
    model/model_metadata.json      the copy the simulator's evaluation reads
    model/.coach_checkpoint        the checkpoint's name, ``N_Step-M.ckpt``
    model/deepracer_checkpoints.json   best and last checkpoint, with their evaluation metric
    model/N_Step-M.ckpt.index      the weights (drx.interchange.deepracer.tensor_bundle)
    model/N_Step-M.ckpt.data-00000-of-00001

There is deliberately no TensorFlow ``checkpoint`` file: where one exists the simulator's restore
follows TensorFlow's own lookup instead of ``.coach_checkpoint``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from drx.errors import DrxError
from drx.settings.race import RaceConfig

METADATA = "model_metadata.json"
REWARD = "reward_function.py"
TRAINING_PARAMS = "training_params.yaml"
HYPERPARAMETERS = "hyperparameters.json"
IP_HYPERPARAMETERS = "ip/hyperparameters.json"
MODEL_METADATA = "model/model_metadata.json"
COACH_CHECKPOINT = "model/.coach_checkpoint"
DEEPRACER_CHECKPOINTS = "model/deepracer_checkpoints.json"
DATA_SUFFIX = ".data-00000-of-00001"
METRICS_VERSION = 2.0  # deepracer-simapp bundle/markov/metrics/constants.py
CHECKPOINT_NAME = re.compile(r"^(\d+)_Step-(\d+)\.ckpt$")
RACE_TYPES = {
    "time-trial": "TIME_TRIAL",
    "object-avoidance": "OBJECT_AVOIDANCE",
    "head-to-bot": "HEAD_TO_BOT",
    "head-to-model": "HEAD_TO_MODEL",  # deepracer-for-cloud's name (docs/head-to-head.md)
}


def checkpoint_name(iteration: int, steps: int) -> str:
    """DeepRacer's checkpoint name, ``N_Step-M.ckpt``: the checkpoint's number and the agent's steps
    (rl_coach's ``{checkpoint_id}_Step-{steps}.ckpt``)."""
    return f"{int(iteration)}_Step-{int(steps)}.ckpt"


def deepracer_checkpoints(name: str, eval_progress: float | None, elapsed: float | None) -> dict[str, Any]:
    """``deepracer_checkpoints.json`` naming one checkpoint as both best and last (an export holds one):
    its mean evaluation progress [%] and the simulated seconds of training [s], as simapp's
    ``TrainingMetrics.update`` writes them."""
    entry = {
        "name": name,
        "avg_eval_metric": float(eval_progress or 0.0),
        "time_stamp": float(elapsed or 0.0),
    }
    return {"best_checkpoint": entry, "last_checkpoint": dict(entry)}


def world_and_direction(route_id: str) -> tuple[str, bool | None]:
    """``WORLD_NAME`` and ``TRACK_DIRECTION_CLOCKWISE`` for a route id.

    The console names a two-way track without its ``_cw``/``_ccw`` suffix and says the direction
    apart; the simulator then drives ``WORLD_NAME + "_cw"`` or ``"_ccw"`` whenever the key is
    present (deepracer-simapp ``bundle/markov/boto/s3/files/yaml_file.py``, ``_update_world_name``).
    So a one-way track (``reinvent_base``, with no ``reinvent_base_ccw`` route) gets no direction
    (``None``: leave the key out), and DeepRacer on AWS drives it its own way.
    """
    from drx.sim.track_names import split_direction

    base, direction = split_direction(route_id)
    return (base, direction == "cw") if direction is not None else (route_id, None)


def training_params(
    model_name: str,
    route_id: str,
    race: RaceConfig,
    *,
    change_start: bool = True,
    alternate_direction: bool = False,
    round_robin_advance: float = 0.05,
    start_position_offset: float = 0.0,
    reverse: bool = False,
) -> dict[str, Any]:
    """The training settings DeepRacer reads from ``training_params.yaml`` (keys as the console's file,
    ``../shared/deepracer-models/console-2023-continuous-shallow/training_params.yaml``).

    The start options are the simulator's (deepracer-simapp ``bundle/markov/rollout_worker.py`` reads
    ``CHANGE_START_POSITION``, ``ALTERNATE_DRIVING_DIRECTION``, ``ROUND_ROBIN_ADVANCE_DIST`` and
    ``START_POSITION_OFFSET``; deepracer-for-cloud's ``scripts/training/prepare-config.py`` writes
    them from its ``DR_TRAIN_*`` settings), from a model's
    :class:`~drx.settings.episodes.EpisodeSettings`.

    :param route_id: the route the model trained on (``reInvent2019_wide_cw``); a model training on
        several tracks gives its first (its track for evaluation): one file names one world.
    :param reverse: the route was driven against its waypoints' order (a direction it has no
        ``_cw``/``_ccw`` variant for): ``REVERSE_DIR``, which the simulator's ``track_data.py`` reads
        (deepracer-for-cloud's ``DR_TRAIN_REVERSE_DIRECTION``).
    """
    world, cw = world_and_direction(route_id)
    params: dict[str, Any] = {"JOB_TYPE": "TRAINING", "WORLD_NAME": world}
    if cw is not None:  # an unquoted YAML boolean: DeepRacer on AWS compares it with `=== true`
        params["TRACK_DIRECTION_CLOCKWISE"] = cw
    if reverse:
        params["REVERSE_DIR"] = True
    params |= {
        "CHANGE_START_POSITION": change_start,
        "ALTERNATE_DRIVING_DIRECTION": alternate_direction,
        "ROUND_ROBIN_ADVANCE_DIST": float(round_robin_advance),
        "START_POSITION_OFFSET": float(start_position_offset),
        "RACE_TYPE": RACE_TYPES[race.race_type],
        "MODEL_NAME": model_name,
        "METRIC_NAME": "TrainingRewardScore",
        "METRIC_NAMESPACE": "AWSDeepRacer",
        "VIDEO_JOB_TYPE": "TRAINING",
        "CAR_COLOR": "Black",
        "BODY_SHELL_TYPE": "deepracer",
    }
    if race.race_type == "object-avoidance":
        params["NUMBER_OF_OBSTACLES"] = race.objects or len(race.object_positions) or 3
        params["OBSTACLE_TYPE"] = "BOX_OBSTACLE"
        params["RANDOMIZE_OBSTACLE_LOCATIONS"] = race.randomize_objects
        if race.object_positions:
            params["OBJECT_POSITIONS"] = [
                f"{fraction:.4f},{1 if lane == 'inside' else -1}" for fraction, lane in race.object_positions
            ]
    elif race.race_type == "head-to-bot":
        params["NUMBER_OF_BOT_CARS"] = race.bots or 3
        params["BOT_CAR_SPEED"] = race.bot_speed if race.bot_speed is not None else 0.2
        params["IS_LANE_CHANGE"] = race.bot_lane_change
    return params


def to_yaml(params: dict[str, Any]) -> str:
    """``training_params.yaml`` text: one ``KEY: value`` a line, booleans as YAML booleans."""
    import yaml

    return "---\n" + yaml.safe_dump(params, sort_keys=False, default_flow_style=False)


def read_yaml(text: str, source: str) -> dict[str, Any]:
    """A ``training_params.yaml``'s keys (a mapping), or one sentence saying why not."""
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise DrxError(f"{source} is not valid YAML ({str(exc).splitlines()[0]}).") from exc
    if not isinstance(data, dict):
        raise DrxError(f"{source} holds no KEY: value settings; it is not a training_params.yaml.")
    return data


def yaml_bool(value: Any) -> bool:
    """A setting written as a YAML boolean or as the string ``"true"``/``"false"`` (the console quotes
    ``TRACK_DIRECTION_CLOCKWISE``)."""
    if isinstance(value, bool):
        return value
    return str(value).strip().lower() in ("true", "1", "yes")


@dataclass(frozen=True)
class EpisodeMetric:
    """One episode as DeepRacer's training metrics JSON holds it."""

    phase: str  # training | evaluation
    reward: float
    progress: float
    status: str
    seconds: float  # simulated episode time


STATUS_WORDS = {
    "lap_complete": "Lap complete",
    "off_track": "Off track",
    "crashed": "Crashed",
    "reversed": "Reversed",
    "immobilized": "Immobilized",
    "time_up": "Time Up",
    "in_progress": "In progress",
}


def training_metrics(episodes: list[EpisodeMetric]) -> dict[str, Any]:
    """DeepRacer's training metrics (``metrics/training/training-*.json``), as deepracer-simapp's
    ``bundle/markov/metrics/s3_metrics.py`` writes them (metrics version 2.0): one entry per
    episode, times in milliseconds of the simulation clock (drx's episodes' simulated times laid
    end to end); ``episode`` counts training episodes, ``trial`` restarts with each iteration's
    training, and evaluation entries repeat the last training episode's numbers.

    :param episodes: in the order they were driven, each iteration's training before its evaluation.
    """
    rows = []
    clock = 0.0
    episode = trial = 0
    previous_phase = "evaluation"
    for e in episodes:
        if e.phase == "training":
            trial = 1 if previous_phase == "evaluation" else trial + 1
            episode += 1
        previous_phase = e.phase
        start = clock
        clock += max(0.0, e.seconds) * 1000.0
        rows.append(
            {
                "reward_score": int(round(e.reward)),
                "metric_time": int(round(clock)),
                "start_time": int(round(start)),
                "elapsed_time_in_milliseconds": int(round(clock - start)),
                "episode": episode,
                "trial": trial,
                "phase": e.phase,
                "completion_percentage": int(round(e.progress)),
                "episode_status": STATUS_WORDS.get(e.status, e.status),
            }
        )
    return {"metrics": rows, "version": METRICS_VERSION, "best_model_metric": "progress"}


def dumps(data: Any) -> str:
    """JSON as DeepRacer's files are read: plain, indented, a final newline."""
    return json.dumps(data, indent=4) + "\n"
