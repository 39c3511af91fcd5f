"""``--device`` on ``drx model create|clone``, ``drx train`` and ``drx worker``; the device in
``drx info``, ``drx model show`` and ``drx jobs show``. CUDA is mocked away: a GPU is never used."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from typing import Any

import pytest
import torch

from drx.queue import lifecycle
from drx.registry import Job, Model, session_scope
from drx.settings.device import DEVICE_ENV

from .helpers import fails_unchanged, ok, ok_json

NO_CUDA = ("no CUDA device torch can use", "use --device cpu or auto")


@pytest.fixture(autouse=True)
def _no_gpu(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """This machine has no GPU (whatever it has), and no worker set a device."""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    monkeypatch.setattr(torch.backends.mps, "is_available", lambda: False)
    monkeypatch.delenv(DEVICE_ENV, raising=False)
    yield


def test_the_setting_is_stored_inherited_and_shown() -> None:
    assert ok_json("model", "create", "auto")["device"] == "auto"
    assert ok_json("model", "create", "cpu", "--device", "CPU")["device"] == "cpu"
    assert ok_json("model", "clone", "cpu", "kid")["device"] == "cpu"  # the parent's
    assert ok_json("model", "clone", "cpu", "kid2", "--device", "auto")["device"] == "auto"
    shown = ok("model", "show", "auto").stdout
    assert "device" in shown and "auto (a GPU if torch has one)" in shown
    assert ok_json("model", "show", "kid")["device"] == "cpu"


@pytest.mark.parametrize("asked", ["cuda", "cuda:1", "mps"])
def test_a_gpu_this_machine_lacks_is_refused_and_nothing_is_stored_or_queued(asked: str) -> None:
    fails_unchanged("model", "create", "m", "--device", asked, contains=(f"--device {asked}: this machine",))
    ok("model", "create", "m")
    fails_unchanged("model", "clone", "m", "kid", "--device", asked, contains=f"--device {asked}:")
    for detach in ((), ("--detach",)):
        err = fails_unchanged("train", "m", "--device", asked, *detach, contains=f"--device {asked}: ")
        assert "this machine has no" in err
    if asked.startswith("cuda") and torch.version.cuda is None:
        fails_unchanged("train", "m", "--device", asked, contains=(*NO_CUDA, "install torch's CUDA build"))


def test_a_value_that_is_no_device_is_refused() -> None:
    fails_unchanged("model", "create", "m", "--device", "gpu", contains=("--device 'gpu' is not a device",))
    ok("model", "create", "m")
    fails_unchanged("train", "m", "--device", "tpu", "--detach", contains="cuda:N")


def test_a_model_set_to_a_gpu_trains_here_only_with_another_device() -> None:
    ok("model", "create", "m")
    with session_scope() as session:  # made on a machine with a GPU
        session.query(Model).filter(Model.name == "m").one().device = "cuda"
    fails_unchanged("train", "m", "--detach", contains=("--device cuda:", *NO_CUDA))
    ok_json("train", "m", "--device", "cpu", "--detach")
    assert lifecycle.get_job(1).options["device"] == "cpu"
    lifecycle.request_stop(1)
    ok_json("train", "m", "--device", "auto", "--detach")  # auto given: it overrides the model's
    assert lifecycle.get_job(2).options["device"] == "auto"


def test_a_job_that_asks_for_a_gpu_here_fails_with_the_sentence() -> None:
    """What a worker without the GPU does with a job queued elsewhere: the job fails, in one sentence."""
    from drx.queue.dispatch import run_job

    ok("model", "create", "m")
    job = lifecycle.enqueue_training("m", {"device": "cuda:0"})
    outcome = run_job(job.id)
    assert outcome.status == "failed"
    assert outcome.error is not None and outcome.error.startswith("device cuda:0: this machine has no CUDA")
    assert lifecycle.get_job(job.id).device is None  # it never trained


def test_the_worker_passes_its_device_to_its_jobs(monkeypatch: pytest.MonkeyPatch) -> None:
    from drx.queue import worker as worker_module

    fails_unchanged("worker", "--device", "cuda", "--exit-when-idle", contains=NO_CUDA)
    ok("model", "create", "m")
    job = lifecycle.enqueue_training("m")
    seen: dict[str, Any] = {}

    class Launched:
        pid = 4242

        def __init__(self, cmd: list[str], **kwargs: Any) -> None:
            seen.update(kwargs["env"])

    monkeypatch.setattr(subprocess, "Popen", Launched)
    events: list[str] = []
    runner = worker_module.Worker(device="cuda:1", on_event=events.append)
    assert lifecycle.claim(job.id, runner.worker_id)
    runner.launch(lifecycle.get_job(job.id))
    assert seen[DEVICE_ENV] == "cuda:1"


def test_info_and_jobs_show_name_the_device() -> None:
    data = ok_json("info")["device"]
    assert data["device"] == "cpu" and data["description"].startswith(f"cpu (torch {torch.__version__}")
    assert data["torch"] == torch.__version__ and data["environment"] is None
    assert "device (auto)" in ok("info").stdout
    ok("model", "create", "m")
    job = lifecycle.enqueue_training("m")
    with session_scope() as session:  # what the runner records when the job starts
        session.get_one(Job, job.id).device = "cuda:0 (NVIDIA A10G)"
    assert ok_json("jobs", "show", str(job.id))["device"] == "cuda:0 (NVIDIA A10G)"
    assert "cuda:0 (NVIDIA A10G)" in ok("jobs", "show", str(job.id)).stdout
