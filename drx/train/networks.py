"""The policy networks a car can carry, as Stable-Baselines3 feature extractors.

Every network reads the 160x120 grayscale camera frame (two frames for a
stereo camera) and, when the car has a lidar, concatenates the lidar ranges
after the convolutional stack (``../shared/DEEPRACER.md`` section 1):

- ``shallow``: DeepRacer's 3-layer CNN, conv 32@8x8/4, 64@4x4/2, 64@3x3/1, dense 512
  (the layout of SB3's ``NatureCNN``).
- ``deep``: DeepRacer's 5-layer CNN, conv 32@5x5/2, 32@3x3/1, 64@3x3/2, 64@3x3/1,
  dense 64, dense 512.
- ``compact``: drx's CPU network. The frame is averaged down 4x (to 40x30), then
  two strided convolutions, 16@5x5/3 and 32@3x3/2, and one dense layer of 128.
  At 40x30 the road's edges are still two or three pixels wide. Few layers matter
  more than few multiply-adds on a CPU: each convolution's backward pass has a
  fixed cost, and this stack trains a batch of 64 about 40 times faster than
  ``shallow``, which is what makes hundreds of training steps per second on a
  laptop possible (``benchmarks/train_throughput.py``).

Observations arrive channel-first (SB3 transposes image spaces) and are scaled
to [0, 1] by SB3 before they reach the extractor.
"""

from __future__ import annotations

from typing import Any

import torch as th
from gymnasium import spaces
from stable_baselines3.common.preprocessing import is_image_space
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from drx.errors import DrxError

COMPACT_POOL = 4  # the compact network's input average pool [pixels]
CAMERA_KEY = "camera"
LIDAR_KEY = "lidar"


# Convolutions as (out channels, kernel, stride, padding), in DeepRacer's notation out@kxk/stride.
CONV_LAYERS: dict[str, tuple[tuple[int, int, int, int], ...]] = {
    "shallow": ((32, 8, 4, 0), (64, 4, 2, 0), (64, 3, 1, 0)),
    "deep": ((32, 5, 2, 0), (32, 3, 1, 0), (64, 3, 2, 0), (64, 3, 1, 0)),
    "compact": ((16, 5, 3, 1), (32, 3, 2, 1)),  # on the 40x30 pooled frame: -> 13x10 -> 7x5
}


def _conv_stack(kind: str, n_channels: int) -> nn.Sequential:
    """The convolutional part of a network, ending with a flatten."""
    if kind not in CONV_LAYERS:
        raise DrxError(f"Network {kind!r} is unknown; use one of shallow, deep, compact.")
    layers: list[nn.Module] = []
    if kind == "compact":
        layers.append(nn.AvgPool2d(kernel_size=COMPACT_POOL, stride=COMPACT_POOL))  # 160x120 -> 40x30
    channels = n_channels
    for out, kernel, stride, padding in CONV_LAYERS[kind]:
        layers += [nn.Conv2d(channels, out, kernel_size=kernel, stride=stride, padding=padding), nn.ReLU()]
        channels = out
    return nn.Sequential(*layers, nn.Flatten())


def _dense_head(kind: str, n_flat: int) -> tuple[nn.Sequential, int]:
    """The dense layers after the convolutions and their output size."""
    if kind == "shallow":
        return nn.Sequential(nn.Linear(n_flat, 512), nn.ReLU()), 512
    if kind == "deep":
        return nn.Sequential(nn.Linear(n_flat, 64), nn.ReLU(), nn.Linear(64, 512), nn.ReLU()), 512
    return nn.Sequential(nn.Linear(n_flat, 128), nn.ReLU()), 128


class CameraCNN(BaseFeaturesExtractor):
    """One of drx's networks over a camera-only observation.

    :param observation_space: a channel-first image ``Box`` (C, 120, 160).
    :param kind: ``shallow``, ``deep`` or ``compact``.
    """

    def __init__(self, observation_space: spaces.Box, kind: str = "compact") -> None:
        assert is_image_space(observation_space, check_channels=False, normalized_image=False), (
            f"{type(self).__name__} needs an image observation, got {observation_space}; "
            "use DictCNN for camera + lidar."
        )
        n_channels = int(observation_space.shape[0])
        cnn = _conv_stack(kind, n_channels)
        with th.no_grad():
            n_flat = int(cnn(th.zeros(1, *observation_space.shape)).shape[1])
        head, features_dim = _dense_head(kind, n_flat)
        super().__init__(observation_space, features_dim)
        self.kind = kind
        self.cnn = cnn
        self.head = head

    @property
    def input_pool(self) -> int:
        """The parameter-free average pool the network starts with (1 when none)."""
        first = self.cnn[0]
        return int(first.kernel_size) if isinstance(first, nn.AvgPool2d) else 1  # type: ignore[arg-type]

    def forward(self, observations: th.Tensor) -> th.Tensor:
        """Features for a batch of (N, C, H, W) frames in [0, 1].

        Frames already averaged by :attr:`input_pool` (as a pooling rollout buffer
        stores them) skip the network's pooling layer.
        """
        frame_shape = self._observation_space.shape
        assert frame_shape is not None  # a Box of frames
        if self.input_pool > 1 and observations.shape[-1] != frame_shape[-1]:
            return self.head(self.cnn[1:](observations))
        return self.head(self.cnn(observations))


class DictCNN(BaseFeaturesExtractor):
    """A network over ``Dict(camera, lidar)``: the camera CNN's features, then the lidar ranges.

    DeepRacer appends the lidar after the camera's convolutions; drx does the
    same, with one dense layer of 64 over the ranges so that the 64-beam lidar
    does not drown in the 512 camera features.

    :param observation_space: ``Dict(camera=Box(C,120,160), lidar=Box(n,))``.
    :param kind: ``shallow``, ``deep`` or ``compact``.
    """

    def __init__(self, observation_space: spaces.Dict, kind: str = "compact") -> None:
        camera_space = observation_space[CAMERA_KEY]
        lidar_space = observation_space[LIDAR_KEY]
        assert isinstance(camera_space, spaces.Box) and isinstance(lidar_space, spaces.Box), (
            f"DictCNN needs Box spaces under {CAMERA_KEY!r} and {LIDAR_KEY!r}, got {observation_space}"
        )
        camera = CameraCNN(camera_space, kind)
        n_lidar = int(lidar_space.shape[0])
        super().__init__(observation_space, camera.features_dim + 64)
        self.camera = camera
        self.lidar = nn.Sequential(nn.Linear(n_lidar, 64), nn.ReLU())

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """Camera features and lidar features, side by side."""
        lidar = observations[LIDAR_KEY].float().flatten(1)
        return th.cat([self.camera(observations[CAMERA_KEY]), self.lidar(lidar)], dim=1)


def policy_kwargs_for(network: str, observation_space: spaces.Space) -> dict[str, Any]:
    """SB3 ``policy_kwargs`` selecting drx's network for an observation space.

    :param network: ``shallow``, ``deep`` or ``compact``.
    :param observation_space: the env's observation space (Box or Dict).
    """
    if network not in ("shallow", "deep", "compact"):
        raise DrxError(f"Network {network!r} is unknown; use one of shallow, deep, compact.")
    extractor = DictCNN if isinstance(observation_space, spaces.Dict) else CameraCNN
    return {"features_extractor_class": extractor, "features_extractor_kwargs": {"kind": network}}


def input_pool(network: str, observation_space: spaces.Space) -> int:
    """The average pool a rollout buffer may apply to stored frames for this network (1 = none)."""
    if network == "compact" and not isinstance(observation_space, spaces.Dict):
        return COMPACT_POOL
    return 1


# Torch threads worth giving each network's update. The compact network's batch of 64 at 40x30
# gains at most ~25% from a second thread on an idle machine (2.8 vs 3.6 ms per batch), and when
# the cores are busy with anything else a second, spinning thread makes it 5-20x slower (measured
# on a shared 2-core machine: 69 vs 237 end-to-end steps/s). The big networks gain 2-2.5x.
USEFUL_THREADS = {"compact": 1}


def useful_threads(network: str, available: int) -> int:
    """Threads to give ``network``'s update out of ``available``."""
    return max(1, min(available, USEFUL_THREADS.get(network, available)))


def count_parameters(module: nn.Module) -> int:
    """Number of trainable parameters of a module."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad)
