"""``drx track list|show|import|rm``, including every real DeepRacer route in ../shared/tracks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drx.config import data_home
from drx.sim.track import load_track

from .helpers import fails_unchanged, ok, ok_json

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "tracks"
# name: (closed, direction, centre-line length m, road width m) from ../shared/tracks/README.md
FACTS = {
    "reinvent_base": (True, "ccw", 17.709, 0.76),
    "reInvent2019_wide_cw": (True, "cw", 16.598, 1.06),
    "reInvent2019_track": (True, "ccw", 23.118, 1.07),
    "2022_reinvent_champ": (True, "ccw", 33.275, 0.94),
    "Spain_track": (True, "cw", 59.998, 0.91),
    "Oval_track": (True, "ccw", 19.550, 0.61),
    "Bowtie_track": (True, "ccw", 17.428, 0.61),
    "Canada_Training": (True, "ccw", 21.743, 0.66),
    "China_eval_track": (True, "ccw", 18.141 + 0.090, 0.66),  # drx adds the 0.09 m closing segment
    "Straight_track": (False, "-", 5.707, 0.61),
    # added for the calibration logs; its length is the track_len DeepRacer logs (drfc-2023-02-4workers)
    "FS_June2020": (True, "cw", 52.87, 0.91),
    # added for the simapp 5 race-pace log; 58.61 m is the track_len DeepRacer logs (drfc-2022-june-pro)
    "2022_june_pro": (True, "ccw", 58.61, 1.07),
}


def shared(name: str) -> Path:
    path = SHARED / f"{name}.npy"
    if not path.is_file():
        pytest.skip(f"{path} is absent: the real DeepRacer routes live in ../shared/tracks beside the repo")
    return path


def test_every_shared_route_is_known() -> None:
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent")
    assert {p.stem for p in SHARED.glob("*.npy")} == set(FACTS)


@pytest.mark.parametrize("name", sorted(FACTS))
def test_import_every_real_deepracer_route(name: str) -> None:
    closed, direction, length, width = FACTS[name]
    data = ok_json("track", "import", str(shared(name)))
    assert data["name"] == name and data["source"] == "imported"
    assert data["closed"] is closed and data["direction"] == direction
    assert data["length"] == pytest.approx(length, abs=0.01)
    assert data["width"] == pytest.approx(width, abs=0.01)
    copied = data_home() / "tracks" / f"{name}.npy"
    assert copied.is_file()
    track = load_track(name)  # the simulator finds it by name
    assert track.closed is closed
    shown = ok_json("track", "show", name)
    assert shown["turns"] == len(shown["corners"]) and shown["source"] == "imported"


def test_import_says_what_it_fixed() -> None:
    out = ok("track", "import", str(shared("China_eval_track")), "--name", "china").stdout
    assert "open by 0.090 m" in out
    notes = ok_json("track", "show", "china")["notes"]
    assert any("closing row" in n for n in notes)
    skew = ok_json("track", "import", str(shared("Bowtie_track")))["notes"]
    assert any("not perpendicular" in n for n in skew)
    assert any("repeat" in n for n in skew)
    straight = ok_json("track", "import", str(shared("Straight_track")))["notes"]
    assert any("open" in n for n in straight)


def test_import_fixes_swapped_borders(tmp_path: Path) -> None:
    route = np.load(shared("reinvent_base"))
    swapped = route[:, [0, 1, 4, 5, 2, 3]]
    np.save(tmp_path / "swapped.npy", swapped)
    data = ok_json("track", "import", str(tmp_path / "swapped.npy"))
    assert any("swapped" in n for n in data["notes"])
    fixed = np.load(data_home() / "tracks" / "swapped.npy")
    np.testing.assert_allclose(fixed, route)  # the copy is the fixed route


def test_list_and_show_builtin_tracks(tmp_path: Path) -> None:
    tracks = ok_json("track", "list")
    names = [t["name"] for t in tracks]
    assert "oval" in names and len([t for t in tracks if t["source"] == "built-in"]) >= 5
    assert "oval" in ok("track", "list").stdout
    png = tmp_path / "oval.png"
    data = ok_json("track", "show", "oval", "--png", str(png))
    assert data["length"] > 10 and data["direction"] in ("ccw", "cw") and data["turns"] >= 2
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = ok("track", "show", "oval").stdout
    for word in ("length", "width", "direction", "turns"):
        assert word in out


def test_rm_imported_track() -> None:
    ok("track", "import", str(shared("reinvent_base")), "--name", "rb")
    ok("model", "create", "uses-rb", "--track", "rb")
    fails_unchanged("track", "rm", "rb", contains="uses-rb")
    ok("model", "rm", "uses-rb")
    ok("track", "rm", "rb")
    assert not (data_home() / "tracks" / "rb.npy").exists()
    fails_unchanged("track", "rm", "oval", contains="built in")
    fails_unchanged("track", "rm", "rb", contains="No track named 'rb'")


def test_bad_imports_exit_2_and_change_nothing(tmp_path: Path) -> None:
    np.save(tmp_path / "cols.npy", np.zeros((10, 4)))
    fails_unchanged("track", "import", str(tmp_path / "cols.npy"), contains=("(10, 4)", "(N, 6)"))
    np.save(tmp_path / "short.npy", np.zeros((2, 6)))
    fails_unchanged("track", "import", str(tmp_path / "short.npy"), contains="at least 3")
    nan = np.load(shared("reinvent_base")).copy()
    nan[5, 2] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    fails_unchanged("track", "import", str(tmp_path / "nan.npy"), contains="NaN")
    (tmp_path / "garbage.npy").write_bytes(b"not a numpy file at all")
    fails_unchanged("track", "import", str(tmp_path / "garbage.npy"), contains="not a readable")
    np.save(tmp_path / "pickled.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    fails_unchanged("track", "import", str(tmp_path / "pickled.npy"), contains="Python objects")
    (tmp_path / "route.txt").write_text("1 2 3")
    fails_unchanged("track", "import", str(tmp_path / "route.txt"), contains=".npy")
    fails_unchanged("track", "import", str(tmp_path / "missing.npy"), contains="does not exist")
    fails_unchanged("track", "import", str(shared("reinvent_base")), "--name", "oval", contains="built-in")
    fails_unchanged(
        "track", "import", str(shared("reinvent_base")), "--name", "no good", contains="not allowed"
    )
    ok("track", "import", str(shared("reinvent_base")))
    fails_unchanged("track", "import", str(shared("reinvent_base")), contains="already exists")
    fails_unchanged("track", "show", "atlantis", contains=("atlantis", "oval"))
    fails_unchanged("track", "show", str(tmp_path / "cols.npy"), contains="(N, 6)")
    np.save(tmp_path / "my.route.npy", np.load(shared("reinvent_base")))
    fails_unchanged("track", "import", str(tmp_path / "my.route.npy"), contains="--name")


def test_show_a_route_file_before_importing_it() -> None:
    data = ok_json("track", "show", str(shared("China_eval_track")))
    assert data["source"] == "file" and any("closing row" in n for n in data["notes"])
    assert ok_json("info")["counts"]["imported_tracks"] == 0


def test_track_list_reads_builtin_facts_from_its_cache(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The second listing loads no geometry (the facts come from the data home's cache), gives the
    same facts, and a changed route file is described afresh."""
    import os
    import shutil

    from drx.services import tracks as service

    name, original = next(iter(service.builtin_tracks().items()))
    route = tmp_path / original.name
    shutil.copy(original, route)
    monkeypatch.setattr(service, "builtin_tracks", lambda: {name: route})
    described: list[str] = []
    real_describe = service.describe

    def counting_describe(track: object, *args: object, **kwargs: object) -> service.TrackInfo:
        described.append(name)
        return real_describe(track, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(service, "describe", counting_describe)
    first = [i.to_dict() for i in service.builtin_track_infos()]
    assert (data_home() / "cache" / "builtin-tracks.json").is_file()
    assert [i.to_dict() for i in service.builtin_track_infos()] == first
    assert described == [name]  # the second listing loaded nothing
    st = route.stat()
    os.utime(route, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert [i.to_dict() for i in service.builtin_track_infos()] == first
    assert described == [name, name]  # a changed file is described again
