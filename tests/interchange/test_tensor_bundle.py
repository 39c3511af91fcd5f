"""TensorFlow checkpoints (tensor bundles) read and written without TensorFlow.

The real ``.ckpt.index`` files of two DeepRacer models (``../shared/deepracer-models`` beside the
checkout; their ``.data`` files are absent) are decoded and re-encoded byte for byte; bundles
written here are read back, and damaged ones are refused with one sentence naming the damage.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from drx.errors import DrxError
from drx.interchange.deepracer.tensor_bundle import (
    HEADER,
    TensorEntry,
    _read_varint,
    _rows,
    _separator,
    _successor,
    _table,
    encode_index,
    read_bundle,
    read_index,
    write_bundle,
)

SHARED_MODELS = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-models"
CONTINUOUS = SHARED_MODELS / "console-2023-continuous-shallow" / "model"
DISCRETE = SHARED_MODELS / "workshop-2019-discrete-shallow" / "model"
REAL_INDEXES = [
    CONTINUOUS / "146_Step-139684.ckpt.index",
    CONTINUOUS / "140_Step-123889.ckpt.index",
    DISCRETE / "11_Step-38428.ckpt.index",
]
ONLINE = "main_level/agent/main/online"
# DeepRacer's shallow network (DEEP_CONVOLUTIONAL_NETWORK_SHALLOW), the same in both towers.
TRUNK = {
    "FRONT_FACING_CAMERA/Conv2d_0/kernel": (8, 8, 1, 32), "FRONT_FACING_CAMERA/Conv2d_0/bias": (32,),
    "FRONT_FACING_CAMERA/Conv2d_2/kernel": (4, 4, 32, 64), "FRONT_FACING_CAMERA/Conv2d_2/bias": (64,),
    "FRONT_FACING_CAMERA/Conv2d_4/kernel": (3, 3, 64, 64), "FRONT_FACING_CAMERA/Conv2d_4/bias": (64,),
    "middleware_fc_embedder/Dense_0/kernel": (11264, 512), "middleware_fc_embedder/Dense_0/bias": (512,),
    "gradients_from_head_0-0_rescalers": (),
}  # fmt: skip
VALUE_HEAD = {"v_values_head_0/output/kernel": (512, 1), "v_values_head_0/output/bias": (1,)}
CONTINUOUS_HEAD = {
    "ppo_head_0/policy_mean/kernel": (512, 2), "ppo_head_0/policy_mean/bias": (2,),
    "ppo_head_0/policy_log_std": (1, 2),
}  # fmt: skip
DISCRETE_HEAD = {"ppo_head_0/policy_fc/kernel": (512, 9), "ppo_head_0/policy_fc/bias": (9,)}


def _real(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"{SHARED_MODELS} is absent: real DeepRacer checkpoints (model/*.ckpt.index) live in "
                    "../shared/deepracer-models beside the checkout")  # fmt: skip
    return path


def _towers(head: dict[str, tuple[int, ...]]) -> dict[str, tuple[int, ...]]:
    value = {f"{ONLINE}/network_0/{k}": v for k, v in {**TRUNK, **VALUE_HEAD}.items()}
    return value | {f"{ONLINE}/network_1/{k}": v for k, v in {**TRUNK, **head}.items()}


def _one_sentence(exc: pytest.ExceptionInfo[DrxError]) -> str:
    message = str(exc.value)
    assert message.endswith(".") and ". " not in message and "\n" not in message, message
    return message


@pytest.mark.parametrize(
    ("path", "head"),
    list(zip(REAL_INDEXES, [CONTINUOUS_HEAD, CONTINUOUS_HEAD, DISCRETE_HEAD], strict=True)),
    ids=[p.name for p in REAL_INDEXES],
)
def test_real_index_holds_the_two_towers(path: Path, head: dict[str, tuple[int, ...]]) -> None:
    header, entries = read_index(_real(path))
    assert header == {"num_shards": 1, "endianness": 0,
                      "version": {"producer": 1, "min_consumer": 0, "bad_consumers": []}}  # fmt: skip
    assert {e.name: e.shape for e in entries} == _towers(head)  # no global_step, no optimiser state
    assert [e.name for e in entries] == sorted(e.name for e in entries)
    assert {e.dtype for e in entries} == {np.dtype(np.float32)} and {e.shard_id for e in entries} == {0}
    # TensorFlow wrote the tensors one after the other in key order, unpadded.
    assert [e.offset for e in entries] == [0, *np.cumsum([e.size for e in entries])[:-1]]
    assert all(e.size == 4 * np.prod(e.shape, dtype=int) for e in entries)
    # The rescalers are 1.0 in every model, so their masked CRC32C is known without the .data file.
    rescalers = [e for e in entries if e.name.endswith("gradients_from_head_0-0_rescalers")]
    assert [e.crc32c for e in rescalers] == [0x2BDAA581, 0x2BDAA581]


def test_drx_checksums_as_tensorflow_does(tmp_path: Path) -> None:
    index, _ = write_bundle(tmp_path / "one.ckpt", {"one": np.float32(1.0), "two": np.float32(2.0)})
    one, two = read_index(index)[1]
    assert one.crc32c == 0x2BDAA581 != two.crc32c  # what TensorFlow stored for the real models' 1.0f


@pytest.mark.parametrize("path", REAL_INDEXES, ids=lambda p: p.name)
def test_real_index_is_encoded_byte_for_byte(path: Path) -> None:
    data = _real(path).read_bytes()
    assert encode_index(*read_index(path)) == data
    total = {"11_Step-38428.ckpt.index": 46736688}.get(path.name, 46722332)  # ~45 MiB of weights
    assert max(e.offset + e.size for e in read_index(path)[1]) == total


def test_real_checkpoint_without_its_data_is_refused() -> None:
    prefix = _real(REAL_INDEXES[0]).with_suffix("")
    if Path(f"{prefix}.data-00000-of-00001").exists():  # the weights came after all: they read, CRCs match
        assert {k: v.shape for k, v in read_bundle(prefix).items()} == _towers(CONTINUOUS_HEAD)
        return
    with pytest.raises(DrxError) as exc:
        read_bundle(prefix)
    assert _one_sentence(exc) == (
        "146_Step-139684.ckpt.data-00000-of-00001 is missing: the checkpoint's weights were not downloaded; "
        "copy the .data file beside 146_Step-139684.ckpt.index."
    )


def _tensors() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    return {
        "net/conv/kernel": rng.standard_normal((3, 3, 1, 4)).astype(np.float32),
        "net/conv/bias": rng.standard_normal(4).astype(np.float32),
        "net/scale": np.float64(2.5),  # a scalar
        "net/empty": np.zeros((0, 3), np.int32),  # TensorFlow saves 0-size tensors: size 0, no bytes
        "net/step": np.array([1, -2, 2**40], np.int64),
        "net/big_endian": np.array([1.5, -3.25], ">f8"),
        "net/mask": np.array([True, False, True]),
        "a_first": rng.integers(-100, 100, (2, 5), dtype=np.int32),
    }


def test_write_then_read_round_trips(tmp_path: Path) -> None:
    tensors = _tensors()
    prefix = tmp_path / "ckpt" / "3_Step-1200.ckpt"
    paths = write_bundle(prefix, tensors)
    assert paths == [Path(f"{prefix}.index"), Path(f"{prefix}.data-00000-of-00001")]
    assert sorted(p.name for p in prefix.parent.iterdir()) == sorted(p.name for p in paths)  # no temp files
    back = read_bundle(prefix)
    assert list(back) == sorted(tensors)
    for name, value in tensors.items():
        assert back[name].dtype == value.dtype.newbyteorder("=") and back[name].shape == np.shape(value), name
        np.testing.assert_array_equal(back[name], value)
    back["a_first"][0, 0] = 1000  # the arrays are the caller's to change
    header, entries = read_index(paths[0])
    assert header == HEADER
    assert [e.name for e in entries] == sorted(tensors)
    assert [e.offset for e in entries] == [0, *np.cumsum([e.size for e in entries])[:-1]]
    # a_first 40 bytes, net/big_endian 16, net/conv/bias 16, net/conv/kernel 144, net/empty 0, ...
    assert paths[1].stat().st_size == sum(e.size for e in entries) == 40 + 16 + 16 + 144 + 0 + 3 + 8 + 24
    assert next(e for e in entries if e.name == "net/empty") == TensorEntry(
        "net/empty", np.dtype(np.int32), (0, 3), 0, 40 + 16 + 16 + 144, 0, 0xA282EAD8  # the mask of CRC 0
    )
    assert encode_index(header, entries) == paths[0].read_bytes()
    picked = read_bundle(prefix, iter(["net/step", "a_first"]))
    assert list(picked) == ["net/step", "a_first"]
    np.testing.assert_array_equal(picked["a_first"], tensors["a_first"])


def test_a_big_index_spans_several_blocks(tmp_path: Path) -> None:
    tensors = {f"tower_{i % 7}/layer_{i:05d}/{'w' * 80}": np.full(i % 3, i, np.float32) for i in range(3000)}
    index, _ = write_bundle(tmp_path / "big.ckpt", tensors)
    data = index.read_bytes()
    footer = data[-48:]
    index_handle = footer[_read_varint(footer, _read_varint(footer, 0)[1])[1] :]  # after the metaindex's
    separators = [key for key, _ in _rows(data, index_handle)]
    assert len(separators) == 2 and separators[0].startswith(b"tower_") and separators[1] == b"u"
    assert encode_index(*read_index(index)) == index.read_bytes()
    back = read_bundle(tmp_path / "big.ckpt")
    assert list(back) == sorted(tensors) and all((back[k] == v).all() for k, v in tensors.items())


def test_index_keys_between_blocks_are_short() -> None:
    assert _separator(b"the quick brown fox", b"the who") == b"the r"  # LevelDB's own example
    assert _separator(b"abc", b"abcd") == b"abc"  # a prefix stays
    assert _separator(b"ab1", b"ab2") == b"ab1"  # no room between
    assert _successor(b"main_level/x") == b"n" and _successor(b"\xff\xffa") == b"\xff\xffb"
    assert _successor(b"\xff") == b"\xff"


def test_cut_data_is_refused(tmp_path: Path) -> None:
    _, data = write_bundle(tmp_path / "m.ckpt", _tensors())
    size = data.stat().st_size
    os.truncate(data, size - 1)
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt")
    assert f"m.ckpt.data-00000-of-00001 is {size - 1} bytes, the index needs {size}" in _one_sentence(exc)


def test_flipped_byte_is_refused_naming_the_tensor(tmp_path: Path) -> None:
    tensors = _tensors()
    _, data = write_bundle(tmp_path / "m.ckpt", tensors)
    entry = next(e for e in read_index(tmp_path / "m.ckpt.index")[1] if e.name == "net/conv/kernel")
    raw = bytearray(data.read_bytes())
    raw[entry.offset + 5] ^= 0x10
    data.write_bytes(raw)
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt")
    message = _one_sentence(exc)
    assert "m.ckpt.data-00000-of-00001 is corrupt" in message
    assert "tensor 'net/conv/kernel' does not match its checksum" in message
    assert set(read_bundle(tmp_path / "m.ckpt", ["net/conv/bias"])) == {"net/conv/bias"}  # the rest reads


def test_missing_files_are_refused(tmp_path: Path) -> None:
    index, data = write_bundle(tmp_path / "m.ckpt", {"w": np.ones(3, np.float32)})
    data.unlink()
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt")
    assert "m.ckpt.data-00000-of-00001 is missing: the checkpoint's weights were not downloaded" in (
        _one_sentence(exc)
    )
    with pytest.raises(DrxError) as exc:
        read_bundle(index)  # the .index's path instead of the prefix
    assert "m.ckpt.index.index is missing" in _one_sentence(exc)
    assert "without '.index'" in str(exc.value)


def test_corrupt_index_is_refused(tmp_path: Path) -> None:
    index, _ = write_bundle(tmp_path / "m.ckpt", _tensors())
    good = index.read_bytes()
    index.write_bytes(good[:-1] + b"\x00")  # the footer's magic number
    with pytest.raises(DrxError) as exc:
        read_index(index)
    assert "m.ckpt.index is not a TensorFlow checkpoint index" in _one_sentence(exc)
    index.write_bytes(good[:40] + bytes([good[40] ^ 1]) + good[41:])  # a byte of a tensor's entry
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt")
    assert "m.ckpt.index is corrupt (a block's checksum does not match)" in _one_sentence(exc)
    footer = bytearray(good[-48:])
    footer[3:5] = b"\xff\x7f"  # the index block's handle now points past the file
    index.write_bytes(good[:-48] + footer)
    with pytest.raises(DrxError) as exc:
        read_index(index)
    assert "m.ckpt.index is corrupt (" in _one_sentence(exc)


def _index_with(entry: bytes, path: Path) -> Path:
    header = bytes.fromhex("0801") + bytes.fromhex("1a020801")  # num_shards 1, version {producer 1}
    path.write_bytes(_table([(b"", header), (b"s", entry)]))
    return path


def test_unsupported_tensors_are_refused(tmp_path: Path) -> None:
    with pytest.raises(DrxError) as exc:  # DT_STRING, shape [2]
        read_index(_index_with(bytes.fromhex("0807120412020802"), tmp_path / "s.ckpt.index"))
    assert "s.ckpt.index holds tensor 's' of TensorFlow type 7" in _one_sentence(exc)
    with pytest.raises(DrxError) as exc:  # a partitioned variable's slices
        read_index(_index_with(bytes.fromhex("080112003a020a00"), tmp_path / "p.ckpt.index"))
    assert "holds tensor 's' in slices" in _one_sentence(exc)
    with pytest.raises(DrxError) as exc:
        write_bundle(tmp_path / "w.ckpt", {"ok": np.ones(2, np.float32), "names": np.array(["a", "b"])})
    assert "Tensor 'names' for w.ckpt.index is of type <U1" in _one_sentence(exc)
    with pytest.raises(DrxError) as exc:
        write_bundle(tmp_path / "w.ckpt", {"z": np.ones(2, np.complex64)})
    assert "use float16/32/64" in _one_sentence(exc)
    assert not list(tmp_path.glob("w.ckpt*"))  # nothing written


def test_unknown_tensor_name_is_refused(tmp_path: Path) -> None:
    write_bundle(tmp_path / "m.ckpt", {"w": np.ones(3, np.float32)})
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt", ["w", "v"])
    assert "m.ckpt.index has no tensor named 'v'" in _one_sentence(exc)


def test_big_endian_bundles_are_refused(tmp_path: Path) -> None:
    write_bundle(tmp_path / "m.ckpt", {"w": np.ones(3, np.float32)})
    header, entries = read_index(tmp_path / "m.ckpt.index")
    (tmp_path / "m.ckpt.index").write_bytes(encode_index({**header, "endianness": 1}, entries))
    with pytest.raises(DrxError) as exc:
        read_bundle(tmp_path / "m.ckpt")
    assert "m.ckpt.index is a big-endian checkpoint" in _one_sentence(exc)
