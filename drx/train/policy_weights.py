"""A checkpoint's policy rebuilt from the car and its weights only: no pickle is ever read.

An SB3 checkpoint zip holds ``data`` (JSON whose spaces, schedules and classes are
cloudpickled: loading it with SB3's ``load_from_zip_file`` runs whatever the pickles
say) and ``policy.pth`` (a state dict). drx never reads ``data``: the policy's class,
spaces and network are rebuilt from the car (:class:`drx.vehicle.Vehicle`) and the
algorithm, exactly as :func:`drx.train.algorithms.build_algorithm` builds them for
training, and ``policy.pth`` is read with ``torch.load(weights_only=True)``, which
refuses anything but tensors and plain containers. A checkpoint from someone else is
therefore only numbers; it cannot run code here.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path
from typing import Any

import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticCnnPolicy, BasePolicy, MultiInputActorCriticPolicy
from stable_baselines3.common.preprocessing import is_image_space, is_image_space_channels_first
from stable_baselines3.common.vec_env import VecTransposeImage
from stable_baselines3.sac.policies import CnnPolicy as SACCnnPolicy
from stable_baselines3.sac.policies import MultiInputPolicy as SACMultiInputPolicy

from drx.errors import DrxError
from drx.train.checkpoint import read_meta
from drx.train.networks import policy_kwargs_for
from drx.vehicle import Vehicle

POLICY_MEMBER = "policy.pth"
MAX_POLICY_BYTES = 256 << 20  # [bytes] drx's largest network (deep, stereo + lidar) is ~10 MB


def env_spaces(vehicle: Vehicle) -> tuple[spaces.Space, spaces.Space]:
    """The training env's observation and action spaces for ``vehicle`` (from a small env on the oval)."""
    from drx.sim.env import DeepRacerEnv

    env = DeepRacerEnv(track="oval", vehicle=vehicle)
    return env.observation_space, env.action_space


def _channel_first(space: spaces.Space) -> spaces.Space:
    """The space as SB3's policy sees it (``VecTransposeImage`` puts image channels first)."""
    if isinstance(space, spaces.Dict):
        return spaces.Dict({k: _channel_first(v) for k, v in space.spaces.items()})
    if is_image_space(space) and not is_image_space_channels_first(space):  # type: ignore[arg-type]
        return VecTransposeImage.transpose_space(space)  # type: ignore[arg-type]
    return space


def build_policy(vehicle: Vehicle, algorithm: str, towers: str = "shared") -> BasePolicy:
    """An untrained policy of the class and shape training builds for this car and algorithm.

    :param towers: PPO's ``shared`` trunk or DeepRacer's ``separate`` towers
        (:data:`drx.settings.hyperparameters.TOWERS`); SAC ignores it.
    """
    obs_space, action_space = env_spaces(vehicle)
    kwargs: dict[str, Any] = policy_kwargs_for(vehicle.network, obs_space)
    multi = isinstance(obs_space, spaces.Dict)
    if algorithm == "sac":
        if not isinstance(action_space, spaces.Box):
            raise DrxError("SAC trains continuous cars only; this car has discrete actions.")
        cls: type[BasePolicy] = SACMultiInputPolicy if multi else SACCnnPolicy
        kwargs["net_arch"] = {"pi": [64], "qf": [256]}
    elif algorithm == "ppo":
        cls = MultiInputActorCriticPolicy if multi else ActorCriticCnnPolicy
        kwargs["net_arch"] = []
        kwargs["share_features_extractor"] = towers == "shared"
    else:
        raise DrxError(f"Algorithm {algorithm!r} is unknown; use ppo or sac.")
    return cls(_channel_first(obs_space), action_space, lambda _: 0.0, **kwargs)


def read_policy_weights(checkpoint: Path) -> dict[str, th.Tensor]:
    """The ``policy.pth`` state dict of a checkpoint zip, read as weights only.

    :raises DrxError: not a zip, no ``policy.pth``, too large, or holding anything but tensors.
    """
    name = Path(checkpoint).name
    try:
        with zipfile.ZipFile(checkpoint) as zf:
            info = zf.getinfo(POLICY_MEMBER)
            if info.file_size > MAX_POLICY_BYTES:
                raise DrxError(
                    f"Checkpoint {name}: {POLICY_MEMBER} is {info.file_size >> 20} MB, more than any drx "
                    f"network ({MAX_POLICY_BYTES >> 20} MB); refusing it."
                )
            with zf.open(info) as f:
                raw = f.read(MAX_POLICY_BYTES + 1)
    except KeyError:
        raise DrxError(f"Checkpoint {name} has no {POLICY_MEMBER}; it is not an SB3 checkpoint.") from None
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        raise DrxError(f"Checkpoint {name} is not a valid checkpoint file ({exc}).") from exc
    if len(raw) > MAX_POLICY_BYTES:
        raise DrxError(f"Checkpoint {name}: {POLICY_MEMBER} is larger than its recorded size; refusing it.")
    try:
        weights = th.load(io.BytesIO(raw), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - the unpickler refused something: not plain weights
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DrxError(
            f"Checkpoint {name}: {POLICY_MEMBER} holds more than weights and is refused ({reason[:200]})."
        ) from exc
    if not isinstance(weights, dict) or not all(isinstance(v, th.Tensor) for v in weights.values()):
        raise DrxError(f"Checkpoint {name}: {POLICY_MEMBER} is not a state dict of tensors.")
    return weights


def load_policy_weights(checkpoint: Path, vehicle: Vehicle, algorithm: str | None = None) -> BasePolicy:
    """The checkpoint's policy for ``vehicle``, in evaluation mode on the CPU, without unpickling.

    :param algorithm: ``ppo`` or ``sac`` (default: the checkpoint's ``drx.json``, else ``ppo``).
    :raises DrxError: the file is no checkpoint, or its weights do not fit the car's network.
    """
    checkpoint = Path(checkpoint)
    meta = read_meta(checkpoint)
    algorithm = str(algorithm or meta.get("algorithm") or "ppo")
    network = meta.get("network")
    if network is not None and network != vehicle.network:
        raise DrxError(
            f"Checkpoint {checkpoint.name} was trained with the {network} network, not the car's "
            f"{vehicle.network}; it does not fit this car."
        )
    weights = read_policy_weights(checkpoint)
    policy = build_policy(vehicle, algorithm, str(meta.get("towers") or "shared"))
    try:
        policy.load_state_dict(weights, strict=True)
    except (RuntimeError, KeyError, ValueError) as exc:
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DrxError(
            f"Checkpoint {checkpoint.name} does not fit the car ({vehicle.summary()}, {vehicle.network} "
            f"network, {algorithm}): {reason[:200]}."
        ) from exc
    policy.set_training_mode(False)
    return policy
