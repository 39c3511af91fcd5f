"""A drx PPO policy on DeepRacer's ``shallow`` network as DeepRacer's checkpoint tensors, and back.

DeepRacer's PPO network (rl_coach, as patched by deepracer-simapp) is two towers that share no
weight: ``network_0`` gives the value, ``network_1`` the policy. Each tower is the same stack,
``DEEP_CONVOLUTIONAL_NETWORK_SHALLOW`` (deepracer-simapp ``bundle/markov/architecture/
embedder_factory.py``, the 3-layer camera scheme): on the grey 120x160 frame divided by 255,

- ``FRONT_FACING_CAMERA/Conv2d_{0,2,4}``: 32@8x8/4, 64@4x4/2, 64@3x3/1, VALID, NHWC, ReLU
  (rl_coach numbers its layers with the activations between them, hence 0, 2, 4);
- ``middleware_fc_embedder/Dense_0``: 11264 -> 512, ReLU, on the last map flattened in
  TensorFlow's NHWC order (row = (h * 16 + w) * 64 + c);
- ``gradients_from_head_0-0_rescalers``: a scalar (1.0) that only scales gradients;
- heads: ``v_values_head_0/output`` (512 -> 1) on tower 0; on tower 1 ``ppo_head_0/policy_mean``
  (512 -> 2, the Gaussian's mean in the normalised box [-1, 1], steering then speed) and
  ``ppo_head_0/policy_log_std`` ([1, 2]) for a continuous car, or ``ppo_head_0/policy_fc``
  (512 -> N, softmax) for a discrete one.

These are exactly the tensors of the real console checkpoints in
``../shared/deepracer-models/`` (their ``.index`` files), all float32, nothing else (no optimiser
state, no ``global_step``). drx's ``shallow`` policy is the same stack (``drx.train.networks``:
torch's convolutions and dense layers, channel-first), so a checkpoint maps tensor for tensor:
torch kernels ``(out, in, h, w)`` become TensorFlow's ``(h, w, in, out)``, dense weights are
transposed, and the first dense layer's rows are put into NHWC order. A drx model with one
shared trunk (``towers`` ``shared``) writes that trunk into both towers; an imported model keeps
DeepRacer's two (``towers`` ``separate``).

drx's value head predicts returns in units of the run's return scale (:mod:`drx.train.stability`);
DeepRacer's predicts raw returns, so the value head is multiplied by the scale on export.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch as th

from drx.errors import DrxError
from drx.vehicle import Vehicle

PREFIX = "main_level/agent/main/online"
CAMERA = "FRONT_FACING_CAMERA"
CONVS = (0, 2, 4)  # rl_coach's layer numbers of the three convolutions (and drx's cnn indexes)
RESCALER = "gradients_from_head_0-0_rescalers"
VALUE_TOWER, POLICY_TOWER = "network_0", "network_1"
LAST_MAP = (11, 16, 64)  # (h, w, c) of the shallow stack's last feature map on a 120x160 frame
DEEPRACER_NETWORK = "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"


@dataclass(frozen=True)
class TowerWeights:
    """One tower's trunk in torch's layout: three (kernel, bias) convolutions and the dense layer."""

    convs: tuple[tuple[np.ndarray, np.ndarray], ...]
    dense: tuple[np.ndarray, np.ndarray]


def _nhwc_rows() -> np.ndarray:
    """For each row of TensorFlow's flattened NHWC map, the torch (C, H, W) flat index it holds."""
    h, w, c = LAST_MAP
    return np.arange(c * h * w).reshape(c, h, w).transpose(1, 2, 0).ravel()


def _trunk_to_tf(trunk: TowerWeights, tower: str) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    base = f"{PREFIX}/{tower}"
    for index, (kernel, bias) in zip(CONVS, trunk.convs, strict=True):
        out[f"{base}/{CAMERA}/Conv2d_{index}/kernel"] = kernel.transpose(2, 3, 1, 0)
        out[f"{base}/{CAMERA}/Conv2d_{index}/bias"] = bias
    weight, bias = trunk.dense
    out[f"{base}/middleware_fc_embedder/Dense_0/kernel"] = weight[:, _nhwc_rows()].T
    out[f"{base}/middleware_fc_embedder/Dense_0/bias"] = bias
    out[f"{base}/{RESCALER}"] = np.asarray(1.0)
    return out


def _trunk_from_tf(tensors: Mapping[str, np.ndarray], tower: str) -> TowerWeights:
    base = f"{PREFIX}/{tower}"
    convs = tuple(
        (
            tensors[f"{base}/{CAMERA}/Conv2d_{i}/kernel"].transpose(3, 2, 0, 1),
            tensors[f"{base}/{CAMERA}/Conv2d_{i}/bias"],
        )
        for i in CONVS
    )
    kernel = tensors[f"{base}/middleware_fc_embedder/Dense_0/kernel"]
    weight = np.empty_like(kernel.T)
    weight[:, _nhwc_rows()] = kernel.T
    return TowerWeights(convs, (weight, tensors[f"{base}/middleware_fc_embedder/Dense_0/bias"]))


def _numpy(t: th.Tensor) -> np.ndarray:
    return np.ascontiguousarray(t.detach().cpu().numpy().astype(np.float32))


def _trunk_of(extractor: Any) -> TowerWeights:
    """The trunk of a drx ``shallow`` :class:`~drx.train.networks.CameraCNN`."""
    cnn, head = extractor.cnn, extractor.head
    convs = tuple((_numpy(cnn[i].weight), _numpy(cnn[i].bias)) for i in CONVS)
    return TowerWeights(convs, (_numpy(head[0].weight), _numpy(head[0].bias)))


def check_exportable(vehicle: Vehicle, algorithm: str) -> None:
    """Refuse, in one sentence, a car or algorithm DeepRacer's checkpoint cannot hold."""
    if algorithm != "ppo":
        raise DrxError(
            f"DeepRacer's model folder holds PPO models here; this model trains with {algorithm.upper()} "
            "(export it with --for-car, or clone it with --algo ppo)."
        )
    if vehicle.sensor != "camera" or vehicle.lidar:
        raise DrxError(
            "DeepRacer's model folder export takes a car with the front camera only; this car has "
            f"{vehicle.sensor}{' and a lidar' if vehicle.lidar else ''}."
        )


def policy_tensors(policy: Any, vehicle: Vehicle, value_scale: float = 1.0) -> dict[str, np.ndarray]:
    """DeepRacer's checkpoint tensors of a drx PPO policy on the ``shallow`` network.

    ``np.array`` rather than ``np.ascontiguousarray``: the latter makes a 0-d tensor 1-d.

    :param policy: an SB3 actor-critic policy built by drx for ``vehicle`` (shared or separate towers).
    :param vehicle: its car (front camera, ``shallow`` network).
    :param value_scale: the return scale the value head predicts in (its output x this = a return).
    :raises DrxError: the policy is not on the shallow network.
    """
    if vehicle.network != "shallow":
        raise DrxError(f"Only the shallow network maps onto DeepRacer's tensors, not {vehicle.network}.")
    check_exportable(vehicle, "ppo")
    pi = _trunk_of(policy.pi_features_extractor)
    vf = _trunk_of(policy.vf_features_extractor)
    out = {**_trunk_to_tf(vf, VALUE_TOWER), **_trunk_to_tf(pi, POLICY_TOWER)}
    value = policy.value_net
    out[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/kernel"] = _numpy(value.weight).T * value_scale
    out[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/bias"] = _numpy(value.bias) * value_scale
    action = policy.action_net
    head = f"{PREFIX}/{POLICY_TOWER}/ppo_head_0"
    if vehicle.continuous:
        out[f"{head}/policy_mean/kernel"] = _numpy(action.weight).T
        out[f"{head}/policy_mean/bias"] = _numpy(action.bias)
        out[f"{head}/policy_log_std"] = _numpy(policy.log_std).reshape(1, -1)
    else:
        out[f"{head}/policy_fc/kernel"] = _numpy(action.weight).T
        out[f"{head}/policy_fc/bias"] = _numpy(action.bias)
    return {name: np.array(value, dtype=np.float32, order="C") for name, value in out.items()}


def expected_shapes(vehicle: Vehicle) -> dict[str, tuple[int, ...]]:
    """Every tensor DeepRacer's checkpoint holds for this car, with its shape."""
    shapes: dict[str, tuple[int, ...]] = {}
    h, w, c = LAST_MAP
    conv_shapes = ((8, 8, 1, 32), (4, 4, 32, 64), (3, 3, 64, 64))
    for tower in (VALUE_TOWER, POLICY_TOWER):
        base = f"{PREFIX}/{tower}"
        for index, shape in zip(CONVS, conv_shapes, strict=True):
            shapes[f"{base}/{CAMERA}/Conv2d_{index}/kernel"] = shape
            shapes[f"{base}/{CAMERA}/Conv2d_{index}/bias"] = (shape[-1],)
        shapes[f"{base}/middleware_fc_embedder/Dense_0/kernel"] = (h * w * c, 512)
        shapes[f"{base}/middleware_fc_embedder/Dense_0/bias"] = (512,)
        shapes[f"{base}/{RESCALER}"] = ()
    shapes[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/kernel"] = (512, 1)
    shapes[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/bias"] = (1,)
    head = f"{PREFIX}/{POLICY_TOWER}/ppo_head_0"
    if vehicle.continuous:
        shapes[f"{head}/policy_mean/kernel"] = (512, 2)
        shapes[f"{head}/policy_mean/bias"] = (2,)
        shapes[f"{head}/policy_log_std"] = (1, 2)
    else:
        shapes[f"{head}/policy_fc/kernel"] = (512, vehicle.n_actions)
        shapes[f"{head}/policy_fc/bias"] = (vehicle.n_actions,)
    return shapes


def check_tensor_set(shapes: Mapping[str, tuple[int, ...]], vehicle: Vehicle, source: str) -> None:
    """Refuse, in one sentence, a checkpoint whose tensors do not fit the car's network.

    :param shapes: the checkpoint's tensor names and shapes.
    :param source: the checkpoint's name, for the sentence.
    """
    want = expected_shapes(vehicle)
    missing = sorted(set(want) - set(shapes))
    if missing:
        what = "a continuous" if vehicle.continuous else f"a {vehicle.n_actions}-action discrete"
        raise DrxError(
            f"{source} lacks {len(missing)} tensor(s) that {what} car on DeepRacer's shallow network needs, "
            f"first {missing[0]}; it was not trained for the car its model_metadata.json describes."
        )
    for name, shape in want.items():
        if tuple(shapes[name]) != shape:
            raise DrxError(
                f"{source}: tensor {name} has shape {list(shapes[name])}, but the car's network needs "
                f"{list(shape)}; the checkpoint does not fit its model_metadata.json."
            )


def policy_state(tensors: Mapping[str, np.ndarray], vehicle: Vehicle) -> dict[str, th.Tensor]:
    """The state dict of a drx PPO policy with separate towers, from DeepRacer's tensors.

    The value head keeps DeepRacer's raw returns (a return scale of 1). Check the tensors with
    :func:`check_tensor_set` first.
    """
    state: dict[str, np.ndarray] = {}
    for tower, prefix in ((POLICY_TOWER, "pi_features_extractor"), (VALUE_TOWER, "vf_features_extractor")):
        trunk = _trunk_from_tf(tensors, tower)
        names = [prefix] + (["features_extractor"] if tower == POLICY_TOWER else [])
        for name in names:
            for index, (kernel, bias) in zip(CONVS, trunk.convs, strict=True):
                state[f"{name}.cnn.{index}.weight"] = kernel
                state[f"{name}.cnn.{index}.bias"] = bias
            state[f"{name}.head.0.weight"], state[f"{name}.head.0.bias"] = trunk.dense
    state["value_net.weight"] = tensors[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/kernel"].T
    state["value_net.bias"] = tensors[f"{PREFIX}/{VALUE_TOWER}/v_values_head_0/output/bias"]
    head = f"{PREFIX}/{POLICY_TOWER}/ppo_head_0"
    if vehicle.continuous:
        state["action_net.weight"] = tensors[f"{head}/policy_mean/kernel"].T
        state["action_net.bias"] = tensors[f"{head}/policy_mean/bias"]
        state["log_std"] = tensors[f"{head}/policy_log_std"].reshape(-1)
    else:
        state["action_net.weight"] = tensors[f"{head}/policy_fc/kernel"].T
        state["action_net.bias"] = tensors[f"{head}/policy_fc/bias"]
    return {k: th.from_numpy(np.ascontiguousarray(v, dtype=np.float32)) for k, v in state.items()}
