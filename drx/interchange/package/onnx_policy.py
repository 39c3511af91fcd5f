"""A drx checkpoint's policy as an ONNX graph, for onnxruntime and for OpenVINO on the car.

The graph is written layer by layer from the policy's torch modules (convolutions,
pooling, dense layers and activations are all drx's networks use), so it needs only
the ``onnx`` package and stays readable by old runtimes (opset 13, IR version 7).

Inputs:

- ``camera``: ``uint8 [N, 120, 160, C]``, the grayscale frame(s) as the car's camera gives
  them (C = 1, or 2 for a stereo camera); scaled to [0, 1] inside the graph as in training;
- ``lidar`` (lidar cars only): ``float32 [N, beams]`` ranges [m].

Outputs:

- discrete cars: ``action_probabilities`` ``float32 [N, n_actions]`` (softmax of the policy);
- continuous cars: ``action`` ``float32 [N, 2]``, the policy's deterministic (steering, speed)
  in [-1, 1], and ``action_scaled`` ``float32 [N, 2]``, the same in degrees and m/s.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch as th
from torch import nn

from drx.errors import DrxError
from drx.interchange.package.policy_parts import Extractor, policy_parts
from drx.vehicle import Vehicle

if TYPE_CHECKING:
    from stable_baselines3.common.policies import BasePolicy

OPSET = 13
IR_VERSION = 7
CAMERA_INPUT = "camera"
LIDAR_INPUT = "lidar"


def _onnx() -> Any:
    try:
        import onnx
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise DrxError(
            "Exporting a model needs the onnx package; install it with `pip install onnx`."
        ) from exc
    return onnx


def load_policy(checkpoint: Path, vehicle: Vehicle, algorithm: str | None = None) -> BasePolicy:
    """The policy stored in a checkpoint zip for ``vehicle``, in evaluation mode on the CPU.

    Weights only: the policy is rebuilt from the car and ``policy.pth`` is read without
    unpickling anything (:mod:`drx.train.policy_weights`).

    :raises DrxError: the file is not a checkpoint, or does not fit the car.
    """
    from drx.train.policy_weights import load_policy_weights

    return load_policy_weights(Path(checkpoint), vehicle, algorithm)


class _Graph:
    """Collects ONNX nodes and initializers while walking torch modules."""

    def __init__(self) -> None:
        self.onnx = _onnx()
        self.nodes: list[Any] = []
        self.inits: list[Any] = []
        self._n = 0

    def name(self, prefix: str) -> str:
        self._n += 1
        return f"{prefix}_{self._n}"

    def const(self, value: np.ndarray, prefix: str = "c") -> str:
        name = self.name(prefix)
        self.inits.append(self.onnx.numpy_helper.from_array(np.ascontiguousarray(value), name))
        return name

    def node(self, op: str, inputs: list[str], **attrs: Any) -> str:
        out = self.name(op.lower())
        self.nodes.append(self.onnx.helper.make_node(op, inputs, [out], name=out, **attrs))
        return out

    def module(self, m: nn.Module, x: str) -> str:
        """Append ``m`` applied to tensor ``x``; return the output's name."""
        if isinstance(m, nn.Sequential):
            for child in m:
                x = self.module(child, x)
            return x
        if isinstance(m, nn.Identity):
            return x
        if isinstance(m, nn.Conv2d):
            if isinstance(m.padding, str) or m.padding_mode != "zeros":
                raise DrxError(f"Cannot export convolution padding {m.padding!r}/{m.padding_mode}.")
            ph, pw = m.padding
            inputs = [x, self.const(m.weight.detach().numpy(), "conv_w")]
            if m.bias is not None:
                inputs.append(self.const(m.bias.detach().numpy(), "conv_b"))
            return self.node(
                "Conv",
                inputs,
                kernel_shape=list(m.kernel_size),
                strides=list(m.stride),
                pads=[ph, pw, ph, pw],
                dilations=list(m.dilation),
                group=m.groups,
            )
        if isinstance(m, nn.AvgPool2d):
            k = [m.kernel_size] * 2 if isinstance(m.kernel_size, int) else list(m.kernel_size)
            s = [m.stride] * 2 if isinstance(m.stride, int) else list(m.stride)
            p = [m.padding] * 2 if isinstance(m.padding, int) else list(m.padding)
            if m.ceil_mode or m.divisor_override is not None:
                raise DrxError("Cannot export average pooling with ceil_mode or divisor_override.")
            return self.node(
                "AveragePool",
                [x],
                kernel_shape=k,
                strides=s,
                pads=[p[0], p[1], p[0], p[1]],
                count_include_pad=int(m.count_include_pad),
            )
        if isinstance(m, nn.Flatten):
            if m.start_dim != 1 or m.end_dim != -1:
                raise DrxError("Cannot export a Flatten other than Flatten(1, -1).")
            return self.node("Flatten", [x], axis=1)
        if isinstance(m, nn.Linear):
            inputs = [x, self.const(m.weight.detach().numpy(), "fc_w")]
            if m.bias is not None:
                inputs.append(self.const(m.bias.detach().numpy(), "fc_b"))
            return self.node("Gemm", inputs, transB=1)
        if isinstance(m, nn.ReLU):
            return self.node("Relu", [x])
        if isinstance(m, nn.Tanh):
            return self.node("Tanh", [x])
        raise DrxError(f"Cannot export the layer {type(m).__name__} to ONNX.")

    def features(self, extractor: Extractor, camera: str, lidar: str | None) -> str:
        """drx's feature extractors (:mod:`drx.train.networks`) and SB3's NatureCNN."""
        if extractor.camera is not None and extractor.lidar is not None and lidar is not None:
            cam = self.features(extractor.camera, camera, None)
            lid = self.module(extractor.lidar, self.node("Flatten", [lidar], axis=1))
            return self.node("Concat", [cam, lid], axis=1)
        if extractor.cnn is not None and extractor.head is not None:
            return self.module(extractor.head, self.module(extractor.cnn, camera))
        raise DrxError(f"Cannot export the feature extractor {extractor.name} to ONNX.")


def _scaled(g: _Graph, action: str, vehicle: Vehicle) -> str:
    lo = np.array([vehicle.steering_range[0], vehicle.speed_range[0]], np.float32)
    hi = np.array([vehicle.steering_range[1], vehicle.speed_range[1]], np.float32)
    half = g.node("Mul", [g.node("Add", [action, g.const(np.ones(2, np.float32))]), g.const((hi - lo) / 2)])
    return g.node("Add", [half, g.const(lo)])


def policy_to_onnx(policy: nn.Module, vehicle: Vehicle) -> Any:
    """An ``onnx.ModelProto`` computing the policy's outputs from raw camera frames (module docstring).

    :param policy: an SB3 actor-critic (PPO) or SAC policy with a drx network.
    :param vehicle: the car (action space, sensors) the policy drives.
    """
    g = _Graph()
    onnx = g.onnx
    helper, tp = onnx.helper, onnx.TensorProto
    channels = 2 if vehicle.sensor == "stereo" else 1
    inputs = [helper.make_tensor_value_info(CAMERA_INPUT, tp.UINT8, ["N", 120, 160, channels])]
    lidar = None
    if vehicle.lidar:
        obs_space = policy.observation_space
        beams = int(obs_space[LIDAR_INPUT].shape[0])  # type: ignore[index]
        inputs.append(helper.make_tensor_value_info(LIDAR_INPUT, tp.FLOAT, ["N", beams]))
        lidar = LIDAR_INPUT
    frame = g.node("Cast", [CAMERA_INPUT], to=tp.FLOAT)
    frame = g.node("Transpose", [frame], perm=[0, 3, 1, 2])
    frame = g.node("Div", [frame, g.const(np.array(255.0, np.float32))])  # SB3's image scaling
    outputs = []
    parts = policy_parts(policy, with_lidar=lidar is not None)
    latent = g.module(parts.latent, g.features(parts.extractor, frame, lidar))
    if parts.algorithm == "sac":  # tanh of the actor's mean
        action = g.node("Tanh", [g.module(parts.head, latent)])
    else:
        logits = g.module(parts.head, latent)
        if not vehicle.continuous:
            g.nodes.append(helper.make_node("Softmax", [logits], ["action_probabilities"], axis=-1))
            outputs.append(
                helper.make_tensor_value_info("action_probabilities", tp.FLOAT, ["N", vehicle.n_actions])
            )
        else:
            action = g.node(
                "Clip", [logits, g.const(np.array(-1.0, np.float32)), g.const(np.array(1.0, np.float32))]
            )
    if vehicle.continuous:
        g.nodes.append(helper.make_node("Identity", [action], ["action"]))
        g.nodes.append(helper.make_node("Identity", [_scaled(g, action, vehicle)], ["action_scaled"]))
        outputs += [
            helper.make_tensor_value_info("action", tp.FLOAT, ["N", 2]),
            helper.make_tensor_value_info("action_scaled", tp.FLOAT, ["N", 2]),
        ]
    graph = helper.make_graph(g.nodes, "drx_policy", inputs, outputs, initializer=g.inits)
    model = helper.make_model(
        graph, producer_name="drx", opset_imports=[helper.make_opsetid("", OPSET)], ir_version=IR_VERSION
    )
    onnx.checker.check_model(model)
    return model


def export_onnx(checkpoint: Path, vehicle: Vehicle, out: Path) -> Path:
    """Write the checkpoint's policy as ONNX to ``out``; return the path."""
    model = policy_to_onnx(load_policy(checkpoint, vehicle), vehicle)
    out = Path(out)
    out.write_bytes(model.SerializeToString())
    return out


def torch_outputs(policy: BasePolicy, frames: np.ndarray, lidar: np.ndarray | None = None) -> np.ndarray:
    """What the ONNX graph's first output should be, computed with torch on ``(N, 120, 160, C)`` frames:
    action probabilities (discrete PPO) or the clipped deterministic action (continuous)."""
    obs: Any = frames if lidar is None else {CAMERA_INPUT: frames, LIDAR_INPUT: lidar}
    obs_tensor, _ = policy.obs_to_tensor(obs)
    with th.no_grad():
        if hasattr(policy, "actor"):
            return policy._predict(obs_tensor, deterministic=True).cpu().numpy()
        from stable_baselines3.common.policies import ActorCriticPolicy

        assert isinstance(policy, ActorCriticPolicy), type(policy).__name__
        dist = policy.get_distribution(obs_tensor)
        if isinstance(dist.distribution, th.distributions.Categorical):
            return dist.distribution.probs.cpu().numpy()
        return np.clip(dist.mode().cpu().numpy(), -1.0, 1.0)  # the Gaussian's mean
