"""Which checkpoint of a model to use: ``best``, ``last`` or an iteration (what ``drx evaluate``
drives and ``drx model export`` packs), or an imported DeepRacer model's one graph."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from sqlalchemy import select

from drx.errors import DrxError, SettingError
from drx.registry import Checkpoint, Model, session_scope
from drx.services.models import model_artifacts_dir
from drx.storage import get_store
from drx.storage.base import MODEL_FILES
from drx.train.checkpoint import checkpoint_path, read_meta

IMPORTED_GRAPH = "model.pb"  # what `drx model import` keeps of a DeepRacer model package


@dataclass(frozen=True)
class ChosenCheckpoint:
    """The checkpoint an evaluation drives.

    :param path: the checkpoint file.
    :param iteration: its training iteration.
    :param row_id: its ``checkpoints`` row, when it has one.
    :param which: what the user asked for (``best``, ``last`` or an iteration).
    """

    path: Path
    iteration: int | None
    row_id: int | None
    which: str


def choose_checkpoint(model: Model, which: str = "best") -> ChosenCheckpoint:
    """The checkpoint of ``model`` named by ``which``: ``best``, ``last`` or an iteration number.

    drx keeps two files per model, ``best.zip`` and ``last.zip``; an iteration
    number must be one of theirs.

    :raises DrxError: the model has no checkpoint, or not that one.
    """
    folder = model_artifacts_dir(model.name)
    get_store().pull_tree(model.name, MODEL_FILES)  # trained on another host: its files come from the store
    with session_scope() as session:
        rows = list(
            session.scalars(
                select(Checkpoint).where(Checkpoint.model_id == model.id).order_by(Checkpoint.iteration)
            )
        )
    files = {k: checkpoint_path(folder, k) for k in ("best", "last")}
    present = {k: p for k, p in files.items() if p.is_file()}
    graph = folder / "model" / IMPORTED_GRAPH
    if not present and graph.is_file():  # an imported DeepRacer model: one graph, no checkpoints
        row = rows[-1] if rows else None
        if which not in ("best", "last", str(row.iteration if row else "")):
            raise DrxError(f"Model {model.name!r} is an imported DeepRacer model with one graph; use best.")
        return ChosenCheckpoint(graph, row.iteration if row else None, row.id if row else None, which)
    if not present:
        raise DrxError(
            f"Model {model.name!r} has no checkpoint yet; train it first with `drx train {model.name}`."
        )
    if which in ("best", "last"):
        path = present.get(which) or present.get("last" if which == "best" else "best")
        assert path is not None
        iteration = _iteration(path)
        return ChosenCheckpoint(path, iteration, _row_id(rows, iteration), which)
    try:
        wanted = int(which)
    except ValueError:
        raise SettingError(
            "{field} {value!r} is invalid; use best, last or an iteration number.", "checkpoint", value=which
        ) from None
    for path in present.values():
        if _iteration(path) == wanted:
            return ChosenCheckpoint(path, wanted, _row_id(rows, wanted), which)
    kept = sorted({it for p in present.values() if (it := _iteration(p)) is not None})
    raise DrxError(
        f"Model {model.name!r} has no checkpoint of iteration {wanted} on disk; drx keeps the best and the "
        f"last ({', '.join(map(str, kept)) or 'none'})."
    )


def _iteration(path: Path) -> int | None:
    value = read_meta(path).get("iteration")
    return None if value is None else int(value)


def _row_id(rows: list[Checkpoint], iteration: int | None) -> int | None:
    for row in rows:
        if row.iteration == iteration:
            return row.id
    return None
