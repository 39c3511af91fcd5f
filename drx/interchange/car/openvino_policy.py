"""A DeepRacer frozen graph (``model.pb``) as a drx driver, run by OpenVINO as the car runs it.

A model trained on the DeepRacer console or deepracer-for-cloud, imported with
``drx model import``, has no drx checkpoint: only its frozen TensorFlow graph and its
``model_metadata.json``. This driver runs that graph with OpenVINO's TensorFlow frontend
(the ``openvino`` package; no TensorFlow needed) and turns its output into drx actions the
way DeepRacer does:

- Inputs are found as the car's inference node finds them, by name: a camera input has
  ``observation``, ``FRONT_FACING_CAMERA``, ``STEREO_CAMERAS`` or ``LEFT_CAMERA`` in its name, a
  lidar input ``LIDAR`` (aws-deepracer-inference-pkg ``intel_inference_eng.cpp``). Frames go
  in as float32 grey pixels 0..255, NHWC, batch 1. A ``SECTOR_LIDAR`` input of 8 values gets
  drx's 64 ranges folded into DeepRacer's 8 sectors (:meth:`drx.sim.lidar.Lidar.sectors`).
- The first output is read. Discrete models drive the action of highest probability
  (aws-deepracer-navigation-pkg ``deepracer_navigation_node.py``). Continuous models give
  (steering, speed) in [-1, 1], clipped as the car clips them; DeepRacer's SAC graph ends
  before the ``tanh`` its simulator applies (deepracer-simapp ``sac_head.py``:
  ``tf.identity(mean, name="policy")``, then ``tf.tanh`` for the action), so the ``tanh`` is
  applied here unless the graph already ends with one (drx's own car export does).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.interchange.car.tf_graph import parse_graph

OPENVINO_HINT = (
    "Running a DeepRacer model.pb needs OpenVINO; install it with `pip install openvino` and try again."
)
CAMERA_KEYS = ("observation", "FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA")
LIDAR_KEY = "LIDAR"
FRAME = (120, 160)  # (height, width) of drx's (and DeepRacer's) camera frames


def openvino() -> Any:
    """The ``openvino`` module.

    :raises DrxError: OpenVINO is not installed (:data:`OPENVINO_HINT`).
    """
    try:
        import openvino as ov
    except ImportError as exc:
        raise DrxError(OPENVINO_HINT) from exc
    return ov


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def _name(port: Any) -> str:
    names = sorted(port.get_names())
    return names[0].split(":")[0] if names else ""


def ends_with_tanh(graph_bytes: bytes, output: str) -> bool:
    """Whether the graph's node ``output`` is a ``Tanh``, or an ``Identity`` chain down to one."""
    nodes = {n.name: n for n in parse_graph(graph_bytes).node}
    node = nodes.get(output)
    while node is not None and node.op == "Identity" and node.input:
        node = nodes.get(node.input[0].split(":")[0])
    return node is not None and node.op == "Tanh"


class OpenVINOPolicy:
    """Drives drx's car with a DeepRacer ``model.pb`` (module docstring).

    :param graph: the frozen graph file.
    :param metadata: its ``model_metadata.json`` content.
    :raises DrxError: OpenVINO missing, a file OpenVINO cannot read, inputs drx cannot feed, an
        output that does not fit the action space.
    """

    def __init__(self, graph: Path, metadata: dict[str, Any]) -> None:
        ov = openvino()
        graph = Path(graph)
        space = metadata.get("action_space")
        kind = metadata.get("action_space_type", "continuous" if isinstance(space, dict) else "discrete")
        self.continuous = kind == "continuous"
        self.n_actions = 0 if self.continuous else len(space or ())
        core = ov.Core()
        try:
            model = core.read_model(str(graph))
        except Exception as exc:  # noqa: BLE001 - OpenVINO raises RuntimeError subclasses of many kinds
            raise DrxError(
                f"OpenVINO cannot read {graph.name} as a TensorFlow frozen graph ({_first_line(exc)})."
            ) from exc
        self.camera, self.lidar, shapes = "", "", {}
        for port in model.inputs:
            name = _name(port)
            dims = list(port.get_partial_shape())
            if any(key in name for key in CAMERA_KEYS) and not self.camera:
                self.camera = name
            elif LIDAR_KEY in name and not self.lidar:
                self.lidar = name
            else:
                raise DrxError(f"{graph.name} has an input {name!r} that neither a camera nor a lidar feeds.")
            rest = [d.get_length() if d.is_static else -1 for d in dims[1:]]
            if name == self.camera and len(rest) == 3:  # a frame of open size is given drx's 160x120
                rest[:2] = [FRAME[i] if rest[i] < 0 else rest[i] for i in (0, 1)]
            shapes[port] = [1, *rest]
        if not self.camera:
            raise DrxError(
                f"{graph.name} has no camera input ({', '.join(CAMERA_KEYS)}); drx cannot drive it."
            )
        try:
            model.reshape(shapes)  # batch 1, as the car runs it
        except RuntimeError as exc:
            raise DrxError(f"OpenVINO cannot give {graph.name} a batch of 1 ({_first_line(exc)}).") from exc
        ports = {_name(p): p for p in model.inputs}
        if not all(ports[n].get_partial_shape().is_static for n in ports):
            raise DrxError(f"{graph.name} has inputs of open size beyond the batch; drx cannot feed them.")
        camera_shape = list(ports[self.camera].get_shape())
        if len(camera_shape) != 4 or tuple(camera_shape[1:3]) != FRAME:
            raise DrxError(
                f"{graph.name} takes camera input {camera_shape}; drx's camera gives [1, 120, 160, C]."
            )
        self.channels = int(camera_shape[3])
        self.lidar_values = int(ports[self.lidar].get_shape()[-1]) if self.lidar else 0
        try:
            compiled = core.compile_model(model, "CPU", {"INFERENCE_PRECISION_HINT": "f32"})
        except RuntimeError as exc:
            raise DrxError(f"OpenVINO cannot compile {graph.name} for the CPU ({_first_line(exc)}).") from exc
        self.request = compiled.create_infer_request()
        self._ports = {_name(port): port for port in compiled.inputs}
        self.output = compiled.outputs[0]
        self.squash = (
            self.continuous
            and metadata.get("training_algorithm") == "sac"
            and not ends_with_tanh(graph.read_bytes(), _name(self.output))
        )
        self._sectors: Any = None
        try:
            probe = self.outputs(np.zeros((*FRAME, self.channels), np.uint8), np.full(64, 2.0, np.float32))
        except RuntimeError as exc:
            raise DrxError(
                f"OpenVINO cannot run {graph.name} on drx's sensors ({_first_line(exc)})."
            ) from exc
        wanted = 2 if self.continuous else self.n_actions
        if probe.size < wanted or (not self.continuous and probe.size != wanted):
            raise DrxError(
                f"{graph.name} outputs {probe.size} values; its model_metadata.json needs "
                f"{wanted if not self.continuous else 'at least 2'}."
            )

    @classmethod
    def from_file(cls, graph: Path) -> OpenVINOPolicy:
        """The driver of a ``model.pb`` with its ``model_metadata.json`` beside it."""
        meta_path = Path(graph).with_name("model_metadata.json")
        try:
            metadata = json.loads(meta_path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DrxError(f"{meta_path} is missing or unreadable ({exc}); re-import the model.") from exc
        return cls(Path(graph), metadata)

    def outputs(self, camera: np.ndarray, lidar: np.ndarray | None = None) -> np.ndarray:
        """The graph's first output for one camera frame ``(120, 160, C)`` (and lidar scan), flattened."""
        frame = np.asarray(camera, np.float32).reshape(1, *FRAME, self.channels)
        feeds: dict[Any, np.ndarray] = {self._ports[self.camera]: frame}
        if self.lidar:
            ranges = np.asarray(lidar, np.float32).ravel()
            if self.lidar_values != ranges.size:
                ranges = self._fold(ranges)
            feeds[self._ports[self.lidar]] = ranges.reshape(1, -1)
        result = self.request.infer(feeds)
        return np.asarray(result[self.output], np.float32).ravel()

    def _fold(self, ranges: np.ndarray) -> np.ndarray:
        from drx.sim.lidar import LIDAR_SECTORS, Lidar

        if self.lidar_values != LIDAR_SECTORS:
            raise DrxError(
                f"The model's lidar input takes {self.lidar_values} values; drx's lidar gives {ranges.size}."
            )
        if self._sectors is None:
            self._sectors = Lidar()
        return np.asarray(self._sectors.sectors(ranges), np.float32)

    def __call__(self, observation: Any) -> Any:
        """The action for one observation (a frame, or ``{"camera", "lidar"}``)."""
        if isinstance(observation, dict):
            out = self.outputs(observation["camera"], observation.get("lidar"))
        else:
            out = self.outputs(observation)
        if not self.continuous:
            return int(np.argmax(out))
        action = out[:2]
        if self.squash:
            action = np.tanh(action)
        return np.clip(action, -1.0, 1.0).astype(np.float32)
