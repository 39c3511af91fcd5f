"""TensorFlow checkpoints ("tensor bundles") read and written without TensorFlow.

A checkpoint ``NAME.ckpt`` is two files. ``NAME.ckpt.data-00000-of-00001`` holds the tensors'
raw little-endian bytes, one after the other. ``NAME.ckpt.index`` is a LevelDB-style sorted
table: under the empty key (sorted first) a ``BundleHeaderProto``, then, under each tensor's
name, a ``BundleEntryProto``: dtype, shape, shard, offset and size in the data file, and the
masked CRC32C of the tensor's bytes.

Sources: tensorflow ``core/util/tensor_bundle/tensor_bundle.{h,cc}`` (the bundle),
``core/protobuf/tensor_bundle.proto`` (the two messages), ``core/lib/io/table_builder.cc``,
``block_builder.cc``, ``format.{h,cc}`` and ``table_options.h`` (the table). The two messages
are tiny, so they are encoded by hand in proto3's wire form as TensorFlow's C++ writes them
(fields in number order, zero scalars left out, message fields always), byte for byte.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import google_crc32c
import numpy as np

from drx.atomic import atomic_write
from drx.errors import DrxError

# TensorFlow's DataType numbers (core/framework/types.proto) of the types stored as plain bytes.
_DTYPES: dict[int, np.dtype] = {
    1: np.dtype(np.float32), 2: np.dtype(np.float64), 3: np.dtype(np.int32), 4: np.dtype(np.uint8),
    5: np.dtype(np.int16), 6: np.dtype(np.int8), 9: np.dtype(np.int64), 10: np.dtype(np.bool_),
    17: np.dtype(np.uint16), 19: np.dtype(np.float16), 22: np.dtype(np.uint32), 23: np.dtype(np.uint64),
}  # fmt: skip
_DT_NUMBER = {dtype: number for number, dtype in _DTYPES.items()}
_SUPPORTED = "float16/32/64, int8/16/32/64, uint8/16/32/64 or bool"

_MAGIC = 0xDB4775248B80FB57  # format.h kTableMagicNumber
_FOOTER = 48  # format.h Footer: two BlockHandles padded to 40 bytes, then the magic
_TRAILER = 5  # format.h kBlockTrailerSize: compression type byte + masked CRC32C
_BLOCK_SIZE = 262144  # table_options.h default, which BundleWriter keeps
_RESTART_INTERVAL = 16  # table_options.h default (the index block restarts at every key)
# What BundleWriter::Finish writes: one shard, little-endian, kTensorBundleVersion 1, min consumer 0.
HEADER: dict[str, Any] = {"num_shards": 1, "endianness": 0,
                          "version": {"producer": 1, "min_consumer": 0, "bad_consumers": []}}  # fmt: skip


@dataclass(frozen=True)
class TensorEntry:
    """What a checkpoint's ``.index`` says of one tensor (its ``BundleEntryProto``)."""

    name: str
    dtype: np.dtype
    shape: tuple[int, ...]
    shard_id: int
    offset: int
    size: int
    crc32c: int  # as stored: masked


def _crc(data: Any) -> int:
    """The masked CRC32C (core/lib/hash/crc32c.h Mask) TensorFlow stores, of bytes or a uint8 array."""
    crc = google_crc32c.value(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


# ----- protobuf wire form ------------------------------------------------------------------------
_Fields = dict[int, list[Any]]  # field number -> values: ints (varint, fixed32/64) or bytes


def _varint(n: int) -> bytes:
    n &= (1 << 64) - 1  # a negative int takes ten bytes, as in protobuf
    out = bytearray()
    while n >= 0x80:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    return bytes(out) + bytes([n])


def _read_varint(buf: bytes, pos: int) -> tuple[int, int]:
    n = shift = 0
    while pos < len(buf) and shift < 64:
        n, pos, shift = n | (buf[pos] & 0x7F) << shift, pos + 1, shift + 7
        if buf[pos - 1] < 0x80:
            return n, pos
    raise ValueError("a varint runs past its end")


def _int_field(number: int, value: int) -> bytes:
    return _varint(number << 3) + _varint(value) if value else b""  # proto3 leaves zeros out


def _msg_field(number: int, body: bytes) -> bytes:
    return _varint(number << 3 | 2) + _varint(len(body)) + body


def _fields(buf: bytes) -> _Fields:
    fields: _Fields = {}
    pos = 0
    while pos < len(buf):
        tag, pos = _read_varint(buf, pos)
        wire = tag & 7
        value: int | bytes | None = None
        if wire == 0:
            value, pos = _read_varint(buf, pos)
        elif wire in (1, 5):
            width = 8 if wire == 1 else 4
            value, pos = int.from_bytes(buf[pos : pos + width], "little"), pos + width
        elif wire == 2:
            length, pos = _read_varint(buf, pos)
            value, pos = buf[pos : pos + length], pos + length
        if value is None or pos > len(buf):
            raise ValueError("a protobuf message is malformed")
        fields.setdefault(tag >> 3, []).append(value)
    return fields


def _int(fields: _Fields, number: int) -> int:
    value = fields.get(number, [0])[-1]
    if not isinstance(value, int):
        raise ValueError(f"protobuf field {number} is not a number")
    return value - (1 << 64) if value >= 1 << 63 else value


def _msgs(fields: _Fields, number: int) -> list[_Fields]:
    return [_fields(v) for v in fields.get(number, []) if isinstance(v, bytes)]


def _ints(fields: _Fields, number: int) -> list[int]:
    """A repeated int32, packed (as proto3 writes it) or not."""
    out: list[int] = []
    for value in fields.get(number, []):
        pos, packed = 0, value if isinstance(value, bytes) else _varint(value)
        while pos < len(packed):
            n, pos = _read_varint(packed, pos)
            out.append(n)
    return [n - (1 << 64) if n >= 1 << 63 else n for n in out]


# ----- the sorted table --------------------------------------------------------------------------
class _Block:
    """A block being built (block_builder.cc): each key keeps only what differs from the key
    before, except at restart points, where a reader can start."""

    def __init__(self, restart_interval: int = _RESTART_INTERVAL) -> None:
        self.interval, self.count, self.last = restart_interval, 0, b""
        self.buf, self.restarts = bytearray(), [0]

    def add(self, key: bytes, value: bytes) -> None:
        shared = 0
        if self.count < self.interval:
            while shared < min(len(key), len(self.last)) and key[shared] == self.last[shared]:
                shared += 1
        else:
            self.restarts.append(len(self.buf))
            self.count = 0
        self.buf += _varint(shared) + _varint(len(key) - shared) + _varint(len(value)) + key[shared:] + value
        self.last, self.count = key, self.count + 1

    def size(self) -> int:
        return len(self.buf) + 4 * len(self.restarts) + 4

    def finish(self) -> bytes:
        n = len(self.restarts)
        return bytes(self.buf) + struct.pack(f"<{n + 1}I", *self.restarts, n)


def _separator(start: bytes, limit: bytes) -> bytes:
    """table_builder.cc FindShortestSeparator: a short key >= start and < limit."""
    i = 0
    while i < min(len(start), len(limit)) and start[i] == limit[i]:
        i += 1
    if i < min(len(start), len(limit)) and start[i] < 0xFF and start[i] + 1 < limit[i]:
        return start[:i] + bytes([start[i] + 1])
    return start


def _successor(key: bytes) -> bytes:
    """table_builder.cc FindShortSuccessor: a short key >= key."""
    i = next((i for i, byte in enumerate(key) if byte != 0xFF), len(key))
    return key[:i] + bytes([key[i] + 1]) if i < len(key) else key


def _table(rows: Iterable[tuple[bytes, bytes]]) -> bytes:
    """A table (table_builder.cc) of rows sorted by key: data blocks of ~256 KiB, an empty metaindex
    block, an index block mapping a key between two data blocks to the first one's handle, the footer.
    (TensorFlow also cuts a block before a row of 512 KiB or more; no bundle row is that long.)"""
    out = bytearray()

    def write(contents: bytes) -> bytes:  # the block's handle
        handle = _varint(len(out)) + _varint(len(contents))
        out.extend(contents + b"\0" + struct.pack("<I", _crc(contents + b"\0")))
        return handle

    data, index, pending, last = _Block(), _Block(1), b"", b""
    for key, value in rows:
        if pending:  # a block's index key waits for the next block's first key, so it can be short
            index.add(_separator(last, key), pending)
            pending = b""
        data.add(key, value)
        last = key
        if data.size() >= _BLOCK_SIZE:
            pending, data = write(data.finish()), _Block()
    if data.buf:
        pending = write(data.finish())
    metaindex = write(_Block().finish())
    if pending:
        index.add(_successor(last), pending)
    return bytes(out + (metaindex + write(index.finish())).ljust(40, b"\0") + struct.pack("<Q", _MAGIC))


def _rows(data: bytes, handle: bytes) -> Iterator[tuple[bytes, bytes]]:
    """The rows of the block at ``handle`` (format.cc ReadBlock, block.cc), its checksum checked."""
    offset, pos = _read_varint(handle, 0)
    end = offset + _read_varint(handle, pos)[0]
    if end + _TRAILER > len(data) - _FOOTER:
        raise ValueError("a block runs past the footer")
    block, kind = data[offset:end], data[end]
    if _crc(data[offset : end + 1]) != int.from_bytes(data[end + 1 : end + _TRAILER], "little"):
        raise ValueError("a block's checksum does not match")
    if kind != 0:  # Snappy; TensorFlow never compresses a bundle's index (tensor_bundle.cc)
        raise ValueError(f"a block is compressed (type {kind})")
    (restarts,) = struct.unpack_from("<I", block, len(block) - 4)
    pos, key, end = 0, b"", len(block) - 4 * (restarts + 1)
    while pos < end:
        shared, pos = _read_varint(block, pos)
        unshared, pos = _read_varint(block, pos)
        length, pos = _read_varint(block, pos)
        if shared > len(key) or pos + unshared + length > end:
            raise ValueError("a block's entry runs past the block")
        key = key[:shared] + block[pos : pos + unshared]
        yield key, block[pos + unshared : pos + unshared + length]
        pos += unshared + length


# ----- the bundle --------------------------------------------------------------------------------
def _dt_number(dtype: np.dtype, what: str) -> int:
    number = _DT_NUMBER.get(dtype.newbyteorder("="))
    if number is None:
        raise DrxError(f"{what} is of type {dtype}, which drx cannot put in a checkpoint; use {_SUPPORTED}.")
    return number


def _encode_header(header: Mapping[str, Any]) -> bytes:
    version = header.get("version", {})
    bad = b"".join(_varint(v) for v in version.get("bad_consumers", []))  # packed
    body = _int_field(1, version.get("producer", 0)) + _int_field(2, version.get("min_consumer", 0))
    body += _msg_field(3, bad) if bad else b""
    return _int_field(1, header["num_shards"]) + _int_field(2, header["endianness"]) + _msg_field(3, body)


def _encode_entry(e: TensorEntry) -> bytes:
    shape = b"".join(_msg_field(2, _int_field(1, d)) for d in e.shape)  # TensorShapeProto.dim
    crc = b"\x35" + struct.pack("<I", e.crc32c) if e.crc32c else b""  # field 6, fixed32
    dtype = _int_field(1, _dt_number(e.dtype, f"Tensor {e.name!r}"))
    return dtype + _msg_field(2, shape) + b"".join(
        _int_field(n, v) for n, v in ((3, e.shard_id), (4, e.offset), (5, e.size))
    ) + crc  # fmt: skip


def _decode_entry(path: Path, key: bytes, value: bytes) -> TensorEntry:
    f, name = _fields(value), key.decode("utf-8", "surrogateescape")
    if 7 in f:
        raise DrxError(f"{path.name} holds tensor {name!r} in slices (a partitioned variable), which drx "
                       "does not read; save the checkpoint without partitioned variables.")  # fmt: skip
    if _int(f, 1) not in _DTYPES:
        raise DrxError(f"{path.name} holds tensor {name!r} of TensorFlow type {_int(f, 1)} (types.proto), "
                       f"which drx does not read; drx reads {_SUPPORTED} tensors.")  # fmt: skip
    shape = tuple(_int(dim, 1) for proto in _msgs(f, 2) for dim in _msgs(proto, 2))
    entry = TensorEntry(name, _DTYPES[_int(f, 1)], shape, _int(f, 3), _int(f, 4), _int(f, 5), _int(f, 6))
    if min(shape, default=0) < 0 or entry.size != math.prod(shape) * entry.dtype.itemsize or entry.offset < 0:
        raise ValueError(f"tensor {name!r} of shape {shape} cannot take {entry.size} bytes at {entry.offset}")
    return entry


def encode_index(header: Mapping[str, Any], entries: Sequence[TensorEntry]) -> bytes:
    """The bytes of a ``.index`` file, as TensorFlow's ``BundleWriter::Finish`` writes them.

    Format: tensorflow ``core/util/tensor_bundle/tensor_bundle.cc`` (the header under the key ``""``,
    then each tensor's ``BundleEntryProto`` in key order), ``core/protobuf/tensor_bundle.proto``,
    ``core/lib/io/table_builder.cc``, ``block_builder.cc``, ``format.cc`` (the table).

    :param header: the ``BundleHeaderProto`` as :func:`read_index` gives it (:data:`HEADER` for a new one).
    :param entries: the tensors' entries, in any order (the table sorts their names as UTF-8 bytes).
    """
    rows = sorted((e.name.encode("utf-8", "surrogateescape"), _encode_entry(e)) for e in entries)
    keys = [b"", *(key for key, _ in rows)]
    assert all(a < b for a, b in zip(keys, keys[1:], strict=False)), "tensor names: unique, not empty"
    return _table([(b"", _encode_header(header)), *rows])


def read_index(path: Path) -> tuple[dict[str, Any], list[TensorEntry]]:
    """A checkpoint's ``.index``: its header and what it says of each tensor, in key order.

    Format: tensorflow ``core/util/tensor_bundle/tensor_bundle.{h,cc}``,
    ``core/protobuf/tensor_bundle.proto``, ``core/lib/io/format.{h,cc}``, ``block.cc``, ``table.cc``.

    :param path: the ``NAME.ckpt.index`` file.
    :returns: the header, ``{"num_shards", "endianness" (0: little), "version": {"producer",
        "min_consumer", "bad_consumers"}}``, and the tensors' entries.
    :raises DrxError: the file is missing, is not an index or is corrupt, or a tensor is not plain numbers.
    """
    path = Path(path)
    if not path.is_file():
        raise DrxError(f"{path.name} is missing from {path.parent}: give a TensorFlow checkpoint's prefix, "
                       "the path of its .index file without '.index'.")  # fmt: skip
    data = path.read_bytes()
    if len(data) < _FOOTER or int.from_bytes(data[-8:], "little") != _MAGIC:
        raise DrxError(f"{path.name} is not a TensorFlow checkpoint index (it does not end in the table "
                       "magic number); give the .ckpt.index file that TensorFlow wrote.")  # fmt: skip
    try:
        footer = data[-_FOOTER:]
        index_handle = footer[_read_varint(footer, _read_varint(footer, 0)[1])[1] :]  # after the metaindex's
        rows = [row for _, handle in _rows(data, index_handle) for row in _rows(data, handle)]
        if not rows or rows[0][0] != b"" or any(a[0] >= b[0] for a, b in zip(rows, rows[1:], strict=False)):
            raise ValueError("its keys are not the header's then the tensors' in order")
        head = _fields(rows[0][1])
        version = (_msgs(head, 3) or [{}])[-1]
        header = {"num_shards": _int(head, 1), "endianness": _int(head, 2), "version": {
            "producer": _int(version, 1), "min_consumer": _int(version, 2), "bad_consumers": _ints(version, 3)
        }}  # fmt: skip
        return header, [_decode_entry(path, key, value) for key, value in rows[1:]]
    except (ValueError, struct.error) as exc:
        raise DrxError(f"{path.name} is corrupt ({exc}); copy the checkpoint again.") from exc


def read_bundle(prefix: Path, names: Iterable[str] | None = None) -> dict[str, np.ndarray]:
    """The tensors of a checkpoint, checked against the sizes and CRC32Cs its index gives.

    Format: tensorflow ``core/util/tensor_bundle/tensor_bundle.cc`` (``BundleReader``), :func:`read_index`.

    :param prefix: the checkpoint's prefix, e.g. ``model/146_Step-139684.ckpt`` (its files are
        ``PREFIX.index`` and ``PREFIX.data-00000-of-00001``).
    :param names: the tensors to read, in the order the result gives them; all (in key order) when None.
    :raises DrxError: a file is missing, cut short or corrupt, or a tensor is not in the checkpoint.
    """
    index = Path(f"{prefix}.index")
    header, entries = read_index(index)
    version = header["version"]
    if header["endianness"] != 0:
        raise DrxError(f"{index.name} is a big-endian checkpoint, which drx does not read; save it on a "
                       "little-endian machine (x86 or ARM).")  # fmt: skip
    if version["producer"] < 0 or version["min_consumer"] > 1 or 1 in version["bad_consumers"]:
        raise DrxError(f"{index.name} is a checkpoint of a newer format ({version}), which drx does not "
                       "read; save it with TensorFlow 1 or 2.")  # fmt: skip
    by_name = {e.name: e for e in entries}
    order = list(by_name if names is None else names)
    for name in (name for name in order if name not in by_name):
        raise DrxError(f"{index.name} has no tensor named {name!r}; name one of its {len(entries)} tensors.")
    wanted = [by_name[name] for name in order]
    out: dict[str, np.ndarray] = {}
    for shard in sorted({e.shard_id for e in entries}):
        data = Path(f"{prefix}.data-{shard:05d}-of-{header['num_shards']:05d}")
        if not data.is_file():
            raise DrxError(f"{data.name} is missing: the checkpoint's weights were not downloaded; "
                           f"copy the .data file beside {index.name}.")  # fmt: skip
        have, need = data.stat().st_size, max(e.offset + e.size for e in entries if e.shard_id == shard)
        if have < need:
            raise DrxError(f"{data.name} is {have} bytes, the index needs {need}: the file was cut short; "
                           "copy it again.")  # fmt: skip
        with data.open("rb") as f:
            for e in (e for e in wanted if e.shard_id == shard):
                raw = np.empty(e.size, np.uint8)
                f.seek(e.offset)
                f.readinto(raw)  # type: ignore[arg-type]
                if _crc(raw) != e.crc32c:
                    raise DrxError(f"{data.name} is corrupt: tensor {e.name!r} does not match its checksum "
                                   f"in {index.name}; copy the checkpoint again.")  # fmt: skip
                out[e.name] = raw.view(e.dtype.newbyteorder("<")).reshape(e.shape).astype(e.dtype, copy=False)
    return {e.name: out[e.name] for e in wanted}


def write_bundle(prefix: Path, tensors: Mapping[str, np.ndarray]) -> list[Path]:
    """Write a checkpoint that TensorFlow restores: ``PREFIX.index`` and ``PREFIX.data-00000-of-00001``.

    The tensors' bytes follow one another in key order, unpadded (``BundleWriter``'s default
    alignment, 1). Each file is written whole or not at all, the data first as ``BundleWriter::Finish``
    does. Format: tensorflow ``core/util/tensor_bundle/tensor_bundle.cc``; see :func:`encode_index`.

    :param prefix: e.g. ``model/3_Step-1200.ckpt``.
    :param tensors: name -> array of a type of :data:`_DTYPES` (a scalar or an empty array too).
    :returns: the two paths, the ``.index`` first.
    :raises DrxError: a tensor has an empty name or a type a checkpoint cannot hold.
    """
    index, data = Path(f"{prefix}.index"), Path(f"{prefix}.data-00000-of-00001")
    arrays = {name: np.asarray(value) for name, value in tensors.items()}
    for name, array in arrays.items():
        if not name:
            raise DrxError(f"A tensor for {index.name} has an empty name, the key of the header; name it.")
        _dt_number(array.dtype, f"Tensor {name!r} for {index.name}")
    entries, offset = [], 0
    with atomic_write(data, "wb", durable=True) as f:
        for name in sorted(arrays, key=lambda n: n.encode("utf-8", "surrogateescape")):
            array = arrays[name]
            raw = np.ascontiguousarray(array, array.dtype.newbyteorder("<")).reshape(-1).view(np.uint8)
            f.write(raw)
            dtype = array.dtype.newbyteorder("=")
            entries.append(TensorEntry(name, dtype, array.shape, 0, offset, raw.size, _crc(raw)))
            offset += raw.size
    with atomic_write(index, "wb", durable=True) as f:
        f.write(encode_index(HEADER, entries))
    return [index, data]
