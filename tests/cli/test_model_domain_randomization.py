"""``--domain-randomization``: stored with the model, shown, inherited by clones, exported, and
turned on for training episodes only."""

from __future__ import annotations

import json
import tarfile
from pathlib import Path

from .helpers import ok, ok_json


def test_off_by_default_on_when_asked_shown_and_inherited() -> None:
    assert ok_json("model", "create", "plain")["domain_randomization"] is False
    assert "domain randomization" in ok("model", "show", "plain").stdout
    m = ok_json("model", "create", "robust", "--domain-randomization")
    assert m["domain_randomization"] is True
    shown = ok("model", "show", "robust").stdout
    assert "domain randomization" in shown and "on (training)" in shown
    assert ok_json("model", "show", "robust")["domain_randomization"] is True
    assert ok_json("model", "clone", "robust", "robust2")["domain_randomization"] is True
    assert (
        ok_json("model", "clone", "robust", "calm", "--no-domain-randomization")["domain_randomization"]
        is False
    )
    assert (
        ok_json("model", "clone", "plain", "made-robust", "--domain-randomization")["domain_randomization"]
        is True
    )


def test_training_envs_randomise_evaluation_envs_do_not() -> None:
    from drx.queue import lifecycle
    from drx.queue.train_job import build_spec
    from drx.services.models import get_model

    ok("model", "create", "robust", "--domain-randomization", "--network", "compact")
    ok("model", "create", "plain", "--network", "compact")
    for name, expected in (("robust", True), ("plain", False)):
        spec = build_spec(lifecycle.get_job(lifecycle.enqueue_training(name, {}).id), get_model(name))
        training, evaluation = spec.env_factory("training"), spec.env_factory("evaluation")
        # the training env is the model's schedule of tracks (drx.sim.schedule); its episodes' simulator:
        assert training.unwrapped.current.unwrapped.domain_randomization is expected
        assert evaluation.unwrapped.domain_randomization is False
        training.close()
        evaluation.close()


def test_export_records_it_and_import_restores_it(tmp_path: Path) -> None:
    """DeepRacer's model_metadata.json has no field for it (deepracer-for-cloud keeps it in the
    run's training_params.yaml as ENABLE_DOMAIN_RANDOMIZATION), so the package's manifest does."""
    from drx.interchange.package.model_package import MANIFEST, METADATA, export_model
    from drx.queue import lifecycle
    from drx.queue.dispatch import run_job

    ok("model", "create", "robust", "--domain-randomization", "--network", "compact", "--max-episodes", "5",
       "--episodes-per-iteration", "5")  # fmt: skip
    assert run_job(lifecycle.enqueue_training("robust", {"eval_episodes": 1}).id).status == "succeeded"
    out, _ = export_model("robust", tmp_path / "robust.tar.gz")
    with tarfile.open(out) as tar:
        manifest = json.load(tar.extractfile(MANIFEST))  # type: ignore[arg-type]
        metadata = json.load(tar.extractfile(METADATA))  # type: ignore[arg-type]
    assert manifest["model"]["domain_randomization"] is True
    assert "domain_randomization" not in json.dumps(metadata).lower()
    ok("model", "import", str(out), "--name", "robust-again")
    assert ok_json("model", "show", "robust-again")["domain_randomization"] is True
