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
to [0, 1] by SB3 (or by drx's rollout buffer, once per update) before they reach the extractor.

A gradient step on the CPU takes :meth:`CameraCNN.forward`'s fast path
(:func:`use_fast_path`): the same layers, the same parameters and the same function to
float rounding, computed with kernels that suit a PPO minibatch on a CPU better than
torch's defaults (:func:`onednn_linear`; docs/TRAINING.md has the figures).
"""

from __future__ import annotations

import ctypes
import platform
import sys
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


def _onednn_available() -> bool:
    """Whether torch has oneDNN's fp32 convolution and inner product (x86 CPU builds; not macOS arm64)."""
    try:
        return bool(
            th.backends.mkldnn.is_available()
            and platform.machine().lower() in ("x86_64", "amd64")
            and hasattr(th.ops.mkldnn, "_linear_pointwise")
        )
    except (AttributeError, RuntimeError):
        return False


ONEDNN = _onednn_available()


def _inner_product(a: th.Tensor, b: th.Tensor, bias: th.Tensor | None = None) -> th.Tensor:
    """``a @ b.T (+ bias)`` by oneDNN's inner product; ``b`` may be a transposed view (read in place)."""
    return th.ops.mkldnn._linear_pointwise(a, b, bias, "none", [], "")  # type: ignore[no-any-return]


class _OneDnnLinear(th.autograd.Function):
    """``F.linear`` (fp32) through oneDNN's inner product, forward and backward.

    torch sends fp32 matrix products to MKL, which on AMD CPUs runs its AVX2 code (~95 GFLOP/s a
    core on the 2-core Zen 5 machine of docs/TRAINING.md); oneDNN picks the CPU's AVX-512 kernels by
    feature, not vendor. For ``shallow``'s dense layer (64 x 11264 -> 512) measured on one thread:
    forward 9.2 -> 4.8 ms, input gradient 11.7 -> 4.2 ms, weight gradient 16.3 -> 3.7 ms. All
    three are the same inner product, of the right operands, some read transposed in place.
    """

    @staticmethod
    def forward(ctx: Any, x: th.Tensor, weight: th.Tensor, bias: th.Tensor | None) -> th.Tensor:  # noqa: D102
        x, weight = x.contiguous(), weight.contiguous()
        ctx.save_for_backward(x, weight)
        return _inner_product(x, weight, bias)

    @staticmethod
    def backward(ctx: Any, grad: th.Tensor) -> tuple[th.Tensor | None, ...]:  # noqa: D102
        x, weight = ctx.saved_tensors
        grad = grad.contiguous()
        grad_x = grad_weight = grad_bias = None
        if ctx.needs_input_grad[0]:
            grad_x = _inner_product(grad, weight.t())  # grad @ weight
        if ctx.needs_input_grad[1]:
            grad_weight = _inner_product(grad.t().contiguous(), x.t())  # grad.T @ x
        if ctx.needs_input_grad[2]:
            grad_bias = grad.sum(0)
        return grad_x, grad_weight, grad_bias


# glibc's malloc serves blocks from its mmap threshold up with fresh mmap()s (a page fault on
# every first touch) and gives the heap's free top back to the system past its trim threshold.
# Its dynamic thresholds did not settle here for torch's blocks of a few MB (th.empty(64, 11264)
# faulted its 704 pages on every allocation, numpy's same-size arrays only the first two
# times), so an update of `shallow` on its fast path faulted 2,000-7,000 pages a minibatch (4-13
# ms of system time out of ~65). Fixed thresholds end that; they cover the largest block a
# `shallow` update allocates per minibatch (its 23 MB weight gradient).
MALLOC_MMAP_THRESHOLD = 32 * 2**20  # glibc's largest allowed value
MALLOC_TRIM_THRESHOLD = 128 * 2**20
_malloc_tuned = False


def tune_malloc() -> None:
    """Set glibc malloc's mmap and trim thresholds (:data:`MALLOC_MMAP_THRESHOLD`) for this process,
    once; nothing elsewhere (other C libraries, other systems) or when already done."""
    global _malloc_tuned
    if _malloc_tuned or not sys.platform.startswith("linux"):
        return
    _malloc_tuned = True
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return  # not glibc (musl has no mallopt)
    m_trim_threshold, m_mmap_threshold = -1, -3  # glibc's <malloc.h>
    mallopt(m_mmap_threshold, MALLOC_MMAP_THRESHOLD)
    mallopt(m_trim_threshold, MALLOC_TRIM_THRESHOLD)


def onednn_linear(x: th.Tensor, layer: nn.Linear) -> th.Tensor:
    """``layer(x)`` for a (N, in) fp32 CPU batch, computed by oneDNN when torch has it (else torch's)."""
    if not ONEDNN or x.dim() != 2 or x.dtype != th.float32 or x.device.type != "cpu":
        return layer(x)
    return _OneDnnLinear.apply(x, layer.weight, layer.bias)  # type: ignore[no-any-return]


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
        self.fast = True  # take the fast path for gradient steps on the CPU (use_fast_path)

    @property
    def input_pool(self) -> int:
        """The parameter-free average pool the network starts with (1 when none)."""
        first = self.cnn[0]
        return int(first.kernel_size) if isinstance(first, nn.AvgPool2d) else 1  # type: ignore[arg-type]

    def forward(self, observations: th.Tensor) -> th.Tensor:
        """Features for a batch of (N, C, H, W) frames in [0, 1].

        Frames already averaged by :attr:`input_pool` (as a pooling rollout buffer
        stores them) skip the network's pooling layer. A gradient step on the CPU (grad mode on)
        computes the same function faster (:meth:`_forward_fast`, unless :func:`use_fast_path`
        turned it off).
        """
        frame_shape = self._observation_space.shape
        assert frame_shape is not None  # a Box of frames
        cnn: nn.Module = self.cnn
        if self.input_pool > 1 and observations.shape[-1] != frame_shape[-1]:
            cnn = self.cnn[1:]
        fast = self.fast and self.kind in FAST_KINDS and observations.device.type == "cpu"
        if fast and th.is_grad_enabled():
            return self._forward_fast(list(cnn.children()), observations)
        return self.head(cnn(observations))

    def _forward_fast(self, layers: list[nn.Module], x: th.Tensor) -> th.Tensor:
        """:meth:`forward`'s layers for a gradient step on the CPU, with oneDNN's kernels kept on
        oneDNN's own (blocked) tensors through the convolutions, and the dense layers through
        :func:`onednn_linear`.

        torch runs the same oneDNN convolutions on its own tensors, reordering every input,
        output and gradient to and from oneDNN's layout, and in ``shallow`` copying the second
        convolution's input gradient out of channels-last: 5.5 ms of a 64 ms minibatch on one
        thread (58.4 vs 63.9 ms with the dense layers through oneDNN either way). The ReLUs run in
        place (a convolution's backward needs its input, not its output).
        """
        blocked = ONEDNN and x.dtype == th.float32
        if blocked:
            x = x.contiguous().to_mkldnn()
        for layer in layers:
            if blocked and isinstance(layer, nn.Conv2d):
                assert not isinstance(layer.padding, str)  # drx's layers have numeric padding
                x = th.mkldnn_convolution(
                    x, layer.weight, layer.bias, list(layer.padding), list(layer.stride),
                    list(layer.dilation), layer.groups,
                )  # fmt: skip
            elif isinstance(layer, nn.ReLU) and x.is_mkldnn:
                x = x.relu_()
            elif isinstance(layer, nn.Flatten) and x.is_mkldnn:
                x = x.to_dense().flatten(1)
            else:
                x = layer(x)
        for layer in self.head:
            x = onednn_linear(x, layer) if isinstance(layer, nn.Linear) else layer(x)
        return x


# The networks whose gradient steps take the fast path (CameraCNN._forward_fast). compact's
# minibatch is small enough that the fast path gained nothing measurable (4.4 vs 4.6 ms on one
# thread, within the noise), and its features stay bit for bit as they were.
FAST_KINDS = frozenset({"shallow", "deep"})


def use_fast_path(module: nn.Module, on: bool = True) -> None:
    """Let every drx camera network in ``module`` take (or not) its fast path for gradient steps."""
    for child in module.modules():
        if isinstance(child, CameraCNN):
            child.fast = on


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
