"""``drx model export --for-deepracer``: a drx model as DeepRacer's model folder.

The folder (:mod:`drx.interchange.deepracer.folder_files`) is what deepracer-for-cloud takes as a
pretrained model or uploads, and what DeepRacer on AWS imports. Its checkpoint is DeepRacer's
two-tower ``shallow`` network (:mod:`drx.interchange.deepracer.deepracer_weights`):

- a model on ``shallow`` is written tensor for tensor (a shared trunk into both towers);
- a model on drx's ``compact`` network (the default) is first **distilled** into ``shallow``
  (:mod:`drx.interchange.deepracer.distill`), since DeepRacer's simulator builds no other network here.

Then the written checkpoint is read back from disk and raced in drx's time trial beside the
original, with the same seed, so the export's laps are those of the files it wrote, not of the
weights in memory. Everything is written to a temporary folder first; the destination (a
folder, a ``.tar.gz``, or ``s3://bucket/prefix``) receives it only when all of it is there.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from drx.errors import DrxError
from drx.interchange.deepracer import deepracer_weights as weights
from drx.interchange.deepracer import folder_files as files
from drx.interchange.deepracer.locations import check_destination, place
from drx.interchange.deepracer.tensor_bundle import read_bundle, write_bundle
from drx.vehicle import Vehicle

Progress = Callable[[str], None]


class Course(Protocol):
    """The time trial an export races on (drx's evaluation, a layer above: the CLI passes
    :meth:`drx.evaluate.course.TimeTrialCourse.for_model` as ``course_for``)."""

    @property
    def checkpoint_path(self) -> Path: ...

    @property
    def iteration(self) -> int | None: ...

    def make_env(self) -> Any: ...

    def race(self, driver: Callable[[Any], Any]) -> Any: ...


CourseFor = Callable[..., Course]  # (model, which, *, laps, seed, time_cap_minutes) -> Course
DEFAULT_DISTILL_SECONDS = 300.0
LAP_CAP_MINUTES = 3.0  # [min] of simulated time a lap of the export's time trials may take


@dataclass(frozen=True)
class Laps:
    """A time trial's laps, as the export reports them."""

    completed: int
    laps: int
    fastest: float | None
    mean: float | None
    off_track: int

    def to_dict(self) -> dict[str, Any]:
        return {"completed": self.completed, "laps": self.laps, "fastest": self.fastest, "mean": self.mean,
                "off_track": self.off_track}  # fmt: skip


@dataclass
class FolderExport:
    """What ``drx model export --for-deepracer`` wrote and how the export drives."""

    destination: str
    model: str
    checkpoint: str  # DeepRacer's name, N_Step-M.ckpt
    iteration: int | None
    network: str  # the model's own network
    files: list[str]
    size_bytes: int
    seconds: float
    original: Laps | None = None
    exported: Laps | None = None
    distillation: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "destination": self.destination, "model": self.model, "checkpoint": self.checkpoint,
            "iteration": self.iteration, "network": self.network, "files": self.files,
            "size_bytes": self.size_bytes, "seconds": round(self.seconds, 2),
            "original_laps": self.original.to_dict() if self.original else None,
            "exported_laps": self.exported.to_dict() if self.exported else None,
            "distillation": self.distillation, "notes": self.notes,
        }  # fmt: skip


def _laps(result: Any) -> Laps:
    done = [lap for lap in result.laps if lap.time is not None]
    times = [float(lap.time) for lap in done]
    return Laps(
        completed=len(done),
        laps=len(result.laps),
        fastest=min(times) if times else None,
        mean=float(np.mean(times)) if times else None,
        off_track=sum(lap.off_track_count for lap in result.laps),
    )


def _driver(policy: Any) -> Callable[[Any], Any]:
    def drive(observation: Any) -> Any:
        action, _ = policy.predict(observation, deterministic=True)
        return action

    return drive


def _episodes(model_id: int) -> list[files.EpisodeMetric]:
    """The model's training and evaluation episodes, in the order they were driven."""
    from sqlalchemy import select

    from drx.registry import Episode, session_scope

    with session_scope() as session:
        # training before evaluation within an iteration, as DeepRacer's metrics interleave them
        order = (Episode.iteration, Episode.phase.desc(), Episode.episode)
        rows = session.scalars(select(Episode).where(Episode.model_id == model_id).order_by(*order)).all()
        return [
            files.EpisodeMetric(
                phase=row.phase,
                reward=row.reward,
                progress=row.progress,
                status=row.status,
                seconds=float(row.lap_time) if row.lap_time else row.steps / 15.0,
            )  # fmt: skip
            for row in rows
        ]


def export_deepracer(
    name: str,
    out: str,
    which: str = "best",
    *,
    course_for: CourseFor,
    seed: int = 0,
    laps: int = 3,
    distill_seconds: float = DEFAULT_DISTILL_SECONDS,
    on_progress: Progress | None = None,
) -> FolderExport:
    """Write model ``name`` as DeepRacer's model folder to ``out`` and race the export.

    :param out: a new (or empty) folder, a path ending ``.tar.gz``, or ``s3://bucket/prefix``.
    :param which: ``best``, ``last`` or an iteration number.
    :param course_for: the time trial of a model's checkpoint (:class:`Course`).
    :param seed: the time trials' (and the distillation's) seed.
    :param laps: laps of each time trial (0: race nothing).
    :param distill_seconds: the longest a compact model's distillation may take.
    :raises DrxError: unknown model, no checkpoint, a car or algorithm DeepRacer's folder cannot hold,
        a bad destination; nothing is written then.
    """
    from drx.registry import RewardSource, session_scope
    from drx.services.models import get_model
    from drx.train.checkpoint import read_meta
    from drx.train.policy_weights import build_policy, load_policy_weights

    say = on_progress or (lambda _text: None)
    started = time.monotonic()
    check_destination(out)
    model = get_model(name)
    vehicle = model.vehicle()
    weights.check_exportable(vehicle, model.algorithm)
    if vehicle.network == "deep":
        raise DrxError("DeepRacer's model folder export takes the shallow and compact networks, not deep.")
    # DeepRacer's rules, capped at LAP_CAP_MINUTES a lap: a model that has not lapped by then is not racing
    cap = min(20.0, LAP_CAP_MINUTES * max(1, laps))
    course = course_for(name, str(which), laps=max(1, laps), seed=seed, time_cap_minutes=cap)
    if course.checkpoint_path.suffix == ".pb":
        raise DrxError(f"Model {name!r} is an imported car file (model.pb) with no weights to export.")
    meta = read_meta(course.checkpoint_path)
    teacher = load_policy_weights(course.checkpoint_path, vehicle, "ppo")
    shallow = replace(vehicle, network="shallow")
    result = FolderExport(destination=out, model=name, checkpoint="", iteration=course.iteration,
                          network=vehicle.network, files=[], size_bytes=0, seconds=0.0)  # fmt: skip
    if laps:
        say("racing the original")
        result.original = _laps(course.race(_driver(teacher)))
    value_scale = float((meta.get("return_scale") or {}).get("rms") or 1.0)
    if vehicle.network == "shallow":
        student = teacher
    else:
        from drx.interchange.deepracer.distill import distill_policy

        say(f"distilling the {vehicle.network} network into DeepRacer's shallow network")
        student, report = distill_policy(
            teacher,
            vehicle,
            course.make_env,
            seed=seed,
            max_seconds=distill_seconds,
            on_progress=say,
        )
        result.distillation = report.to_dict()
    tensors = weights.policy_tensors(student, shallow, value_scale)
    ckpt = files.checkpoint_name(course.iteration or 0, int(meta.get("steps") or 0))
    result.checkpoint = ckpt
    with session_scope() as session:
        reward_code = session.get_one(RewardSource, model.reward_sha256).code
    with tempfile.TemporaryDirectory(prefix="drx-deepracer-") as tmp:
        folder = Path(tmp) / "model-folder"
        say("writing the folder")
        _write_folder(folder, model, shallow, ckpt, tensors, meta, reward_code)
        if laps:
            say("racing the export, read back from its files")
            back = build_policy(shallow, "ppo", "separate")
            read = read_bundle(folder / "model" / ckpt)
            weights.check_tensor_set({k: v.shape for k, v in read.items()}, shallow, ckpt)
            back.load_state_dict(weights.policy_state(read, shallow), strict=True)
            back.set_training_mode(False)
            trial = course.race(_driver(back))
            result.exported = _laps(trial)
        result.files = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
        result.size_bytes = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
        place(folder, out)
    if _not_deepracer(model.track_name):
        result.notes.append(
            f"Track {model.track_name!r} is not one of DeepRacer's; pick a DeepRacer track there "
            "(training_params.yaml names it as WORLD_NAME)."
        )
    result.seconds = time.monotonic() - started
    return result


def _not_deepracer(track_name: str) -> bool:
    from drx.services.tracks import find_track

    return find_track(track_name).source != "deepracer"


def _write_folder(
    folder: Path,
    model: Any,
    shallow: Vehicle,
    ckpt: str,
    tensors: dict[str, np.ndarray],
    meta: dict[str, Any],
    reward_code: str,
) -> None:
    """Every file of DeepRacer's model folder, into ``folder``."""
    (folder / "model").mkdir(parents=True)
    (folder / "ip").mkdir()
    (folder / "metrics" / "training").mkdir(parents=True)
    # "version": the simulator whose car the model trained on, which DeepRacer on AWS and
    # deepracer-for-cloud race it on alike (launch/racecar.launch.py picks the physics by version >= 5)
    metadata = files.dumps(shallow.to_model_metadata("ppo", model.car_settings().simulator))
    hyper = files.dumps(model.hyperparameter_settings().to_deepracer_json(model.stop_settings().max_episodes))
    starts = model.episode_settings()  # the first track is WORLD_NAME (one file names one world)
    params = files.training_params(
        model.name,
        model.track_name,
        model.race_config(),
        change_start=starts.change_start_position,
        alternate_direction=starts.alternate_direction,
        round_robin_advance=starts.round_robin_advance,
        start_position_offset=starts.start_position_offset,
        reverse=bool(starts.first and starts.first.reverse),
    )
    texts = {
        files.METADATA: metadata,
        files.MODEL_METADATA: metadata,
        files.REWARD: reward_code,
        files.TRAINING_PARAMS: files.to_yaml(params),
        files.HYPERPARAMETERS: hyper,
        files.IP_HYPERPARAMETERS: hyper,
        files.COACH_CHECKPOINT: ckpt,
        files.DEEPRACER_CHECKPOINTS: files.dumps(
            files.deepracer_checkpoints(ckpt, meta.get("eval_progress"), meta.get("sim_time"))
        ),
        f"metrics/training/training-{time.strftime('%Y%m%d%H%M%S')}-{model.name}.json": json.dumps(
            files.training_metrics(_episodes(model.id))
        ),
    }
    for rel, text in texts.items():
        (folder / rel).write_text(text, encoding="utf-8")
    write_bundle(folder / "model" / ckpt, tensors)


