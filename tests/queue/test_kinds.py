"""The one table of job kinds: each has a runner, a worker claims each, an unknown kind is refused."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from typer.testing import CliRunner

from drx.cli.main import app
from drx.errors import DrxError
from drx.queue import lifecycle
from drx.queue.dispatch import runner_for
from drx.queue.kinds import KINDS, job_kind
from drx.registry import Job, Model, session_scope
from drx.registry.testing import snapshot
from drx.services.models import get_model

MakeModel = Callable[..., Model]


def test_every_kind_names_a_runner_that_imports() -> None:
    assert set(KINDS) == {"train", "evaluate"}
    for name in KINDS:
        assert callable(runner_for(name)), name
    assert job_kind("train").trains_model and not job_kind("evaluate").trains_model


def test_a_worker_claims_every_kind_oldest_first_and_only_training_moves_the_model(
    make_model: MakeModel,
) -> None:
    model = make_model("m")
    with session_scope() as session:
        evaluation = lifecycle.enqueue(session, model.id, "evaluate", {"model": "m"})
    assert get_model("m").status == "draft"  # an evaluation leaves its model alone
    training = lifecycle.enqueue_training("m")
    assert get_model("m").status == "queued"
    worker = lifecycle.new_worker_id()
    first, second = lifecycle.claim_next(worker), lifecycle.claim_next(worker)
    assert first is not None and second is not None
    assert [(j.id, j.kind, j.max_attempts) for j in (first, second)] == [
        (evaluation.id, "evaluate", 3),
        (training.id, "train", 3),
    ]
    assert get_model("m").status == "training"


def test_an_unknown_kind_is_refused_and_nothing_changes(make_model: MakeModel) -> None:
    model = make_model("m")
    with session_scope() as session, pytest.raises(DrxError, match="'dance' is unknown"):
        lifecycle.enqueue(session, model.id, "dance")
    with session_scope() as session:  # a row another drx version wrote
        session.add(Job(model_id=model.id, kind="dance", status="queued", options={}))
    job_id = lifecycle.list_jobs()[0][0].id
    assert lifecycle.claim_next(lifecycle.new_worker_id()) is None  # no worker takes it
    before = snapshot()
    result = CliRunner().invoke(app, ["job", "run", str(job_id)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "Job kind 'dance' is unknown" in result.output
    assert snapshot() == before
