"""``drx sim replay`` picks drx's car from the logs' own metadata and says which it used and why."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.calibration._logs import (
    CONSOLE_CSV,
    CONTINUOUS_CSV,
    DRFC_LOG,
    JUNE_PRO_LOG,
    need,
    write_robomaker_log,
    write_sim_trace,
)

from .helpers import fails, ok, ok_json

DEFAULT_SAYS = "No simulator version in the logs; used simulator 5's car (pass --simulator to choose)."


@pytest.mark.parametrize(
    "log, version, chosen_by, source",
    [
        (DRFC_LOG, "5", "logs", "simapp_version 5.0 in the robomaker log"),
        (JUNE_PRO_LOG, "5", "logs", "simapp_version 5.0 in the robomaker log"),
        (CONSOLE_CSV, "4", "logs", "version 4.0 in ../../../model/model_metadata.json"),
        (CONTINUOUS_CSV, "5", "default", DEFAULT_SAYS[0].lower() + DEFAULT_SAYS[1:-1]),
    ],
    ids=["drfc-2023-02-4workers", "drfc-2022-june-pro", "console-reinvent_base", "console-continuous"],
)
def test_the_car_comes_from_the_shared_logs_metadata(
    log: Path, version: str, chosen_by: str, source: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Run from the logs' folder, as a user would: ``drx sim replay 3-iteration.csv``."""
    monkeypatch.chdir(need(log).parent)
    log = Path(log.name)
    data = ok_json("sim", "replay", str(log), "--horizon", "5")
    assert data["simulator"] == version and data["simulator_chosen_by"] == chosen_by
    assert data["simulator_source"] == source and data["simulator_note"] is None
    assert data["simulator_in_logs"] == ([] if chosen_by == "default" else [version])
    out = ok("sim", "replay", str(log), "--horizon", "5").stdout
    said = DEFAULT_SAYS if chosen_by == "default" else f"Simulator {version}'s car: {source}."
    assert out.startswith(said + "\n"), out  # one line, however long, before the table
    assert f"drx (simulator {version} car) vs DeepRacer" in out


def test_shared_logs_of_two_simulators_are_refused_together() -> None:
    err = fails(
        "sim",
        "replay",
        str(need(DRFC_LOG)),
        str(need(CONSOLE_CSV)),
        contains=(
            "different DeepRacer simulators",
            f"4 for {CONSOLE_CSV}",
            f"5 for {DRFC_LOG}",
            "pass --simulator 4 or 5",
        ),
    )
    assert "model_metadata.json" in err


def test_synthetic_logs_choose_and_say(tmp_path: Path) -> None:
    logs = [str(write_robomaker_log(tmp_path / f"r{i}.log", "5.0")) for i in range(2)]
    data = ok_json("sim", "replay", *logs, "--horizon", "5")
    assert data["simulator"] == "5" and data["simulator_source"] == "simapp_version 5.0 in 2 robomaker logs"
    assert data["overall"]["windows"] > 0
    out = ok("sim", "replay", *logs, "--horizon", "5").stdout
    assert out.startswith("Simulator 5's car: simapp_version 5.0 in 2 robomaker logs.\n")


def test_the_users_simulator_wins_with_a_note(tmp_path: Path) -> None:
    log = str(write_robomaker_log(tmp_path / "r.log", "5.0"))
    out = ok("sim", "replay", log, "--simulator", "4", "--horizon", "5").stdout
    lines = out.splitlines()
    assert lines[0] == "Simulator 4's car: chosen with --simulator."
    assert lines[1] == (
        "Note: the logs name simulator 5 (simapp_version 5.0 in the robomaker log); replayed "
        "with simulator 4's car as --simulator asked."
    )
    assert "drx (simulator 4 car)" in out
    data = ok_json("sim", "replay", log, "--simulator", "4", "--horizon", "5")
    assert (data["simulator"], data["simulator_chosen_by"], data["simulator_in_logs"]) == ("4", "user", ["5"])
    assert data["simulator_note"] == lines[1].removeprefix("Note: ")
    agreeing = ok("sim", "replay", log, "--simulator", "5", "--horizon", "5").stdout
    assert agreeing.startswith("Simulator 5's car: chosen with --simulator; the logs agree: ")
    assert "Note:" not in agreeing


def test_logs_that_disagree_exit_2_naming_them(tmp_path: Path) -> None:
    new = write_robomaker_log(tmp_path / "new.log", "5.0")
    old = write_robomaker_log(tmp_path / "old.log", "4.0")
    fails(
        "sim",
        "replay",
        str(new),
        str(old),
        "--horizon",
        "5",
        contains=(
            f"4 for {old} (simapp_version 4.0",
            f"5 for {new} (simapp_version 5.0",
            "pass --simulator 4 or 5",
        ),
    )
    data = ok_json("sim", "replay", str(new), str(old), "--simulator", "4", "--horizon", "5")  # chosen: fine
    assert data["simulator"] == "4" and data["simulator_in_logs"] == ["4", "5"]
    assert data["simulator_note"].startswith("the logs name different simulators: 4 for ")


def test_logs_without_metadata_use_the_default_car(tmp_path: Path) -> None:
    csv = str(write_sim_trace(tmp_path.joinpath(*"abcd") / "0-iteration.csv"))
    assert ok("sim", "replay", csv, "--horizon", "5").stdout.startswith(DEFAULT_SAYS + "\n")
    assert ok_json("sim", "replay", csv, "--horizon", "5")["simulator_chosen_by"] == "default"


@pytest.mark.parametrize("bad", ["7", "3", "newest"])  # 4, 5 and 6 have cars
def test_a_simulator_without_a_car_exits_2(bad: str, tmp_path: Path) -> None:
    log = str(write_robomaker_log(tmp_path / "r.log", "5.0"))
    fails(
        "sim",
        "replay",
        log,
        "--simulator",
        bad,
        contains=f"--simulator {bad} is not a DeepRacer simulator version drx has a car for; use 4, 5 or 6.",
    )
