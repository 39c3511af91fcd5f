"""drx's shallow PPO policy as DeepRacer's checkpoint tensors and back, checked against an NHWC
forward pass written from DeepRacer's layer list (not from drx's torch code)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch as th
from numpy.lib.stride_tricks import sliding_window_view

from drx.errors import DrxError
from drx.interchange.deepracer import deepracer_weights as dw
from drx.train.policy_weights import build_policy
from drx.vehicle import Vehicle, grid_actions

CONTINUOUS = Vehicle(
    name="c", continuous=True, steering_range=(-25, 27), speed_range=(1, 3.3), network="shallow"
)
DISCRETE = Vehicle(name="d", actions=grid_actions(30, 3, 1, 3), network="shallow")


def _conv_nhwc(x: np.ndarray, kernel: np.ndarray, bias: np.ndarray, stride: int) -> np.ndarray:
    """TensorFlow's VALID Conv2D + bias + ReLU on an NHWC batch, kernel (h, w, in, out)."""
    kh, kw = kernel.shape[:2]
    windows = sliding_window_view(x, (kh, kw), axis=(1, 2))[:, ::stride, ::stride]  # N,H',W',C,kh,kw
    return np.maximum(np.einsum("nhwcij,ijco->nhwo", windows, kernel) + bias, 0.0)


def _tower(tensors: dict[str, np.ndarray], tower: str, frames: np.ndarray) -> np.ndarray:
    """DeepRacer's shallow tower up to its middleware's ReLU: frames uint8 (N, 120, 160, 1)."""
    base = f"{dw.PREFIX}/{tower}"
    x = frames.astype(np.float64) / 255.0
    for index, stride in zip(dw.CONVS, (4, 2, 1), strict=True):
        conv = f"{base}/FRONT_FACING_CAMERA/Conv2d_{index}"
        x = _conv_nhwc(x, tensors[f"{conv}/kernel"], tensors[f"{conv}/bias"], stride)
    flat = x.reshape(len(x), -1)  # TensorFlow's flatten: NHWC order
    dense = f"{base}/middleware_fc_embedder/Dense_0"
    return np.maximum(flat @ tensors[f"{dense}/kernel"] + tensors[f"{dense}/bias"], 0.0)


def _random_policy(vehicle: Vehicle, towers: str, seed: int) -> th.nn.Module:
    th.manual_seed(seed)
    policy = build_policy(vehicle, "ppo", towers)
    with th.no_grad():
        for p in policy.parameters():
            p.add_(th.randn_like(p) * 0.05)  # SB3 starts heads near zero: make every output count
    return policy


def _torch_outputs(policy: th.nn.Module, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    obs = th.as_tensor(frames).permute(0, 3, 1, 2)
    with th.no_grad():
        dist = policy.get_distribution(obs)
        values = policy.predict_values(obs)
    out = dist.distribution.mean if hasattr(dist.distribution, "mean") and policy.action_space.shape else None
    if out is None:
        out = dist.distribution.probs
    return out.numpy().astype(np.float64), values.numpy().reshape(-1).astype(np.float64)


@pytest.mark.parametrize("vehicle", [CONTINUOUS, DISCRETE], ids=["continuous", "discrete"])
@pytest.mark.parametrize("towers", ["shared", "separate"])
def test_tensors_drive_as_the_policy_in_deepracers_layout(vehicle: Vehicle, towers: str) -> None:
    policy = _random_policy(vehicle, towers, seed=3)
    tensors = dw.policy_tensors(policy, vehicle, value_scale=2.5)
    assert {k: v.shape for k, v in tensors.items()} == dw.expected_shapes(vehicle)
    assert all(v.dtype == np.float32 for v in tensors.values())
    frames = np.random.default_rng(0).integers(0, 256, size=(4, 120, 160, 1), dtype=np.uint8)
    action, value = _torch_outputs(policy, frames)
    pi = _tower(tensors, dw.POLICY_TOWER, frames)
    vf = _tower(tensors, dw.VALUE_TOWER, frames)
    head = f"{dw.PREFIX}/network_1/ppo_head_0"
    if vehicle.continuous:
        np.testing.assert_allclose(
            pi @ tensors[f"{head}/policy_mean/kernel"] + tensors[f"{head}/policy_mean/bias"],
            action,
            atol=1e-4,
        )
    else:
        logits = pi @ tensors[f"{head}/policy_fc/kernel"] + tensors[f"{head}/policy_fc/bias"]
        probs = np.exp(logits - logits.max(1, keepdims=True))
        np.testing.assert_allclose(probs / probs.sum(1, keepdims=True), action, atol=1e-5)
    v_head = f"{dw.PREFIX}/network_0/v_values_head_0/output"
    np.testing.assert_allclose(
        (vf @ tensors[f"{v_head}/kernel"]).ravel() + tensors[f"{v_head}/bias"],
        value * 2.5,
        rtol=1e-4,
        atol=1e-4,
    )
    same_towers = np.array_equal(
        tensors[f"{dw.PREFIX}/network_0/middleware_fc_embedder/Dense_0/kernel"],
        tensors[f"{dw.PREFIX}/network_1/middleware_fc_embedder/Dense_0/kernel"],
    )
    assert same_towers == (towers == "shared")


@pytest.mark.parametrize("vehicle", [CONTINUOUS, DISCRETE], ids=["continuous", "discrete"])
def test_tensors_load_back_into_a_two_tower_policy(vehicle: Vehicle) -> None:
    policy = _random_policy(vehicle, "separate", seed=5)
    back = build_policy(vehicle, "ppo", "separate")
    back.load_state_dict(dw.policy_state(dw.policy_tensors(policy, vehicle), vehicle), strict=True)
    for name, tensor in policy.state_dict().items():
        assert th.equal(tensor, back.state_dict()[name]), name


def test_tensor_sets_that_do_not_fit_are_refused() -> None:
    shapes = dw.expected_shapes(DISCRETE)
    dw.check_tensor_set(shapes, DISCRETE, "ok.ckpt")
    with pytest.raises(DrxError, match="lacks 3 tensor"):
        dw.check_tensor_set(shapes, CONTINUOUS, "x.ckpt")
    nine = dataclasses.replace(DISCRETE, actions=grid_actions(30, 3, 1, 3)[:8])
    with pytest.raises(
        DrxError, match=r"policy_fc/kernel has shape \[512, 9\], but the car's network needs \[512, 8\]"
    ):
        dw.check_tensor_set(shapes, nine, "x.ckpt")
    with pytest.raises(DrxError, match="front camera only"):
        dw.check_exportable(dataclasses.replace(CONTINUOUS, sensor="stereo"), "ppo")
    with pytest.raises(DrxError, match="holds PPO models"):
        dw.check_exportable(CONTINUOUS, "sac")
