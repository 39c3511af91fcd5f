"""A training sink that stores each checkpoint's files before the registry hears of it.

The trainer writes ``last.zip`` (and ``best.zip``), the iteration's trace and the model's
metadata files locally, then calls ``on_checkpoint``. :class:`StoringSink` uploads them
first (traces and metadata, then ``best.zip``, then ``last.zip``: ``last`` names the newest
durable iteration, so it goes up last) and only then forwards the record, with the stored
paths, to the registry. A host killed in between leaves the registry at the previous
checkpoint, which is what the store holds; the next host resumes from there.
"""

from __future__ import annotations

from dataclasses import replace

from drx.storage.base import ArtifactStore
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary, TrainingSink

# What a checkpoint carries along besides the two checkpoint files.
COMPANIONS = ("training-simtrace", "ip", "reward_function.py")
LAST, BEST = "model/last.zip", "model/best.zip"


def push_checkpoint(store: ArtifactStore, name: str, is_best: bool) -> None:
    """Upload a new checkpoint of model ``name``: its companions, then ``best``, then ``last``."""
    if not store.remote:
        return
    model_files = [
        f"model/{p.name}"
        for p in (store.model_dir(name) / "model").glob("*")
        if p.is_file() and not p.name.startswith(".") and f"model/{p.name}" not in (LAST, BEST)
    ]
    store.push_tree(name, [*COMPANIONS, *model_files])  # the files changed since they were stored
    if is_best:
        store.push(name, BEST)
    store.push(name, LAST)


class StoringSink:
    """Forwards every record to ``inner``; a checkpoint only once its files are stored.

    :param inner: the sink that records (the registry's).
    :param store: the artifact store.
    :param name: the model trained.
    """

    def __init__(self, inner: TrainingSink, store: ArtifactStore, name: str) -> None:
        self.inner = inner
        self.store = store
        self.name = name

    def on_episode(self, record: EpisodeRecord) -> None:
        """Forward."""
        self.inner.on_episode(record)

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """Forward."""
        self.inner.on_iteration(summary, episodes)

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Store the checkpoint's files, then forward the record with their stored paths."""
        push_checkpoint(self.store, self.name, record.is_best)
        stored = replace(
            record,
            path=self.store.stored_path(self.name, record.path),
            best_path=self.store.stored_path(self.name, record.best_path) if record.best_path else None,
        )
        self.inner.on_checkpoint(stored)

    def on_step(self, steps: int) -> None:
        """Forward."""
        self.inner.on_step(steps)

    def stop_requested(self) -> bool:
        """Ask ``inner``."""
        return self.inner.stop_requested()

    def on_discard(self, iteration: int) -> None:
        """Forward."""
        self.inner.on_discard(iteration)

    def on_phase(self, phase: str, elapsed: float) -> None:
        """Forward (to an inner sink that hears phases)."""
        hook = getattr(self.inner, "on_phase", None)
        if hook is not None:
            hook(phase, elapsed)
