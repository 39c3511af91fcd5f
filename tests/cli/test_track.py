"""``drx track list|show|import|rm``: DeepRacer's routes shipped with drx (by route id and display
name), drx's own tracks, and the routes users import."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from drx.config import data_home
from drx.sim.catalogue import SHIPPED_FOLDERS
from drx.sim.track import load_track

from .helpers import fails, fails_unchanged, ok, ok_json

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "tracks"
SHIPPED = SHIPPED_FOLDERS["deepracer"]
# name: (display name, closed, direction, centre-line length m, road width m) from ../shared/tracks/README.md
# (display names: drx/sim/track_names.py's sources)
FACTS = {
    "reinvent_base": ("re:Invent 2018", True, "ccw", 17.709, 0.76),
    "reInvent2019_wide_cw": ("A to Z Speedway (clockwise)", True, "cw", 16.598, 1.06),
    "reInvent2019_track": ("Smile Speedway", True, "ccw", 23.118, 1.07),
    "2022_reinvent_champ": ("2022 re:Invent Championship", True, "ccw", 33.275, 0.94),
    "Spain_track": ("Circuit de Barcelona-Catalunya", True, "cw", 59.998, 0.91),
    "Oval_track": ("Oval Track", True, "ccw", 19.550, 0.61),
    "Bowtie_track": ("Bowtie Track", True, "ccw", 17.428, 0.61),
    "Canada_Training": ("Toronto Turnpike Training", True, "ccw", 21.743, 0.66),
    # drx adds the 0.09 m closing segment
    "China_eval_track": ("Shanghai Sudu Eval", True, "ccw", 18.141 + 0.090, 0.66),
    "Straight_track": ("Straight track", False, "-", 5.707, 0.61),
    # added for the calibration logs; its length is the track_len DeepRacer logs (drfc-2023-02-4workers)
    "FS_June2020": ("Fumiaki Loop", True, "cw", 52.87, 0.91),
    # added for the simapp 5 race-pace log; 58.61 m is the track_len DeepRacer logs (drfc-2022-june-pro)
    "2022_june_pro": ("BreadCentric Speedway", True, "ccw", 58.61, 1.07),
}


def shipped(name: str) -> Path:
    """A DeepRacer route as drx ships it (a route file to import under another name)."""
    return SHIPPED / f"{name}.npy"


def test_every_shared_route_is_shipped_unchanged() -> None:
    """The package holds the routes of ../shared/tracks byte for byte (tools/sync_deepracer_routes.py)."""
    assert {p.stem for p in SHIPPED.glob("*.npy")} >= set(FACTS)
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent: the real DeepRacer routes live in ../shared/tracks beside the repo")
    for path in SHARED.glob("*.npy"):
        assert shipped(path.stem).read_bytes() == path.read_bytes(), "run tools/sync_deepracer_routes.py"
    assert (SHIPPED / "NOTICE.md").is_file()


def test_a_fresh_install_lists_deepracer_tracks_by_route_id_and_display_name() -> None:
    listed = {t["name"]: t for t in ok_json("track", "list", "--source", "deepracer")}
    assert set(listed) == {p.stem for p in SHIPPED.glob("*.npy")}
    for name, (display, closed, direction, length, width) in FACTS.items():
        t = listed[name]
        assert (t["display_name"], t["source"], t["closed"], t["direction"]) == (
            display,
            "deepracer",
            closed,
            direction,
        )
        assert t["length"] == pytest.approx(length, abs=0.01), name
        assert t["width"] == pytest.approx(width, abs=0.01), name
    everything = ok_json("track", "list")
    sources = [t["source"] for t in everything]
    assert sources == sorted(
        sources, key=["deepracer", "drx", "imported"].index
    )  # grouped, DeepRacer's first
    assert {"oval", "kidney", "technical"} <= {t["name"] for t in everything if t["source"] == "drx"}


def test_list_fits_80_columns_and_names_what_it_hid() -> None:
    out = ok("track", "list").stdout
    assert max(len(line) for line in out.splitlines()) <= 80
    for text in (
        "reInvent2019_wide_cw",
        "A to Z Speedway (clockwise)",
        "Circuit de Barcelona-Catalunya",
        "oval",
    ):
        assert text in out
    assert "hidden: source, width (--wide shows every column)" in out
    wide = ok("track", "list", "--wide").stdout
    assert "DeepRacer" in wide and "hidden" not in wide


def test_list_search_and_source() -> None:
    names = [t["name"] for t in ok_json("track", "list", "--search", "smile")]
    assert names == ["reInvent2019_track", "reInvent2019_track_cw", "reInvent2019_track_ccw"]
    speedways = {t["name"] for t in ok_json("track", "list", "-s", "SPEEDWAY")}
    assert {"reInvent2019_wide_cw", "reInvent2019_track", "2022_june_pro", "speedway"} <= speedways
    assert "reinvent_base" in {t["name"] for t in ok_json("track", "list", "--search", "reinvent 2018")}
    drx_own = ok_json("track", "list", "--source", "drx")
    assert drx_own and {t["source"] for t in drx_own} == {"drx"}
    assert ok_json("track", "list", "--source", "imported") == []
    assert "No tracks matching 'atlantis'" in ok("track", "list", "--search", "atlantis").stdout
    fails("track", "list", "--source", "aws", contains=("--source 'aws'", "deepracer"))


@pytest.mark.parametrize(
    ("typed", "name"),
    [
        ("reInvent2019_wide_cw", "reInvent2019_wide_cw"),
        ("reinvent2019_WIDE_cw", "reInvent2019_wide_cw"),
        ("A to Z Speedway (clockwise)", "reInvent2019_wide_cw"),
        ("a to z speedway (Clockwise)", "reInvent2019_wide_cw"),
        ("A to Z Speedway CW", "reInvent2019_wide_cw"),
        ("A to Z Speedway", "reInvent2019_wide"),  # the console's track, not a direction variant
        ("A to Z Speedway counter-clockwise", "reInvent2019_wide_ccw"),
        ("RL Speedway", "2022_summit_speedway"),
        ("Smile Speedway", "reInvent2019_track"),
        ("circuit de barcelona-catalunya", "Spain_track"),
        ("oval", "oval"),
        ("Oval Track", "Oval_track"),
    ],
)
def test_show_takes_the_route_id_or_the_display_name(typed: str, name: str) -> None:
    shown = ok_json("track", "show", typed)
    assert shown["name"] == name and shown["turns"] == len(shown["corners"])


def test_show_a_deepracer_track_and_draw_it(tmp_path: Path) -> None:
    png = tmp_path / "a-to-z.png"
    data = ok_json("track", "show", "reInvent2019_wide_cw", "--png", str(png))
    assert data["display_name"] == "A to Z Speedway (clockwise)" and data["direction"] == "cw"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = ok("track", "show", "A to Z Speedway (clockwise)").stdout
    for word in ("display name", "A to Z Speedway (clockwise)", "DeepRacer", "length", "width", "turns"):
        assert word in out


def test_unknown_names_say_what_is_near_in_one_sentence() -> None:
    err = fails_unchanged("track", "show", "smile speedwy", contains="No track named 'smile speedwy'")
    assert "'reInvent2019_track' (Smile Speedway)" in err and "`drx track list`" in err
    err = fails_unchanged("track", "show", "atlantis", contains=("atlantis", "`drx track list`"))
    # a DeepRacer route drx can name but does not ship: how to get it
    fails_unchanged("track", "show", "H_track", contains=("H track", "drx track import H_track.npy"))
    fails_unchanged(
        "model", "create", "m", "--track", "Toronto Turnpike Eval", contains=("Canada_Eval", "does not ship"),
    )  # fmt: skip
    # a track only shipped as its two direction variants: which one
    fails_unchanged(
        "track", "show", "Forever Raceway",
        contains=("Forever Raceway (clockwise)", "Forever Raceway (counter-clockwise)"),
    )  # fmt: skip


def test_model_create_takes_the_display_name_or_the_route_id_without_an_import() -> None:
    by_display = ok_json("model", "create", "m1", "--track", "A to Z Speedway (clockwise)")
    by_route = ok_json("model", "create", "m2", "--track", "reInvent2019_wide_cw")
    assert by_display["track"] == by_route["track"] == "reInvent2019_wide_cw"  # the canonical route id
    assert by_display["track_sha256"] == by_route["track_sha256"]
    assert "A to Z Speedway (clockwise)" in ok("model", "show", "m1").stdout
    assert ok_json("info")["counts"]["imported_tracks"] == 0
    fails_unchanged("model", "create", "m3", "--track", "Spain track", contains="Spain_track")


@pytest.mark.parametrize("name", sorted(FACTS))
def test_import_every_real_deepracer_route_under_another_name(name: str) -> None:
    """Importing still fixes every route's quirks; an upstream route keeps its display name."""
    display, closed, direction, length, width = FACTS[name]
    data = ok_json("track", "import", str(shipped(name)), "--name", f"my-{name}")
    assert data["name"] == f"my-{name}" and data["source"] == "imported" and data["display_name"] == display
    assert data["closed"] is closed and data["direction"] == direction
    assert data["length"] == pytest.approx(length, abs=0.01)
    assert data["width"] == pytest.approx(width, abs=0.01)
    assert (data_home() / "tracks" / f"my-{name}.npy").is_file()
    assert load_track(f"my-{name}").closed is closed  # the simulator finds it by name
    shown = ok_json("track", "show", f"my-{name}")
    assert shown["turns"] == len(shown["corners"]) and shown["source"] == "imported"


def test_import_refuses_to_shadow_a_shipped_name(tmp_path: Path) -> None:
    route = str(shipped("reinvent_base"))
    fails_unchanged("track", "import", route, contains=("re:Invent 2018", "ships", "--name"))
    fails_unchanged("track", "import", route, "--name", "Reinvent_Base", contains="--name")
    fails_unchanged("track", "import", route, "--name", "OvalTrack", contains="Oval Track")
    fails_unchanged("track", "import", route, "--name", "oval", contains=("drx's own tracks", "--name"))
    ok("track", "import", route, "--name", "rb")
    # a DeepRacer route drx does not ship imports under its own name and gets its display name
    shutil.copy(shipped("Oval_track"), tmp_path / "H_track.npy")
    data = ok_json("track", "import", str(tmp_path / "H_track.npy"))
    assert (data["name"], data["display_name"]) == ("H_track", "H track")
    assert ok_json("track", "show", "H track")["name"] == "H_track"
    imported = ok_json("track", "list", "--source", "imported")
    expected = [("H_track", "H track"), ("rb", "re:Invent 2018")]
    assert [(t["name"], t["display_name"]) for t in imported] == expected


def test_import_says_what_it_fixed() -> None:
    out = ok("track", "import", str(shipped("China_eval_track")), "--name", "china").stdout
    assert "open by 0.090 m" in out
    notes = ok_json("track", "show", "china")["notes"]
    assert any("closing row" in n for n in notes)
    skew = ok_json("track", "import", str(shipped("Bowtie_track")), "--name", "bowtie")["notes"]
    assert any("not perpendicular" in n for n in skew)
    assert any("repeat" in n for n in skew)
    straight = ok_json("track", "import", str(shipped("Straight_track")), "--name", "straight")["notes"]
    assert any("open" in n for n in straight)


def test_import_fixes_swapped_borders(tmp_path: Path) -> None:
    route = np.load(shipped("reinvent_base"))
    swapped = route[:, [0, 1, 4, 5, 2, 3]]
    np.save(tmp_path / "swapped.npy", swapped)
    data = ok_json("track", "import", str(tmp_path / "swapped.npy"))
    assert any("swapped" in n for n in data["notes"])
    fixed = np.load(data_home() / "tracks" / "swapped.npy")
    np.testing.assert_allclose(fixed, route)  # the copy is the fixed route


def test_list_and_show_drx_tracks(tmp_path: Path) -> None:
    tracks = ok_json("track", "list")
    names = [t["name"] for t in tracks]
    assert "oval" in names and len([t for t in tracks if t["source"] == "drx"]) >= 5
    assert "oval" in ok("track", "list").stdout
    png = tmp_path / "oval.png"
    data = ok_json("track", "show", "oval", "--png", str(png))
    assert data["length"] > 10 and data["direction"] in ("ccw", "cw") and data["turns"] >= 2
    assert data["source"] == "drx" and data["display_name"] is None
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = ok("track", "show", "oval").stdout
    for word in ("length", "width", "direction", "turns"):
        assert word in out


def test_rm_imported_track() -> None:
    ok("track", "import", str(shipped("reinvent_base")), "--name", "rb")
    ok("model", "create", "uses-rb", "--track", "rb")
    fails_unchanged("track", "rm", "rb", contains="uses-rb")
    ok("model", "rm", "uses-rb")
    ok("track", "rm", "rb")
    assert not (data_home() / "tracks" / "rb.npy").exists()
    fails_unchanged("track", "rm", "oval", contains="shipped with drx")
    fails_unchanged("track", "rm", "Smile Speedway", contains=("reInvent2019_track", "shipped with drx"))
    fails_unchanged("track", "rm", "rb", contains="No track named 'rb'")


def test_bad_imports_exit_2_and_change_nothing(tmp_path: Path) -> None:
    np.save(tmp_path / "cols.npy", np.zeros((10, 4)))
    fails_unchanged("track", "import", str(tmp_path / "cols.npy"), contains=("(10, 4)", "(N, 6)"))
    np.save(tmp_path / "short.npy", np.zeros((2, 6)))
    fails_unchanged("track", "import", str(tmp_path / "short.npy"), contains="at least 3")
    nan = np.load(shipped("reinvent_base")).copy()
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
    fails_unchanged(
        "track", "import", str(shipped("reinvent_base")), "--name", "no good", contains="not allowed"
    )
    ok("track", "import", str(shipped("reinvent_base")), "--name", "rb")
    fails_unchanged(
        "track", "import", str(shipped("reinvent_base")), "--name", "rb", contains="already exists"
    )
    fails_unchanged("track", "show", str(tmp_path / "cols.npy"), contains="(N, 6)")
    np.save(tmp_path / "my.route.npy", np.load(shipped("reinvent_base")))
    fails_unchanged("track", "import", str(tmp_path / "my.route.npy"), contains="--name")


def test_show_a_route_file_before_importing_it() -> None:
    data = ok_json("track", "show", str(shipped("China_eval_track")))
    assert data["source"] == "file" and any("closing row" in n for n in data["notes"])
    assert data["display_name"] == "Shanghai Sudu Eval"
    assert ok_json("info")["counts"]["imported_tracks"] == 0


def test_track_list_reads_shipped_facts_from_its_cache(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The second listing reads no route (the facts come from the data home's cache), gives the
    same facts, and a changed route file is measured afresh; the facts are those ``show`` gives."""
    import os

    from drx.services import tracks as service
    from drx.sim import track as sim_track
    from drx.sim.catalogue import TrackEntry

    route = tmp_path / "Spain_track.npy"
    shutil.copy(shipped("Spain_track"), route)
    monkeypatch.setattr(service, "shipped_tracks", lambda: [TrackEntry("Spain_track", "deepracer", route)])
    measured: list[Path] = []
    real = sim_track.route_facts

    def counting(path: Path) -> dict:
        measured.append(path)
        return real(path)

    monkeypatch.setattr(sim_track, "route_facts", counting)
    first = [i.to_dict() for i in service.shipped_track_infos()]
    assert (data_home() / "cache" / service.FACTS_CACHE).is_file()
    assert [i.to_dict() for i in service.shipped_track_infos()] == first
    assert measured == [route]  # the second listing read nothing
    st = route.stat()
    os.utime(route, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert [i.to_dict() for i in service.shipped_track_infos()] == first
    assert measured == [route, route]  # a changed file is measured again
    shown = ok_json("track", "show", "Spain_track")
    for key in ("length", "width", "width_min", "width_max", "direction", "closed", "waypoints"):
        assert first[0][key] == pytest.approx(shown[key], abs=1e-6), key


def test_every_command_that_takes_a_track_takes_its_display_name(tmp_path: Path) -> None:
    """reward validate, sim camera, track best-lap and leaderboard name the route id of what was typed."""
    report = ok_json("reward", "validate", "follow_center_line", "--track", "A to Z Speedway (clockwise)")
    assert report["track"] == "reInvent2019_wide_cw" and report["ok"]
    camera = ok_json(
        "sim", "camera", "Smile Speedway", "--progress", "50", "--png", str(tmp_path / "cam.png")
    )
    assert camera["track"] == "reInvent2019_track" and camera["mean_grey"] > 0
    best = ok_json("track", "best-lap", "re:Invent 2018")
    assert best["track"] == "reinvent_base" and best["lap_time"] > 0
    board = ok_json("leaderboard", "--track", "Smile Speedway")
    assert board["track"] == "reInvent2019_track" and board["rows"] == []
    fails("leaderboard", "--track", "Smile Speedwy", contains="Smile Speedway")
