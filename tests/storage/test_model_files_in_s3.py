"""A model's whole life with its files in an S3-compatible bucket, across data homes (hosts)
that share a registry: train on one, analyse, export, import, clone and remove on others."""

from __future__ import annotations

from pathlib import Path

import pytest
from sqlalchemy import select

from drx.analysis.data import model_folder
from drx.interchange.importers.model_import import import_file
from drx.interchange.package.model_package import export_model
from drx.queue import lifecycle
from drx.queue.dispatch import run_job
from drx.queue.train_job import build_spec
from drx.registry import Checkpoint, session_scope
from drx.registry.engine import dispose_engines
from drx.services.models import clone_model, create_model, get_model, remove_model
from drx.storage import get_store, reset_stores


def _host(monkeypatch: pytest.MonkeyPatch, home: Path) -> None:
    monkeypatch.setenv("DRX_HOME", str(home))
    reset_stores()


def _paths(name: str) -> list[str]:
    model_id = get_model(name).id
    with session_scope() as s:
        return list(s.scalars(select(Checkpoint.path).where(Checkpoint.model_id == model_id)))


def test_train_here_analyse_export_import_clone_and_remove_there(
    s3_artifacts: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DRX_DATABASE_URL", f"sqlite:///{tmp_path / 'shared.db'}")  # the shared registry
    dispose_engines()
    _host(monkeypatch, tmp_path / "host-a")
    create_model(
        "m", track="oval", network="compact",
        hyperparameters={"episodes_per_iteration": 5}, stop_conditions={"max_episodes": 5},
    )  # fmt: skip
    assert run_job(lifecycle.enqueue_training("m", {"eval_episodes": 1, "seed": 1}).id).status == "succeeded"
    stored = set(get_store().listing("m", ""))
    assert {
        "model/last.zip", "model/best.zip", "model/model_metadata.json", "ip/hyperparameters.json",
        "reward_function.py", "training-simtrace/0-iteration.csv",
    } <= stored  # fmt: skip
    assert _paths("m") and all(p.startswith(f"{s3_artifacts}/models/m/model/") for p in _paths("m"))

    _host(monkeypatch, tmp_path / "host-b")  # analyses read the traces, fetched into B's cache
    folder = model_folder("m")
    assert folder.is_relative_to(tmp_path / "host-b")
    assert (folder / "training-simtrace" / "0-iteration.csv").stat().st_size > 100
    out, manifest = export_model("m", tmp_path / "m.tar.gz")
    assert manifest["checkpoint"]["iteration"] == 0
    assert "exports/m.tar.gz" in get_store().listing("m", "exports")  # a copy in the bucket
    import_file(out, name="m2")
    assert "model/best.zip" in get_store().listing("m2", "model")
    assert all(p.startswith(f"{s3_artifacts}/models/m2/") for p in _paths("m2"))

    _host(monkeypatch, tmp_path / "host-c")  # a clone starts from its parent's stored best
    clone = clone_model("m", "c")
    spec = build_spec(lifecycle.enqueue_training("c"), clone)
    assert spec.init_checkpoint is not None and spec.init_checkpoint.is_relative_to(tmp_path / "host-c")
    assert spec.init_checkpoint.read_bytes() == (folder / "model" / "best.zip").read_bytes()

    remove_model("m2")  # from yet another host: the objects go, wherever they were written
    assert get_store().listing("m2", "") == []
