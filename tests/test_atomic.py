"""Files written whole or not at all (drx.atomic)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drx.atomic import atomic_write, copy_atomic, write_json_atomic, write_text_atomic


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "results.json"
    write_json_atomic(path, {"lap": 1})
    with pytest.raises(RuntimeError), atomic_write(path) as f:
        f.write('{"lap": 2, "half')
        raise RuntimeError("killed mid-write")
    assert json.loads(path.read_text()) == {"lap": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


def test_writes_replace_whole_files(tmp_path: Path) -> None:
    write_text_atomic(tmp_path / "sub" / "a.txt", "first, longer text")
    write_text_atomic(tmp_path / "sub" / "a.txt", "second")
    assert (tmp_path / "sub" / "a.txt").read_text() == "second"
    with atomic_write(tmp_path / "b.bin", "wb", durable=True) as f:
        f.write(b"\x00\x01")
    copy_atomic(tmp_path / "b.bin", tmp_path / "c.bin")
    assert (tmp_path / "c.bin").read_bytes() == b"\x00\x01"
    assert not [p for p in tmp_path.rglob("*") if p.name.startswith(".")]
