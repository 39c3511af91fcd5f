"""Checkpoint files: SB3 model zips with drx's run state inside, written atomically.

A checkpoint is one file: the zip that SB3's ``save()`` writes (policy and
optimizer state) with one more member, ``drx.json``, holding the run's
counters (iteration, steps, episodes, elapsed time, target streak) and the
evaluation figures used to pick the best. It is written to a temporary file
in the same folder, flushed to disk and moved over the old one with
``os.replace``, so a reader (or a resumed run after ``kill -9``) sees either
the previous checkpoint or the new one, never half of one.

The model folder follows deepracer-for-cloud's layout::

    <model>/model/model_metadata.json   the car, as DeepRacer describes it
    <model>/model/last.zip              the checkpoint after the latest iteration
    <model>/model/best.zip              the best by evaluation progress, then lap time
    <model>/ip/hyperparameters.json     DeepRacer's hyperparameters file
    <model>/training-simtrace/<i>-iteration.csv
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drx.atomic import fsync_dir
from drx.errors import DrxError, NotFoundError
from drx.storage import artifacts_dir

if TYPE_CHECKING:  # annotations only: reading a checkpoint's metadata needs no torch
    from stable_baselines3.common.base_class import BaseAlgorithm

META_MEMBER = "drx.json"
LAST = "last.zip"
BEST = "best.zip"


def model_folder(model_name: str) -> Path:
    """The artifacts folder of a model: ``$DRX_HOME/artifacts/models/<name>``.

    The same folder as :func:`drx.services.models.model_artifacts_dir` (which removes it with the model).
    """
    return artifacts_dir() / "models" / model_name


def checkpoint_path(folder: Path, which: str = "last") -> Path:
    """``<folder>/model/last.zip`` or ``best.zip``."""
    return Path(folder) / "model" / (BEST if which == "best" else LAST)


def save_checkpoint(model: BaseAlgorithm, path: Path, meta: dict[str, Any]) -> Path:
    """Save ``model`` and ``meta`` to ``path`` atomically.

    :param model: the SB3 algorithm.
    :param path: the checkpoint file (``.zip``).
    :param meta: run state stored as ``drx.json`` inside the zip.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp.zip")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        model.save(tmp)
        with zipfile.ZipFile(tmp, "a") as zf:
            zf.writestr(META_MEMBER, json.dumps(meta, sort_keys=True))
        with tmp.open("rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
        fsync_dir(path.parent)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def read_meta(path: Path) -> dict[str, Any]:
    """The ``drx.json`` run state stored in a checkpoint (``{}`` for a plain SB3 zip)."""
    path = Path(path)
    if not path.is_file():
        raise NotFoundError(f"Checkpoint {path} does not exist.")
    try:
        with zipfile.ZipFile(path) as zf:
            if META_MEMBER not in zf.namelist():
                return {}
            return dict(json.loads(zf.read(META_MEMBER)))
    except zipfile.BadZipFile as exc:
        raise DrxError(f"Checkpoint {path} is not a valid checkpoint file ({exc}).") from exc


def load_weights(model: BaseAlgorithm, path: Path) -> None:
    """Load a checkpoint's policy (and optimizer) state into ``model``.

    :raises DrxError: the checkpoint was made for another network or action space.
    """
    path = Path(path)
    if not path.is_file():
        raise NotFoundError(f"Checkpoint {path} does not exist.")
    try:
        model.set_parameters(str(path), exact_match=True, device=model.device)
    except (RuntimeError, ValueError, KeyError) as exc:
        raise DrxError(
            f"Checkpoint {path} does not fit this model's network or action space; "
            f"clone only models with the same car ({str(exc).splitlines()[0]})."
        ) from exc


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Delete temporary files a killed run left in a model folder (never a finished checkpoint).

    Only one run trains a model at a time, so any temporary file found when a run starts is a
    leftover of a run that died while writing.
    """
    removed = []
    for sub in ("model", "ip"):
        for path in (Path(folder) / sub).glob(".*.tmp*"):
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed


def is_better(progress: float, lap_time: float | None, best: dict[str, Any] | None) -> bool:
    """Whether an evaluation (mean progress, mean lap time) beats the best so far.

    Higher progress wins; at equal progress a shorter lap time wins (a time beats no time).
    """
    if best is None:
        return True
    best_progress = float(best.get("eval_progress") or 0.0)
    if progress > best_progress + 1e-9:
        return True
    if progress < best_progress - 1e-9:
        return False
    best_time = best.get("eval_lap_time")
    if lap_time is None:
        return False
    return best_time is None or lap_time < float(best_time)
