"""The torch device a training runs on: ``auto`` resolved on this machine, a GPU asked for checked.

Where each part runs (docs/TRAINING.md, "Device"):

- the update (SB3's ``device=``, :func:`drx.train.algorithms.build_algorithm`) on the job's device;
- the episodes the trainer's own process samples (one rollout worker, and SAC) and its
  evaluation episodes, with the same policy on the same device: one copy of the weights, none
  made per iteration, and only the action comes back each step (on a GPU a batch of one mostly
  costs kernel launches; ``benchmarks/gpu_throughput.py`` times the forward pass on both);
- rollout worker processes (``--rollout-workers K``, K > 1) on their CPU, one thread each, with
  the weights copied from the device once per iteration (:meth:`drx.train.rollout.RolloutWorkers.set_policy`):
  K processes would each hold a CUDA context (hundreds of MB) to run batches of one;
- ``drx evaluate``, exports and analyses on the CPU (:mod:`drx.train.policy_weights` maps
  every tensor there), so a race's result does not depend on the machine that runs it.

This module imports torch only when its answer could be a GPU: reading torch's version file
tells a CPU-only build (``2.13.0+cpu``) without importing it, so ``drx info`` stays quick.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drx.errors import SettingError
from drx.settings.device import DEVICE_ENV, check_device

DOCS = 'docs/TRAINING.md, "Device"'


@dataclass(frozen=True)
class TorchBuild:
    """Which torch is installed: its version and the GPU toolkit it was built for.

    :param version: ``2.13.0+cpu``, ``2.13.0+cu126``...
    :param cuda: the CUDA version it was built with (``None``: no CUDA).
    :param hip: the ROCm (HIP) version it was built with (``None``: no ROCm).
    """

    version: str
    cuda: str | None = None
    hip: str | None = None

    @property
    def gpu_toolkit(self) -> str | None:
        """``CUDA 12.6`` or ``ROCm 6.2`` when built for one, else ``None``."""
        if self.cuda:
            return f"CUDA {self.cuda}"
        return f"ROCm {self.hip}" if self.hip else None

    def describe(self) -> str:
        """``torch 2.13.0+cpu, no CUDA`` or ``torch 2.13.0+cu126, CUDA 12.6``."""
        return f"torch {self.version}, {self.gpu_toolkit or 'no CUDA'}"


def torch_build() -> TorchBuild | None:
    """The installed torch's build: from torch itself once it is imported, else read from its
    ``version.py`` without importing it (``None`` when that file cannot be read)."""
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "version"):
        return TorchBuild(str(torch.__version__), torch.version.cuda, getattr(torch.version, "hip", None))
    try:
        spec = importlib.util.find_spec("torch")
        if spec is None or spec.origin is None:
            return None
        tree = ast.parse((Path(spec.origin).parent / "version.py").read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError, ImportError):
        return None
    found: dict[str, Any] = {}
    for node in tree.body:  # `cuda = '12.6'`, `cuda: Optional[str] = None`...
        value: ast.expr | None
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target, value = node.targets[0], node.value
        elif isinstance(node, ast.AnnAssign):
            target, value = node.target, node.value
        else:
            continue
        if isinstance(target, ast.Name) and isinstance(value, ast.Constant):
            found[target.id] = value.value
    version = found.get("__version__")
    if not isinstance(version, str):
        return None
    return TorchBuild(version, found.get("cuda") or None, found.get("hip") or None)


def _gpu_possible() -> bool:
    """Whether torch could find a GPU here: torch is loaded (ask it), a CUDA or ROCm build, an
    unreadable build, or macOS (MPS). False only for a CPU-only build elsewhere."""
    if "torch" in sys.modules or sys.platform == "darwin":
        return True
    build = torch_build()
    return build is None or build.gpu_toolkit is not None


def _mps_usable() -> bool:
    import torch

    mps = getattr(torch.backends, "mps", None)
    return bool(mps is not None and mps.is_available() and mps.is_built())


def auto_device() -> str:
    """What ``auto`` means on this machine: ``cuda`` when torch can use a CUDA (or ROCm) GPU, else
    ``mps`` when it can use Apple's, else ``cpu``."""
    if not _gpu_possible():
        return "cpu"
    import torch

    if torch.cuda.is_available():
        return "cuda"
    return "mps" if _mps_usable() else "cpu"


def resolve_device(setting: str | None, field: str = "device") -> str:
    """The torch device a device setting means here: :func:`auto_device` for ``auto`` (``None``),
    else the setting once torch can use it.

    :param setting: ``auto``/``None``, ``cpu``, ``cuda``, ``cuda:N`` or ``mps``.
    :param field: the setting that gave it, for the message.
    :raises SettingError: not a device, or one this machine does not have (the sentence says
        which torch is installed and what to use instead).
    """
    device = check_device(setting, field)
    if device is None:
        return auto_device()
    if device == "cpu":
        return device
    build = torch_build()
    torch_text = f"torch {build.version}" if build else "torch"
    if device == "mps":
        if not (_gpu_possible() and _mps_usable()):
            raise SettingError(
                "{field} {value}: this machine has no Apple GPU torch can use ({torch}); use {field} cpu "
                "or auto.",
                field,
                value=device,
                torch=torch_text,
            )
        return device
    if build is not None and build.gpu_toolkit is None and "torch" not in sys.modules:
        raise _no_cuda(device, field, f"{torch_text} is built without CUDA", install=True)
    import torch

    if not torch.cuda.is_available():
        if not torch.version.cuda and not getattr(torch.version, "hip", None):
            raise _no_cuda(device, field, f"{torch_text} is built without CUDA", install=True)
        raise _no_cuda(device, field, f"{torch_text} finds none; see nvidia-smi and CUDA_VISIBLE_DEVICES")
    count = int(torch.cuda.device_count())
    index = int(device.partition(":")[2] or 0)
    if index >= count:
        raise SettingError(
            "{field} {value}: torch finds {count} CUDA device(s) here, cuda:0 to cuda:{last}; use one of "
            "them, or {field} auto.",
            field,
            value=device,
            count=count,
            last=count - 1,
        )
    return device


def _no_cuda(device: str, field: str, why: str, install: bool = False) -> SettingError:
    fix = ", or install torch's CUDA build ({docs})" if install else ""
    return SettingError(
        "{field} {value}: this machine has no CUDA device torch can use ({why}); use {field} cpu or auto"
        + fix
        + ".",
        field,
        value=device,
        why=why,
        docs=DOCS,
    )


def device_label(device: str) -> str:
    """A resolved device as the dashboard and ``drx jobs show`` name it: ``cpu``, ``mps``, or a
    CUDA device with its number and name, ``cuda:0 (NVIDIA A10G)``."""
    if not device.startswith("cuda"):
        return device
    import torch

    index = int(device.partition(":")[2]) if ":" in device else int(torch.cuda.current_device())
    try:
        name = str(torch.cuda.get_device_name(index))
    except (RuntimeError, AssertionError):  # no such device (a label for a record, not a check)
        return f"cuda:{index}"
    return f"cuda:{index} ({name})"


def describe_device(device: str) -> str:
    """A resolved device with torch's build: ``cpu (torch 2.13.0+cpu, no CUDA)``,
    ``cuda:0 (NVIDIA A10G; torch 2.13.0+cu126, CUDA 12.6)``."""
    build = torch_build()
    torch_text = build.describe() if build else "torch of unknown build"
    label = device_label(device)
    if label.endswith(")"):  # cuda:0 (NVIDIA A10G) -> cuda:0 (NVIDIA A10G; torch ...)
        return f"{label[:-1]}; {torch_text})"
    return f"{label} ({torch_text})"


def device_facts() -> dict[str, Any]:
    """What ``drx info`` reports: the device ``auto`` picks here (``device``, with ``description``),
    torch's version and GPU toolkit, the CUDA devices torch finds (``[]`` without torch imported
    on a CPU-only build: there are none), and ``$DRX_DEVICE`` (``environment``: what a job here
    trains on unless it names a device itself)."""
    device = auto_device()
    build = torch_build()
    gpus: list[str] = []
    if "torch" in sys.modules:
        import torch

        if torch.cuda.is_available():
            gpus = [str(torch.cuda.get_device_name(i)) for i in range(torch.cuda.device_count())]
    return {
        "device": device,
        "description": describe_device(device),
        "torch": build.version if build else None,
        "cuda": build.cuda if build else None,
        "rocm": build.hip if build else None,
        "cuda_devices": gpus,
        "environment": os.environ.get(DEVICE_ENV) or None,
    }
