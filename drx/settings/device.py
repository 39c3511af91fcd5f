"""Which torch device a model trains on: the ``device`` setting (no torch here).

``auto`` (stored as ``None``) picks the machine's GPU when torch can use one, else the CPU
(:func:`drx.train.device.resolve_device`); ``cpu``, ``cuda``, ``cuda:N`` (the GPU with index N)
and ``mps`` (Apple's GPU) ask for one. A job's device is, first to last: its own ``drx train
--device``, the worker's (``drx worker --device``, which its jobs read from ``$DRX_DEVICE``), the
model's setting, ``auto`` (:func:`job_device`). Whether this machine can use the device asked
for is the trainer's question (it needs torch).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping

from drx.errors import SettingError

AUTO = "auto"
DEVICE_ENV = "DRX_DEVICE"  # set by `drx worker --device` for the jobs it launches
DEVICE_HELP = "auto (a GPU torch can use, else the CPU), cpu, cuda, cuda:N (GPU number N) or mps (Apple GPU)"
_DEVICE = re.compile(r"(cpu|mps|cuda(:\d{1,3})?)")


def check_device(value: str | None, field: str = "device") -> str | None:
    """``value`` as drx stores it: ``None`` for ``auto`` (or nothing), else ``cpu``, ``cuda``,
    ``cuda:N`` or ``mps`` in lower case.

    :param field: the setting that gave it, for the message (``device``, ``DRX_DEVICE``).
    :raises SettingError: anything else.
    """
    if value is None:
        return None
    text = str(value).strip().lower()
    if text in ("", AUTO):
        return None
    if not _DEVICE.fullmatch(text):
        raise SettingError(
            "{field} {value!r} is not a device; use {allowed}.", field, value=value, allowed=DEVICE_HELP
        )
    if text.startswith("cuda:"):
        text = f"cuda:{int(text[5:])}"  # cuda:01 is cuda:1
    return text


def job_device(
    job_option: str | None, model_setting: str | None, environ: Mapping[str, str] | None = None
) -> str | None:
    """The device setting a training job runs with (``None``: auto): the job's ``--device``, else
    the worker's (``$DRX_DEVICE``), else the model's; the first one given wins, ``auto`` included.

    The worker's beats the model's: it says what the machine it runs on has (``drx worker
    --device cuda:1`` on a host with two GPUs, ``--device cpu`` to leave a GPU to something else).

    :raises SettingError: a value is not a device (``$DRX_DEVICE`` named as such).
    """
    env = os.environ if environ is None else environ
    if job_option:  # given, even as auto: this job's choice
        return check_device(job_option)
    if env.get(DEVICE_ENV):
        return check_device(env[DEVICE_ENV], DEVICE_ENV)
    return check_device(model_setting)


def device_label(setting: str | None) -> str:
    """A device setting as people read it: ``auto`` for ``None``."""
    return setting or AUTO
