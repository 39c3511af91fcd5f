"""Which DeepRacer simulator recorded a log, from its metadata (drx.calibration.log_metadata): the robomaker
log's ``simapp_version`` line, log-guru's ``.meta.json``, the console's ``model_metadata.json``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drx.calibration import log_metadata
from drx.calibration.log_metadata import (
    car_for_version,
    check_simulator,
    choose_simulator,
    simulator_of_log,
)
from drx.errors import DrxError
from tests.calibration._logs import (
    CONSOLE_CSV,
    CONSOLE_RUN,
    CONTINUOUS_CSV,
    DRFC_LOG,
    JUNE_PRO_LOG,
    SHARED_LOGS,
    need,
    write_robomaker_log,
    write_sim_trace,
)


def _meta_json(log: Path, version: object) -> Path:
    """deepracer-log-guru's ``<log>.meta.json`` beside ``log``."""
    meta = log.with_name(log.name + ".meta.json")
    meta.write_text(json.dumps({"guru_version": "4.0.0", "environment": {"simulation_version": version}}))
    return meta


def _model_metadata(folder: Path, version: object) -> Path:
    """The console's ``model_metadata.json`` in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "model_metadata.json"
    path.write_text(json.dumps({"action_space": [], "sensor": ["FRONT_FACING_CAMERA"], "version": version}))
    return path


def _deep(tmp_path: Path) -> Path:
    """A folder with :data:`MODEL_METADATA_LEVELS` folders of ``tmp_path`` above it: a search for
    model_metadata.json from it never leaves ``tmp_path``."""
    return tmp_path.joinpath(*"abcd")


def _console_run(root: Path, version: object = "4.0") -> tuple[Path, Path]:
    """The console's log layout under ``root``: a training sim-trace CSV and ``model/model_metadata.json``."""
    csv = write_sim_trace(root / "sim-trace/training/training-simtrace/3-iteration.csv")
    return csv, _model_metadata(root / "model", version)


# --- one log -----------------------------------------------------------------------------------


def test_robomaker_log_names_its_simulator_in_its_start_up_line(tmp_path: Path) -> None:
    log = write_robomaker_log(tmp_path / "robomaker.log", "5.0", noise_lines=300)
    found = simulator_of_log(log)
    assert (found.version, found.logged, found.kind, found.where) == ("5", "5.0", "robomaker", log)
    assert found.reason == "simapp_version 5.0 in the robomaker log" and found.exact
    # simapp 4 ran on Python 2: the sensor list reads [u'...']
    old = simulator_of_log(write_robomaker_log(tmp_path / "old.log", "4.0", py2=True))
    assert (old.version, old.logged) == ("4", "4.0")


def test_only_a_robomaker_logs_head_is_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = write_robomaker_log(tmp_path / "robomaker.log", "5.0", noise_lines=400)
    offset = log.read_bytes().index(b"simapp_version")
    monkeypatch.setattr(log_metadata, "_CHUNK", 64)  # the line straddles chunks: still found
    assert simulator_of_log(log).version == "5"
    monkeypatch.setattr(log_metadata, "_CHUNK", offset + len("simapp_version 5"))  # a chunk ends in "5.0"
    assert simulator_of_log(log).logged == "5.0"
    monkeypatch.setattr(log_metadata, "HEADER_BYTES", offset - 100)  # past the head: not read
    assert simulator_of_log(log).version is None


def test_meta_json_beside_the_log(tmp_path: Path) -> None:
    log = write_robomaker_log(tmp_path / "deepracer-0_robomaker.1.x.log", version=None)
    _meta_json(log, "5.0")
    found = simulator_of_log(log)
    assert (found.version, found.kind, found.where) == ("5", "meta.json", tmp_path / f"{log.name}.meta.json")
    assert found.reason == f"environment.simulation_version 5.0 in {log.name}.meta.json"
    # the log's own line comes first
    write_robomaker_log(log, "4.0")
    assert simulator_of_log(log).kind == "robomaker" and simulator_of_log(log).version == "4"


def test_console_model_metadata_a_few_folders_up(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    csv, meta = _console_run(tmp_path / "sample-console-logs")
    found = simulator_of_log(csv)
    assert (found.version, found.logged, found.kind, found.where) == ("4", "4.0", "model_metadata", meta)
    assert found.reason == "version 4.0 in sample-console-logs/model/model_metadata.json"
    # the console's evaluation traces sit a folder deeper
    deeper = write_sim_trace(
        tmp_path / "sample-console-logs/sim-trace/evaluation/20220612/evaluation-simtrace" / "0-iteration.csv"
    )
    assert simulator_of_log(deeper).version == "4"
    # a model_metadata.json in the log's own folder (JSON numbers too), nearer, wins
    _model_metadata(csv.parent, 5)
    assert simulator_of_log(csv).logged == "5" and simulator_of_log(csv).version == "5"


def test_model_metadata_is_looked_for_a_bounded_way_up(tmp_path: Path) -> None:
    _model_metadata(tmp_path / "model", "4.0")
    five_down = write_sim_trace(tmp_path / "a/b/c/d/0-iteration.csv")  # model/ beside the 5th folder up
    six_down = write_sim_trace(tmp_path / "a/b/c/d/e/0-iteration.csv")
    assert simulator_of_log(five_down).version == "4"
    assert log_metadata.MODEL_METADATA_LEVELS == 5
    found = simulator_of_log(six_down)
    assert found.version is None and "no simulator version" in found.reason


def test_a_log_without_metadata_says_why(tmp_path: Path) -> None:
    csv = write_sim_trace(_deep(tmp_path) / "0-iteration.csv")
    found = simulator_of_log(csv)
    assert found.version is None and found.logged is None
    assert "no simapp_version line, no 0-iteration.csv.meta.json, no model_metadata.json" in found.reason
    assert simulator_of_log(tmp_path / "missing.csv").version is None  # reading the log reports it


def test_unreadable_metadata_is_passed_over(tmp_path: Path) -> None:
    log = write_robomaker_log(_deep(tmp_path) / "robomaker.log", version=None)
    log.with_name(log.name + ".meta.json").write_text("{not json")
    found = simulator_of_log(log)
    assert found.version is None and "robomaker.log.meta.json is not valid JSON" in found.reason
    _model_metadata(tmp_path / "model", "5.0")
    assert simulator_of_log(log).kind == "model_metadata"


@pytest.mark.parametrize(
    "logged, car",
    [
        ("5.0", "5"),
        ("5", "5"),
        ("5.1.2", "5"),
        ("4.0", "4"),
        ("3.0", "4"),
        ("1.0", "4"),
        ("6.0", "6"),
        ("7.0", "6"),
        ("v5", "5"),
        ("five", None),
        ("", None),
    ],
)
def test_versions_map_to_drxs_cars_or_the_nearest(logged: str, car: str | None) -> None:
    assert car_for_version(logged) == car


def test_a_version_drx_has_no_car_for_gets_the_nearest_and_says_so(tmp_path: Path) -> None:
    six = choose_simulator([write_robomaker_log(tmp_path / "six.log", "6.0")])
    assert (six.version, six.chosen_by) == ("6", "logs")
    assert six.source == "simapp_version 6.0 in the robomaker log"
    newer = simulator_of_log(write_robomaker_log(tmp_path / "new.log", "7.0"))
    assert (newer.version, newer.logged, newer.exact) == ("6", "7.0", False)
    choice = choose_simulator([tmp_path / "new.log"])
    assert choice.version == "6" and choice.chosen_by == "logs"
    assert choice.source == (
        "simapp_version 7.0 in the robomaker log; drx has no car for simulator 7.0; the nearest it has is 6"
    )
    older = choose_simulator([_console_run(tmp_path / "console", "3.0")[0]])
    assert older.version == "4" and "no car for simulator 3.0; the nearest it has is 4" in older.source


# --- several logs and the user's choice -------------------------------------------------------


def test_logs_that_agree_choose_the_car(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    logs = [write_robomaker_log(tmp_path / f"r{i}.log", "5.0") for i in range(3)]
    choice = choose_simulator(logs)
    assert (choice.version, choice.chosen_by, choice.in_logs, choice.note) == ("5", "logs", ("5",), None)
    assert choice.source == "simapp_version 5.0 in 3 robomaker logs"
    csv, _ = _console_run(tmp_path / "console")  # many CSVs, one model_metadata.json: named once
    more = [write_sim_trace(csv.with_name(f"{i}-iteration.csv")) for i in range(4)]
    console = choose_simulator(more)
    assert console.version == "4" and console.source == "version 4.0 in console/model/model_metadata.json"


def test_logs_that_say_nothing_get_the_default_car(tmp_path: Path) -> None:
    tmp_path = _deep(tmp_path)
    choice = choose_simulator([write_sim_trace(tmp_path / "0-iteration.csv")])
    assert (choice.version, choice.chosen_by, choice.in_logs) == ("5", "default", ())
    assert (
        choice.source
        == "no simulator version in the logs; used simulator 5's car (pass --simulator to choose)"
    )
    # some say, some do not: the ones that say choose, and the rest are counted
    mixed = choose_simulator([write_robomaker_log(tmp_path / "r.log", "4.0"), tmp_path / "0-iteration.csv"])
    assert mixed.version == "4" and mixed.chosen_by == "logs"
    assert mixed.source == "simapp_version 4.0 in the robomaker log r.log; 1 of the 2 logs names no simulator"


def test_logs_that_disagree_are_refused_naming_them(tmp_path: Path) -> None:
    new = [write_robomaker_log(tmp_path / f"new{i}.log", "5.0") for i in range(2)]
    old = write_robomaker_log(tmp_path / "old.log", "4.0")
    with pytest.raises(DrxError) as caught:
        choose_simulator([*new, old])
    message = str(caught.value)
    assert message.startswith("the logs come from different DeepRacer simulators: ")
    assert f"4 for {old} (simapp_version 4.0 in the robomaker log)" in message
    assert f"5 for {new[0]} and 1 more (simapp_version 5.0 in 2 robomaker logs)" in message
    assert message.endswith(
        "pass --simulator 4 or 5 to replay them all with one car, or replay them separately."
    )
    assert "\n" not in message


def test_the_users_choice_wins_with_a_note_when_the_logs_say_otherwise(tmp_path: Path) -> None:
    log = write_robomaker_log(tmp_path / "r.log", "5.0")
    against = choose_simulator([log], "4")
    assert (against.version, against.chosen_by, against.in_logs) == ("4", "user", ("5",))
    assert against.source == "chosen with --simulator"
    assert against.note == (
        "the logs name simulator 5 (simapp_version 5.0 in the robomaker log); replayed with "
        "simulator 4's car as --simulator asked."
    )
    agreeing = choose_simulator([log], "5.0")
    assert agreeing.version == "5" and agreeing.note is None
    assert (
        agreeing.source == "chosen with --simulator; the logs agree: simapp_version 5.0 in the robomaker log"
    )
    silent = choose_simulator([write_sim_trace(_deep(tmp_path) / "0-iteration.csv")], "4")
    assert silent.note is None and silent.source == "chosen with --simulator; the logs name no simulator"
    both = choose_simulator([log, write_robomaker_log(tmp_path / "old.log", "4.0")], "4")  # no error
    assert both.version == "4" and both.note is not None and both.note.startswith("the logs name different")


@pytest.mark.parametrize("bad", ["7", "3", "x", "5.0.0.a"])
def test_a_simulator_drx_has_no_car_for_is_refused(bad: str, tmp_path: Path) -> None:
    with pytest.raises(
        DrxError,
        match=f"--simulator {bad} is not a DeepRacer simulator version drx has a car for; use 4, 5 or 6",
    ):
        check_simulator(bad)
    assert check_simulator("4") == "4" and check_simulator("5.0") == "5" and check_simulator("6") == "6"


# --- the shared real logs (../shared/deepracer-logs) --------------------------------------------


@pytest.mark.parametrize(
    "log, version, kind",
    [
        (DRFC_LOG, "5", "robomaker"),
        (JUNE_PRO_LOG, "5", "robomaker"),
        (CONSOLE_CSV, "4", "model_metadata"),
        (CONTINUOUS_CSV, None, None),
    ],
    ids=["drfc-2023-02-4workers", "drfc-2022-june-pro", "console-reinvent_base", "console-continuous"],
)
def test_the_shared_logs_name_their_simulators(log: Path, version: str | None, kind: str | None) -> None:
    found = simulator_of_log(need(log))
    assert (found.version, found.kind) == (version, kind)
    if kind == "model_metadata":
        assert found.where == CONSOLE_RUN / "model" / "model_metadata.json" and found.logged == "4.0"


def test_the_shared_meta_json_agree_with_their_logs() -> None:
    for meta in sorted(need(SHARED_LOGS).glob("drfc-*/*.log.meta.json")):
        log = meta.with_name(meta.name.removesuffix(".meta.json"))
        assert (
            json.loads(meta.read_text())["environment"]["simulation_version"] == simulator_of_log(log).logged
        )


def test_the_console_robomaker_logs_agree_with_their_model_metadata() -> None:
    logs = sorted(need(CONSOLE_RUN / "logs/evaluation").glob("*-robomaker.log"))
    traces = sorted((CONSOLE_RUN / "sim-trace").glob("*/**/*-iteration.csv"))
    assert logs and traces
    choice = choose_simulator([*logs, *traces])
    assert choice.version == "4" and choice.chosen_by == "logs"
    assert f"simapp_version 4.0 in {len(logs)} robomaker logs" in choice.source


def test_the_shared_logs_simulators_agree_with_their_own_metadata() -> None:
    """``SIMULATOR_OF_SET`` (which car fits and replays each shared log) says what each log's metadata
    says, wherever it says anything (the 2021 console traces say nothing: drx counts them as version
    4's, see ``drx/calibration/logs.py``)."""
    from drx.calibration.log_metadata import simulator_of_log
    from drx.calibration.logs import SHARED_LOG_SETS, SIMULATOR_OF_SET

    if not SHARED_LOGS.is_dir():
        pytest.skip(f"{SHARED_LOGS} is absent: the logs live in ../shared/deepracer-logs beside the repo")
    named = 0
    for name, pattern in SHARED_LOG_SETS.items():
        for path in sorted(SHARED_LOGS.glob(pattern))[:3]:
            said = simulator_of_log(path)
            if said.version is None:
                assert name.startswith("console-continuous"), (name, said.reason)
                continue
            named += 1
            assert said.version == SIMULATOR_OF_SET[name], (name, said.reason)
    assert named >= 6
