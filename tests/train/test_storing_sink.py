"""The order a checkpoint's files are stored in: everything else, then ``best``, then ``last``,
and only then the registry's row (so a host killed in between leaves both at the previous one)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from drx.storage.base import ArtifactStore
from drx.train.records import CheckpointRecord, NullSink
from drx.train.storing_sink import StoringSink


class Recording(ArtifactStore):
    """A remote-looking store that writes down what is pushed, in order."""

    remote = True

    def __init__(self, root: Path, events: list[str]) -> None:
        super().__init__("s3://bucket/p", root)
        self.events = events

    def push(self, name: str, *relpaths: str) -> None:
        self.events.extend(f"push {r}" for r in relpaths)

    def push_tree(self, name: str, subs: Iterable[str] | None = None) -> None:
        folder = self.model_dir(name)
        for sub in subs or [""]:
            base = folder / sub
            files = [base] if base.is_file() else sorted(p for p in base.rglob("*") if p.is_file())
            self.events.extend(f"push {self.relpath(name, p)}" for p in files)

    def stored_path(self, name: str, path: Path | str) -> str:
        return f"s3://bucket/p/models/{name}/{self.relpath(name, path)}"


class Registry(NullSink):
    def __init__(self, events: list[str]) -> None:
        self.events = events
        self.records: list[CheckpointRecord] = []

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        self.events.append("registry row")
        self.records.append(record)


def test_last_goes_up_last_and_the_row_after_it(tmp_path: Path) -> None:
    events: list[str] = []
    store = Recording(tmp_path, events)
    folder = store.model_dir("m")
    for rel in ("model/last.zip", "model/best.zip", "model/model_metadata.json", "ip/hyperparameters.json",
                "training-simtrace/0-iteration.csv", "reward_function.py"):  # fmt: skip
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_text(rel)
    registry = Registry(events)
    sink = StoringSink(registry, store, "m")
    record = CheckpointRecord(
        iteration=0, path=str(folder / "model/last.zip"), steps=10, episodes=5, eval_progress=50.0,
        eval_lap_time=None, is_best=True, best_path=str(folder / "model/best.zip"),
    )  # fmt: skip
    sink.on_checkpoint(record)
    assert events[-3:] == ["push model/best.zip", "push model/last.zip", "registry row"]
    assert set(events[:-3]) == {
        "push training-simtrace/0-iteration.csv", "push ip/hyperparameters.json",
        "push reward_function.py", "push model/model_metadata.json",
    }  # fmt: skip
    stored = registry.records[0]
    assert stored.path == "s3://bucket/p/models/m/model/last.zip"
    assert stored.best_path == "s3://bucket/p/models/m/model/best.zip"

    events.clear()
    sink.on_checkpoint(CheckpointRecord(**{**record.__dict__, "is_best": False, "best_path": None}))
    assert "push model/best.zip" not in events and events[-2:] == ["push model/last.zip", "registry row"]


class PhaseShowing(NullSink):
    def __init__(self) -> None:
        self.phases: list[tuple[str, float]] = []

    def on_phase(self, phase: str, elapsed: float) -> None:
        self.phases.append((phase, elapsed))


def test_wrapping_sinks_pass_phases_on(tmp_path: Path) -> None:
    """The progress line and the watch page show the run's phase through any wrapper."""
    from drx.sweep.trial import PruningSink, SweepTrial

    shown = PhaseShowing()
    storing = StoringSink(shown, Recording(tmp_path, []), "m")
    storing.on_phase("sampling episodes", 1.5)
    pruning = PruningSink(storing, SweepTrial.__new__(SweepTrial))  # no study: on_phase only forwards
    pruning.on_phase("updating the policy: epoch 1/3", 2.0)
    assert shown.phases == [("sampling episodes", 1.5), ("updating the policy: epoch 1/3", 2.0)]
    StoringSink(NullSink(), Recording(tmp_path, []), "m").on_phase("saving", 3.0)  # no hook: no error
