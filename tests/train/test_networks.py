"""The networks: DeepRacer's layouts, the compact one's pooling shortcut, camera + lidar."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from gymnasium import spaces

from drx.errors import DrxError
from drx.train.buffer import pool_frames
from drx.train.networks import CameraCNN, DictCNN, policy_kwargs_for

FRAME = spaces.Box(0, 255, (1, 120, 160), np.uint8)


@pytest.mark.parametrize(
    ("kind", "convs", "features"),
    [
        ("shallow", [(32, 8, 4), (64, 4, 2), (64, 3, 1)], 512),
        ("deep", [(32, 5, 2), (32, 3, 1), (64, 3, 2), (64, 3, 1)], 512),
    ],
)
def test_deepracer_layouts(kind: str, convs: list[tuple[int, int, int]], features: int) -> None:
    net = CameraCNN(FRAME, kind)
    layers = [(m.out_channels, m.kernel_size[0], m.stride[0]) for m in net.cnn if isinstance(m, th.nn.Conv2d)]
    assert layers == convs
    assert net.features_dim == features
    if kind == "deep":
        dense = [m.out_features for m in net.head if isinstance(m, th.nn.Linear)]
        assert dense == [64, 512]


def test_compact_skips_its_pool_for_pooled_frames() -> None:
    net = CameraCNN(FRAME, "compact")
    frames = np.random.default_rng(0).integers(0, 256, (3, 1, 120, 160), dtype=np.uint8)
    full = net(th.as_tensor(frames).float() / 255.0)
    pooled = net(th.as_tensor(pool_frames(frames, net.input_pool)) / 255.0)
    assert net.input_pool == 4
    assert th.allclose(full, pooled, atol=1e-5)


def test_stereo_and_lidar_inputs() -> None:
    stereo = spaces.Box(0, 255, (2, 120, 160), np.uint8)
    space = spaces.Dict({"camera": stereo, "lidar": spaces.Box(0.15, 2.0, (64,), np.float32)})
    for kind in ("shallow", "deep", "compact"):
        net = DictCNN(space, kind)
        out = net({"camera": th.zeros(2, 2, 120, 160), "lidar": th.ones(2, 64)})
        assert out.shape == (2, net.features_dim) == (2, net.camera.features_dim + 64)
    assert policy_kwargs_for("deep", space)["features_extractor_class"] is DictCNN


def test_unknown_network() -> None:
    with pytest.raises(DrxError, match="unknown"):
        policy_kwargs_for("resnet", FRAME)
