"""Several writers at once: read-then-write transactions wait for each other instead of failing."""

from __future__ import annotations

import threading

import pytest
from sqlalchemy import func, select

from drx.registry import Job, session_scope
from drx.registry.testing import external_test_url
from drx.services import models

WRITERS = 4
TRANSACTIONS = 15


def test_concurrent_read_then_write_transactions_all_succeed() -> None:
    if external_test_url() is not None:  # the PostgreSQL run (registry_backend)
        pytest.skip("checks SQLite's locking")
    model_id = models.create_model("busy").id
    errors: list[BaseException] = []

    def writer(worker: int) -> None:
        try:
            for _ in range(TRANSACTIONS):
                with session_scope() as s:
                    # Read, then write in the same transaction: a claim-like pattern.
                    n = s.scalar(select(func.count(Job.id)).where(Job.model_id == model_id))
                    s.add(Job(model_id=model_id, kind="train", worker_id=f"w{worker}", options={"seen": n}))
        except BaseException as exc:  # collected and reported below
            errors.append(exc)

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(WRITERS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors, errors
    with session_scope() as s:
        jobs = s.scalars(select(Job)).all()
        assert len(jobs) == WRITERS * TRANSACTIONS
        # Serialised: every transaction saw all the rows committed before it.
        assert sorted(j.options["seen"] for j in jobs) == list(range(WRITERS * TRANSACTIONS))
