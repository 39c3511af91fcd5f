"""``--device``: the setting's spellings, what ``auto`` resolves to, a GPU this machine lacks, a
checkpoint written on a GPU loading here, and the same numbers on the CPU whichever way it is asked.

Everything runs on the CPU: CUDA is mocked for the resolution, and a "GPU checkpoint" is an SB3
zip whose tensors torch recorded as stored on ``cuda:0``.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
import torch as th
import torch.serialization

from drx.errors import SettingError
from drx.settings.device import DEVICE_ENV, check_device, job_device
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.train import device as device_module
from drx.train.algorithms import build_algorithm
from drx.train.checkpoint import load_weights, read_meta, save_checkpoint
from drx.train.device import auto_device, describe_device, resolve_device, torch_build
from drx.train.policy_weights import read_policy_weights
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car
from .dummy_env import CorridorEnv

ROOT = Path(__file__).resolve().parents[2]


# ----- the setting ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("given", "stored"),
    [(None, None), ("auto", None), (" AUTO ", None), ("cpu", "cpu"), ("CUDA", "cuda"), ("cuda:01", "cuda:1"),
     ("mps", "mps")],
)  # fmt: skip
def test_settings_are_stored_normalised(given: str | None, stored: str | None) -> None:
    assert check_device(given) == stored


@pytest.mark.parametrize("given", ["gpu", "cuda:", "cuda:x", "tpu", "cpu:0"])
def test_other_values_are_refused_naming_the_choices(given: str) -> None:
    with pytest.raises(SettingError, match="is not a device; use auto .*cpu, cuda, cuda:N") as info:
        check_device(given)
    assert info.value.field == "device" and repr(given) in str(info.value)


def test_a_job_s_device_the_worker_s_then_the_model_s() -> None:
    assert job_device(None, None, {}) is None  # auto
    assert job_device(None, "cpu", {}) == "cpu"
    assert job_device(None, "cpu", {DEVICE_ENV: "cuda:1"}) == "cuda:1"  # the worker's beats the model's
    assert job_device("auto", "cpu", {DEVICE_ENV: "cuda"}) is None  # the job's own, auto too, beats both
    with pytest.raises(SettingError, match=DEVICE_ENV):
        job_device(None, None, {DEVICE_ENV: "gpu"})


# ----- resolution ------------------------------------------------------------------------------
@contextmanager
def gpus(monkeypatch: pytest.MonkeyPatch, cuda: int, mps: bool = False) -> Iterator[None]:
    """torch sees ``cuda`` CUDA devices (and an Apple GPU with ``mps``), for resolution only."""
    monkeypatch.setattr(th.cuda, "is_available", lambda: cuda > 0)
    monkeypatch.setattr(th.cuda, "device_count", lambda: cuda)
    monkeypatch.setattr(th.backends.mps, "is_available", lambda: mps)
    monkeypatch.setattr(th.backends.mps, "is_built", lambda: mps)
    yield


def test_auto_picks_the_cpu_without_a_gpu(monkeypatch: pytest.MonkeyPatch) -> None:
    with gpus(monkeypatch, cuda=0):
        assert auto_device() == resolve_device(None) == resolve_device("auto") == "cpu"


def test_auto_picks_cuda_then_mps_when_torch_has_them(monkeypatch: pytest.MonkeyPatch) -> None:
    with gpus(monkeypatch, cuda=1, mps=True):
        assert resolve_device("auto") == "cuda"
        assert resolve_device("cuda:0") == "cuda:0"
        with pytest.raises(SettingError, match="finds 1 CUDA device"):
            resolve_device("cuda:1")
    with gpus(monkeypatch, cuda=0, mps=True):
        assert resolve_device(None) == "mps"


def test_a_gpu_this_machine_lacks_is_one_sentence_naming_the_value_and_the_fix(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with gpus(monkeypatch, cuda=0):
        for asked in ("cuda", "cuda:1", "mps"):
            with pytest.raises(SettingError) as info:
                resolve_device(asked)
            text = info.value.worded(lambda field: "--" + field)
            assert text.startswith(f"--device {asked}: this machine has no ")
            assert f"torch {th.__version__}" in text and "use --device cpu or auto" in text
            assert "\n" not in text


def test_torch_s_build_is_read_without_importing_it() -> None:
    """The CLI asks before torch loads: a CPU-only build says "no GPU" at once, and refuses cuda."""
    code = (
        "import sys; from drx.train.device import auto_device, resolve_device, torch_build\n"
        "build = torch_build(); print(build.version)\n"
        "if build.gpu_toolkit is None:\n"
        "    assert auto_device() == 'cpu'\n"
        "    try: resolve_device('cuda')\n"
        "    except Exception as exc: print(exc)\n"
        "print('torch' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == th.__version__ == torch_build().version  # type: ignore[union-attr]
    assert lines[-1] == "False"  # torch never loaded
    if th.version.cuda is None:
        assert "built without CUDA" in lines[1] and "install torch's CUDA build" in lines[1]


def test_describe_names_the_device_and_torch_s_build() -> None:
    text = describe_device("cpu")
    assert text.startswith("cpu (torch ") and th.__version__ in text
    if th.version.cuda is None:
        assert text == f"cpu (torch {th.__version__}, no CUDA)"


# ----- checkpoints written on a GPU ------------------------------------------------------------
@contextmanager
def stored_on_cuda(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """``torch.save`` records every tensor as stored on ``cuda:0``, as it does on a GPU."""
    with monkeypatch.context() as patch:
        patch.setattr(torch.serialization, "location_tag", lambda storage: "cuda:0")
        yield


@pytest.mark.parametrize("algorithm", ["ppo", "sac"])
def test_a_checkpoint_trained_on_cuda_loads_on_the_cpu(
    algorithm: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    car = compact_car(continuous=algorithm == "sac")
    hp = Hyperparameters.default(algorithm)
    trained = build_algorithm(CorridorEnv(car), car.network, hp, seed=3)
    path = tmp_path / "last.zip"
    with stored_on_cuda(monkeypatch):
        save_checkpoint(trained, path, {"device": "cuda:0", "network": car.network, "algorithm": algorithm})
    with zipfile.ZipFile(path) as zf:
        raw = zf.read("policy.pth")
    with pytest.raises(RuntimeError, match="CUDA"):  # the file really says cuda: a plain load fails here
        th.load(io.BytesIO(raw), weights_only=True)

    fresh = build_algorithm(CorridorEnv(car), car.network, hp, seed=4, device="cpu")
    load_weights(fresh, path)  # resuming or cloning: SB3's set_parameters, mapped to the model's device
    want, got = trained.policy.state_dict(), fresh.policy.state_dict()
    assert all(got[k].device.type == "cpu" and th.equal(got[k], want[k]) for k in want)
    weights = read_policy_weights(path)  # drx evaluate, exports, analyses: weights only, on the CPU
    assert all(w.device.type == "cpu" and th.equal(w, want[k]) for k, w in weights.items())
    assert read_meta(path)["device"] == "cuda:0"


# ----- the same numbers on the CPU --------------------------------------------------------------
def _run(corridor_spec: SpecFactory, folder: Path, device: str | None) -> tuple[list[float], dict]:
    spec = corridor_spec(folder=folder, stop=StopConditions(max_minutes=None, max_episodes=5))
    spec.device = device
    trainer = Trainer(spec)
    result = trainer.run()
    figures = [s.policy_loss or 0.0 for s in result.summaries] + [float(result.steps)]
    weights = {k: v.detach().numpy().copy() for k, v in trainer.model.policy.state_dict().items()}
    return figures, weights


def test_cpu_results_are_the_same_asked_as_cpu_or_auto(
    corridor_spec: SpecFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(th.cuda, "is_available", lambda: False)  # auto is the CPU here, as on a laptop
    on_cpu = _run(corridor_spec, tmp_path / "cpu", "cpu")
    on_auto = _run(corridor_spec, tmp_path / "auto", None)
    assert on_cpu[0] == on_auto[0]
    assert all(np.array_equal(on_cpu[1][k], on_auto[1][k]) for k in on_cpu[1])
    assert read_meta(tmp_path / "auto" / "model" / "last.zip")["device"] == "cpu"


def test_the_trainer_refuses_a_gpu_it_lacks_before_building_anything(
    corridor_spec: SpecFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(th.cuda, "is_available", lambda: False)
    spec = corridor_spec(folder=tmp_path / "m")
    spec.device = "cuda"
    with pytest.raises(SettingError, match="device cuda: this machine has no CUDA device"):
        Trainer(spec)
    assert not (tmp_path / "m" / "model").exists()


def test_the_module_imports_no_torch_itself() -> None:
    """drx.train.device is what `drx info` and the CLI's checks import: torch loads in its functions."""
    source = Path(device_module.__file__).read_text()
    assert "\nimport torch" not in source and "\nfrom torch" not in source
