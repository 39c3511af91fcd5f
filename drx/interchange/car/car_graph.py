"""A drx policy as the frozen TensorFlow graph a DeepRacer car loads (``model.pb``).

The graph has DeepRacer's names and shapes, so the car's model optimizer and inference
node treat it as a console-trained model:

- Inputs, float32 NHWC, batch dimension open (-1) as in DeepRacer's graphs:
  ``main_level/agent/{main|policy}/online/network_0/{SENSOR}/{SENSOR}`` with ``main`` for
  PPO and ``policy`` for SAC, and SENSOR ``FRONT_FACING_CAMERA`` ``[-1, 120, 160, 1]``,
  ``STEREO_CAMERAS`` ``[-1, 120, 160, 2]`` (channel 0 left, 1 right), ``LIDAR`` ``[-1, 64]`` or
  ``SECTOR_LIDAR`` ``[-1, 8]`` (aws-deepracer/aws-deepracer-model-optimizer-pkg
  ``model_optimizer_pkg/constants.py``: ``NETWORK_INPUT_FORMAT_MAPPING``,
  ``INPUT_HEAD_NAME_MAPPING``, ``INPUT_CHANNEL_SIZE_MAPPING``; aws-deepracer-systems-pkg
  ``constants.py``: 64 lidar values by default, 8 for SECTOR_LIDAR). The car feeds grey
  pixels as floats in 0..255 (aws-deepracer-inference-pkg ``intel_inference_eng.cpp``,
  ``load1DImg``/``loadStereoImg``); the graph divides by 255 itself, as SB3 does in training.
- One output, the only node nothing consumes (the car's ``mo_tf.py`` call names no output,
  and the inference node reads the first one): ``main_level/agent/main/online/network_1/
  ppo_head_0/policy`` for PPO, ``main_level/agent/policy/online/network_0/sac_policy_head_0/
  policy`` for SAC (deepracer-simapp ``markov/boto/s3/constants.py``,
  ``FROZEN_HEAD_OUTPUT_GRAPH_FORMAT_MAPPING``; written by
  ``markov/boto/s3/files/checkpoint_files/tensorflow_model.py``, ``write_frozen_graph``).

  * discrete PPO: the softmax over the actions, as DeepRacer's ``ppo_head`` (deepracer-simapp
    ``rl_coach.patch``: ``tf.nn.softmax(policy_values, name="policy")``). The car drives
    the action of highest probability (aws-deepracer-navigation-pkg ``deepracer_navigation_node.py``).
  * continuous PPO: the policy mean, clipped to [-1, 1] (DeepRacer's is the unclipped mean,
    ``tf.identity(..., name="policy")``; the car clips to [-1, 1] before scaling to the ranges,
    so the clip changes nothing on the car and makes the output exactly what drx drives).
  * SAC: ``tanh`` of the actor's mean. DeepRacer's SAC graph ends before the ``tanh``
    (``sac_head.py``: ``tf.identity(mean, name="policy")``) while its simulator drives the
    ``tanh`` of it; the car clips the raw mean. drx puts the ``tanh`` in the graph so the car
    drives what drx evaluated.

Layers become TensorFlow's NHWC operations: convolutions ``Pad`` + ``Conv2D`` + ``BiasAdd``,
pooling ``AvgPool``, dense layers ``MatMul`` + ``BiasAdd`` (the first one after a flatten takes
its weight rows in NHWC order, so no transpose is needed), ``Relu``, ``Tanh``, ``ConcatV2``
(camera features, then lidar features). Every operation is one the car's OpenVINO 2021 model
optimizer converts (:data:`drx.interchange.car.tf_graph.MO_2021_TF_OPS`); a layer that would need
another one is refused with :class:`~drx.errors.DrxError`, and nothing is written.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from torch import nn

from drx.errors import DrxError
from drx.interchange.car.tf_graph import FLOAT, INT32, GraphBuilder
from drx.interchange.package.policy_parts import Extractor, policy_parts
from drx.vehicle import Vehicle

PPO_OUTPUT = "main_level/agent/main/online/network_1/ppo_head_0/policy"
SAC_OUTPUT = "main_level/agent/policy/online/network_0/sac_policy_head_0/policy"
INPUT_FORMAT = "main_level/agent/{head}/online/network_0/{sensor}/{sensor}"
HEAD = {"ppo": "main", "sac": "policy"}
FRAME = (120, 160)  # (height, width) [pixels] of the car's camera frames
LIDAR_SENSORS = {64: "LIDAR", 8: "SECTOR_LIDAR"}  # values per scan -> DeepRacer sensor name
# Activations and the TensorFlow operation each becomes; only those in MO_2021_TF_OPS reach a graph.
ACTIVATIONS: dict[type[nn.Module], str] = {
    nn.ReLU: "Relu",
    nn.Tanh: "Tanh",
    nn.Sigmoid: "Sigmoid",
    nn.ELU: "Elu",
    nn.SELU: "Selu",
    nn.LeakyReLU: "LeakyRelu",
}


@dataclass(frozen=True)
class _Tensor:
    """A tensor in the graph: its node, its NHWC (height, width, channels) when it is a feature map,
    and, for a flattened map, the torch (C, H, W) feature index of each of its columns."""

    name: str
    hwc: tuple[int, int, int] | None = None
    columns: np.ndarray | None = None


def camera_sensor(vehicle: Vehicle) -> str:
    """DeepRacer's name of the car's camera input."""
    return "STEREO_CAMERAS" if vehicle.sensor == "stereo" else "FRONT_FACING_CAMERA"


def lidar_sensor(values: int) -> str:
    """DeepRacer's name of a lidar input with ``values`` values per scan.

    :raises DrxError: the car knows no lidar of that size.
    """
    if values not in LIDAR_SENSORS:
        raise DrxError(
            f"The car's lidar gives 64 ranges (LIDAR) or 8 sectors (SECTOR_LIDAR), not {values} values; "
            "the car cannot run this network."
        )
    return LIDAR_SENSORS[values]


def input_names(vehicle: Vehicle, algorithm: str, lidar_values: int | None) -> dict[str, str]:
    """``{"camera": name, "lidar": name}`` of the graph's inputs (lidar only when the car has one)."""
    head = HEAD["sac" if algorithm == "sac" else "ppo"]
    names = {"camera": INPUT_FORMAT.format(head=head, sensor=camera_sensor(vehicle))}
    if lidar_values is not None:
        names["lidar"] = INPUT_FORMAT.format(head=head, sensor=lidar_sensor(lidar_values))
    return names


def output_name(algorithm: str) -> str:
    """The graph's output node for ``algorithm`` (``ppo`` or ``sac``)."""
    return SAC_OUTPUT if algorithm == "sac" else PPO_OUTPUT


class _Writer:
    """Walks drx's torch modules and adds the matching TensorFlow nodes."""

    def __init__(self) -> None:
        self.g = GraphBuilder()

    def act(self, op: str, x: _Tensor) -> _Tensor:
        return _Tensor(self.g.op(op, [x.name], f"drx/{op.lower()}", T=FLOAT), x.hwc, x.columns)

    def bias(self, x: str, bias: Any, hwc: tuple[int, int, int] | None = None) -> _Tensor:
        b = self.g.const(bias.detach().numpy().astype(np.float32), "drx/bias")
        return _Tensor(self.g.op("BiasAdd", [x, b], "drx/bias_add", T=FLOAT, data_format="NHWC"), hwc)

    def conv(self, m: nn.Conv2d, x: _Tensor) -> _Tensor:
        if x.hwc is None:
            raise DrxError("A convolution must follow the camera frame or another convolution.")
        if isinstance(m.padding, str) or m.padding_mode != "zeros" or m.groups != 1 or m.dilation != (1, 1):
            raise DrxError(
                f"The car export supports plain convolutions only (got padding {m.padding!r}, "
                f"groups {m.groups}, dilation {m.dilation})."
            )
        (kh, kw), (sh, sw), (ph, pw) = m.kernel_size, m.stride, m.padding
        h, w, _ = x.hwc
        name = x.name
        if ph or pw:  # explicit zero padding, then a VALID convolution (Conv2D has only SAME/VALID)
            pads = self.g.const(np.array([[0, 0], [ph, ph], [pw, pw], [0, 0]], np.int32), "drx/paddings")
            name = self.g.op("Pad", [name, pads], "drx/pad", T=FLOAT, Tpaddings=INT32)
        weight = self.g.const(
            m.weight.detach().numpy().transpose(2, 3, 1, 0).astype(np.float32), "drx/kernel"
        )
        conv = self.g.op(
            "Conv2D",
            [name, weight],
            "drx/conv2d",
            T=FLOAT,
            strides=[1, sh, sw, 1],
            padding="VALID",
            data_format="NHWC",
            dilations=[1, 1, 1, 1],
            use_cudnn_on_gpu=True,
        )
        hwc = ((h + 2 * ph - kh) // sh + 1, (w + 2 * pw - kw) // sw + 1, m.out_channels)
        if m.bias is None:
            return _Tensor(conv, hwc)
        return self.bias(conv, m.bias, hwc)

    def pool(self, m: nn.AvgPool2d, x: _Tensor) -> _Tensor:
        k = (m.kernel_size,) * 2 if isinstance(m.kernel_size, int) else tuple(m.kernel_size)
        s = (m.stride,) * 2 if isinstance(m.stride, int) else tuple(m.stride)
        if x.hwc is None or m.padding not in (0, (0, 0)) or m.ceil_mode or m.divisor_override is not None:
            raise DrxError("The car export supports average pooling without padding or ceil mode only.")
        h, w, c = x.hwc
        name = self.g.op(
            "AvgPool",
            [x.name],
            "drx/avg_pool",
            T=FLOAT,
            ksize=[1, k[0], k[1], 1],
            strides=[1, s[0], s[1], 1],
            padding="VALID",
            data_format="NHWC",
        )
        return _Tensor(name, ((h - k[0]) // s[0] + 1, (w - k[1]) // s[1] + 1, c))

    def flatten(self, m: nn.Flatten, x: _Tensor) -> _Tensor:
        if m.start_dim != 1 or m.end_dim != -1 or x.hwc is None:
            raise DrxError("The car export supports Flatten(1, -1) of a feature map only.")
        h, w, c = x.hwc
        shape = self.g.const(np.array([-1, h * w * c], np.int32), "drx/flat_shape")
        name = self.g.op("Reshape", [x.name, shape], "drx/flatten", T=FLOAT, Tshape=INT32)
        # TF flattens (H, W, C); torch flattened (C, H, W): column j of TF holds torch feature columns[j].
        columns = np.arange(c * h * w).reshape(c, h, w).transpose(1, 2, 0).ravel()
        return _Tensor(name, None, columns)

    def dense(self, m: nn.Linear, x: _Tensor) -> _Tensor:
        weight = m.weight.detach().numpy()
        if x.columns is not None:
            weight = weight[:, x.columns]
        kernel = self.g.const(np.ascontiguousarray(weight.T, np.float32), "drx/weights")
        matmul = self.g.op(
            "MatMul", [x.name, kernel], "drx/matmul", T=FLOAT, transpose_a=False, transpose_b=False
        )
        if m.bias is None:
            return _Tensor(matmul)
        return self.bias(matmul, m.bias)

    def module(self, m: nn.Module, x: _Tensor) -> _Tensor:
        """Append ``m`` applied to ``x``."""
        if isinstance(m, nn.Sequential):
            for child in m:
                x = self.module(child, x)
            return x
        if isinstance(m, nn.Identity):
            return x
        if isinstance(m, nn.Conv2d):
            return self.conv(m, x)
        if isinstance(m, nn.AvgPool2d):
            return self.pool(m, x)
        if isinstance(m, nn.Flatten):
            return self.flatten(m, x)
        if isinstance(m, nn.Linear):
            return self.dense(m, x)
        if type(m) in ACTIVATIONS:
            return self.act(ACTIVATIONS[type(m)], x)
        raise DrxError(
            f"The car export cannot write the layer {type(m).__name__}; the car cannot run this network."
        )

    def features(self, extractor: Extractor, camera: _Tensor, lidar: _Tensor | None) -> _Tensor:
        """drx's feature extractors (:mod:`drx.train.networks`), and SB3's NatureCNN."""
        if extractor.camera is not None and extractor.lidar is not None and lidar is not None:
            cam = self.features(extractor.camera, camera, None)
            lid = self.module(extractor.lidar, lidar)
            axis = self.g.const(np.array(1, np.int32), "drx/concat_axis")
            return _Tensor(
                self.g.op("ConcatV2", [cam.name, lid.name, axis], "drx/concat", T=FLOAT, N=2, Tidx=INT32)
            )
        if extractor.cnn is not None and extractor.head is not None:
            return self.module(extractor.head, self.module(extractor.cnn, camera))
        raise DrxError(f"The car export cannot write the feature extractor {extractor.name}.")


def policy_to_graph(policy: nn.Module, vehicle: Vehicle) -> bytes:
    """The frozen graph (``model.pb`` bytes) of an SB3 PPO or SAC policy with a drx network.

    :param vehicle: the car the policy drives (sensor, action space).
    :raises DrxError: a layer or operation the car cannot run; nothing is returned then.
    """
    algorithm = "sac" if hasattr(policy, "actor") else "ppo"
    space = policy.observation_space
    lidar_values = int(space["lidar"].shape[0]) if vehicle.lidar else None  # type: ignore[index]
    names = input_names(vehicle, algorithm, lidar_values)
    w = _Writer()
    channels = 2 if vehicle.sensor == "stereo" else 1
    raw = w.g.placeholder(names["camera"], [-1, *FRAME, channels])
    scale = w.g.const(np.array(255.0, np.float32), "drx/pixel_scale")
    camera = _Tensor(w.g.op("RealDiv", [raw, scale], "drx/frame", T=FLOAT), (*FRAME, channels))
    lidar = _Tensor(w.g.placeholder(names["lidar"], [-1, lidar_values])) if lidar_values else None
    out = output_name(algorithm)
    parts = policy_parts(policy, with_lidar=lidar is not None)
    if parts.sde:
        raise DrxError("The car export does not support SAC with state-dependent exploration (use_sde).")
    latent = w.module(parts.latent, w.features(parts.extractor, camera, lidar))
    if algorithm == "sac":
        action = w.act("Tanh", w.module(parts.head, latent))
        w.g.op("Identity", [action.name], out, T=FLOAT)
        return w.g.serialize()
    logits = w.module(parts.head, latent)
    if not vehicle.continuous:
        w.g.op("Softmax", [logits.name], out, T=FLOAT)
        return w.g.serialize()
    low = w.g.const(np.array(-1.0, np.float32), "drx/action_low")
    high = w.g.const(np.array(1.0, np.float32), "drx/action_high")
    clipped = w.g.op(
        "Minimum", [w.g.op("Maximum", [logits.name, low], "drx/max", T=FLOAT), high], "drx/min", T=FLOAT
    )
    w.g.op("Identity", [clipped], out, T=FLOAT)
    return w.g.serialize()
