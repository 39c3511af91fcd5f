"""TensorFlow frozen graphs (``GraphDef`` protobufs) written and read without TensorFlow.

A DeepRacer car loads a policy as a frozen TensorFlow graph, ``model.pb``: a serialized
``tensorflow.GraphDef``. drx builds that message with the ``protobuf`` runtime it already
has (``onnx`` depends on it), from a descriptor of the few TensorFlow messages a frozen
graph uses, declared here field by field. Installing TensorFlow (hundreds of MB) or
TensorBoard (which ships the generated classes, plus grpcio and a web server) only to
write a few kilobytes of protobuf would make ``pip install drx`` much heavier.

The field numbers and types are TensorFlow's, from ``tensorflow/core/framework/``
``graph.proto`` (``GraphDef``: node = 1, versions = 4), ``node_def.proto``, ``attr_value.proto``,
``tensor.proto``, ``tensor_shape.proto``, ``types.proto`` (``DT_FLOAT`` = 1, ``DT_INT32`` = 3)
and ``versions.proto``. Enum fields are declared as ``int32``, which has the same wire form.
Fields drx never writes are left out; reading a graph that has them keeps them as unknown
fields, so nothing is lost.

:data:`MO_2021_TF_OPS` lists the TensorFlow operations drx may put in a graph: every one is
in the "TensorFlow Supported Operations" table of the OpenVINO 2021 Model Optimizer
(openvinotoolkit/openvino ``docs/MO_DG/prepare_model/Supported_Frameworks_Layers.md``), which
the stock DeepRacer car runs (``mo_tf.py``, aws-deepracer/aws-deepracer-model-optimizer-pkg
``model_optimizer_node.py``). :meth:`GraphBuilder.op` refuses any other operation.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from functools import cache
from typing import Any

import numpy as np

from drx.errors import DrxError

DT_FLOAT = 1
DT_INT32 = 3
_DTYPES = {np.dtype(np.float32): DT_FLOAT, np.dtype(np.int32): DT_INT32}

# The operations drx writes; each is in the OpenVINO 2021 Model Optimizer's TensorFlow table (module
# docstring). AddV2 is not: the 2021.1 table has only Add, so drx writes Add.
MO_2021_TF_OPS = frozenset(
    {
        "Add",
        "AvgPool",
        "BiasAdd",
        "ConcatV2",
        "Const",
        "Conv2D",
        "Identity",
        "MatMul",
        "Maximum",
        "Minimum",
        "Mul",
        "Pad",
        "Placeholder",
        "RealDiv",
        "Relu",
        "Reshape",
        "Sigmoid",
        "Softmax",
        "Tanh",
    }
)

# (message, [(field name, number, type, label, message type name)]) in package "tensorflow".
_T = {"int32": 5, "int64": 3, "float": 2, "bool": 8, "string": 9, "bytes": 12, "message": 11}
_OPTIONAL, _REPEATED = 1, 3
_MESSAGES: dict[str, list[tuple[str, int, str, int, str]]] = {
    "TensorShapeProto.Dim": [("size", 1, "int64", _OPTIONAL, ""), ("name", 2, "string", _OPTIONAL, "")],
    "TensorShapeProto": [
        ("dim", 2, "message", _REPEATED, "TensorShapeProto.Dim"),
        ("unknown_rank", 3, "bool", _OPTIONAL, ""),
    ],
    "TensorProto": [
        ("dtype", 1, "int32", _OPTIONAL, ""),
        ("tensor_shape", 2, "message", _OPTIONAL, "TensorShapeProto"),
        ("version_number", 3, "int32", _OPTIONAL, ""),
        ("tensor_content", 4, "bytes", _OPTIONAL, ""),
        ("float_val", 5, "float", _REPEATED, ""),
        ("int_val", 7, "int32", _REPEATED, ""),
    ],
    "AttrValue.ListValue": [
        ("s", 2, "bytes", _REPEATED, ""),
        ("i", 3, "int64", _REPEATED, ""),
        ("f", 4, "float", _REPEATED, ""),
        ("b", 5, "bool", _REPEATED, ""),
        ("type", 6, "int32", _REPEATED, ""),
        ("shape", 7, "message", _REPEATED, "TensorShapeProto"),
        ("tensor", 8, "message", _REPEATED, "TensorProto"),
    ],
    "AttrValue": [  # all in the oneof "value"
        ("list", 1, "message", _OPTIONAL, "AttrValue.ListValue"),
        ("s", 2, "bytes", _OPTIONAL, ""),
        ("i", 3, "int64", _OPTIONAL, ""),
        ("f", 4, "float", _OPTIONAL, ""),
        ("b", 5, "bool", _OPTIONAL, ""),
        ("type", 6, "int32", _OPTIONAL, ""),
        ("shape", 7, "message", _OPTIONAL, "TensorShapeProto"),
        ("tensor", 8, "message", _OPTIONAL, "TensorProto"),
    ],
    "NodeDef.AttrEntry": [
        ("key", 1, "string", _OPTIONAL, ""),
        ("value", 2, "message", _OPTIONAL, "AttrValue"),
    ],
    "NodeDef": [
        ("name", 1, "string", _OPTIONAL, ""),
        ("op", 2, "string", _OPTIONAL, ""),
        ("input", 3, "string", _REPEATED, ""),
        ("device", 4, "string", _OPTIONAL, ""),
        ("attr", 5, "message", _REPEATED, "NodeDef.AttrEntry"),
    ],
    "VersionDef": [
        ("producer", 1, "int32", _OPTIONAL, ""),
        ("min_consumer", 2, "int32", _OPTIONAL, ""),
        ("bad_consumers", 3, "int32", _REPEATED, ""),
    ],
    "GraphDef": [
        ("node", 1, "message", _REPEATED, "NodeDef"),
        ("versions", 4, "message", _OPTIONAL, "VersionDef"),
    ],
}


@cache
def _classes() -> dict[str, Any]:
    """The message classes, built once in a private descriptor pool (so an installed TensorFlow,
    which registers its own ``tensorflow.GraphDef`` in the default pool, never clashes)."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    file = descriptor_pb2.FileDescriptorProto(
        name="drx/tf_graph.proto", package="tensorflow", syntax="proto3"
    )
    made: dict[str, Any] = {}
    for full in _MESSAGES:  # parents are listed after their nested types; create them on demand
        parts = full.split(".")
        parent = None
        for depth in range(1, len(parts) + 1):
            key = ".".join(parts[:depth])
            if key not in made:
                made[key] = (parent.nested_type if parent is not None else file.message_type).add(
                    name=parts[depth - 1]
                )
            parent = made[key]
    for full, fields in _MESSAGES.items():
        message = made[full]
        if full == "NodeDef.AttrEntry":
            message.options.map_entry = True
        oneof = None
        if full == "AttrValue":
            message.oneof_decl.add(name="value")
            oneof = 0
        for name, number, kind, label, type_name in fields:
            field = message.field.add(name=name, number=number, type=_T[kind], label=label)
            if type_name:
                field.type_name = f".tensorflow.{type_name}"
            if oneof is not None:
                field.oneof_index = oneof
    pool = descriptor_pool.DescriptorPool()
    pool.Add(file)
    return {
        name: message_factory.GetMessageClass(pool.FindMessageTypeByName(f"tensorflow.{name}"))
        for name in ("GraphDef", "NodeDef", "AttrValue", "TensorProto", "TensorShapeProto")
    }


def graph_def_class() -> Any:
    """The ``tensorflow.GraphDef`` message class."""
    return _classes()["GraphDef"]


def parse_graph(data: bytes) -> Any:
    """A ``GraphDef`` from a ``.pb`` file's bytes.

    :raises DrxError: the bytes are not a GraphDef.
    """
    from google.protobuf.message import DecodeError

    graph = graph_def_class()()
    try:
        graph.ParseFromString(data)
    except (DecodeError, ValueError) as exc:
        raise DrxError(f"The file is not a TensorFlow frozen graph ({exc}).") from exc
    return graph


def _shape(dims: Iterable[int]) -> Any:
    shape = _classes()["TensorShapeProto"]()
    for d in dims:
        shape.dim.add(size=int(d))
    return shape


def tensor_proto(value: np.ndarray) -> Any:
    """A ``TensorProto`` holding a float32 or int32 array (raw little-endian bytes, as TensorFlow writes)."""
    value = np.ascontiguousarray(value)
    if value.dtype not in _DTYPES:
        raise DrxError(f"A graph constant of type {value.dtype} is not supported; use float32 or int32.")
    tensor = _classes()["TensorProto"](dtype=_DTYPES[value.dtype], tensor_shape=_shape(value.shape))
    tensor.tensor_content = value.astype(value.dtype.newbyteorder("<"), copy=False).tobytes()
    return tensor


def tensor_value(tensor: Any) -> np.ndarray:
    """The array a ``TensorProto`` holds (float32 or int32)."""
    dtype = {v: k for k, v in _DTYPES.items()}.get(tensor.dtype)
    if dtype is None:
        raise DrxError(f"A graph constant of TensorFlow type {tensor.dtype} is not supported.")
    shape = [d.size for d in tensor.tensor_shape.dim]
    if tensor.tensor_content:
        return np.frombuffer(tensor.tensor_content, dtype.newbyteorder("<")).astype(dtype).reshape(shape)
    values = tensor.float_val if dtype == np.float32 else tensor.int_val
    return np.broadcast_to(np.array(values, dtype), shape).copy()


class GraphBuilder:
    """Builds a ``GraphDef`` node by node; every op must be one the 2021 Model Optimizer knows."""

    def __init__(self) -> None:
        self.graph = graph_def_class()()
        self.graph.versions.producer = 1
        self._names: set[str] = set()
        self._n = 0

    def _attr(self, value: Any) -> Any:
        attr = _classes()["AttrValue"]()
        if isinstance(value, bool):
            attr.b = value
        elif isinstance(value, int):
            attr.i = value
        elif isinstance(value, float):
            attr.f = value
        elif isinstance(value, str):
            attr.s = value.encode()
        elif isinstance(value, _Type):
            attr.type = value.code
        elif isinstance(value, _Shape):
            attr.shape.CopyFrom(_shape(value.dims))
        elif isinstance(value, np.ndarray):
            attr.tensor.CopyFrom(tensor_proto(value))
        elif isinstance(value, list | tuple) and all(isinstance(v, int) for v in value):
            attr.list.i.extend(value)
        else:
            raise TypeError(f"unsupported attr value {value!r}")
        return attr

    def unique(self, prefix: str) -> str:
        """A node name not used yet, ``prefix`` itself when free."""
        name = prefix
        while name in self._names:
            self._n += 1
            name = f"{prefix}_{self._n}"
        return name

    def op(self, op: str, inputs: Sequence[str], name: str, **attrs: Any) -> str:
        """Add node ``name`` running ``op`` on ``inputs``; return its name.

        :raises DrxError: ``op`` is not in :data:`MO_2021_TF_OPS`.
        """
        if op not in MO_2021_TF_OPS:
            raise DrxError(
                f"The TensorFlow operation {op} is not one the car's OpenVINO 2021 model optimizer converts; "
                "the car cannot run this network."
            )
        name = self.unique(name)
        node = self.graph.node.add(name=name, op=op)
        node.input.extend(inputs)
        for key, value in attrs.items():
            node.attr[key].CopyFrom(self._attr(value))
        self._names.add(name)
        return name

    def placeholder(self, name: str, dims: Sequence[int]) -> str:
        """A float32 input of shape ``dims`` (-1 = any)."""
        return self.op("Placeholder", [], name, dtype=FLOAT, shape=_Shape(tuple(dims)))

    def const(self, value: np.ndarray, name: str) -> str:
        """A constant float32 or int32 tensor."""
        value = np.asarray(value)
        if value.dtype == np.float64:
            value = value.astype(np.float32)
        if value.dtype == np.int64:
            value = value.astype(np.int32)
        return self.op("Const", [], name, dtype=_Type(_DTYPES[value.dtype]), value=value)

    def serialize(self) -> bytes:
        """The ``GraphDef``'s bytes (the content of ``model.pb``)."""
        return self.graph.SerializeToString(deterministic=True)


class _Type:
    def __init__(self, code: int) -> None:
        self.code = code


class _Shape:
    def __init__(self, dims: tuple[int, ...]) -> None:
        self.dims = dims


FLOAT = _Type(DT_FLOAT)
INT32 = _Type(DT_INT32)
