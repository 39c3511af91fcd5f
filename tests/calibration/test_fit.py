"""The fitting core (drx.calibration.fit) replays the logs through the batched step exactly as drx sim
replay does; tools/fit_car_model.py, its command line, refuses bad input in one sentence."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from drx.calibration import calibration_module
from drx.calibration import fit as core
from drx.calibration.logs import shared_log_sets
from drx.calibration.replay import replay, windows
from drx.sim.dynamics import CarParams

ROOT = Path(__file__).resolve().parents[2]
LOGS = ROOT.parent / "shared" / "deepracer-logs"


def _fit_module():  # tools/ is not a package: load the script as a module
    spec = importlib.util.spec_from_file_location("fit_car_model", ROOT / "tools" / "fit_car_model.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("fit_car_model", module)
    spec.loader.exec_module(module)
    return module


def test_batched_replay_matches_the_scalar_replay() -> None:
    if not LOGS.is_dir():
        pytest.skip(f"{LOGS} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo")
    episodes = shared_log_sets(LOGS)["drfc-4workers"][:12]
    car = CarParams()
    wins = windows(episodes, core.HORIZON)
    assert len(wins) > 50
    errors, heading, speed = core.BatchReplay(episodes, wins, core.HORIZON).residuals(car)
    scalar = replay(episodes, car, core.HORIZON, chosen=wins)
    assert errors[:, -1] == pytest.approx(scalar.position_error, abs=1e-9)
    assert np.degrees(np.abs(heading)) == pytest.approx(scalar.heading_error, abs=1e-6)
    assert speed.shape == (len(wins), len(core.SPEED_STEPS))
    assert np.median(np.abs(speed)) < 0.5  # [m/s] the calibrated car's speed stays near the log's


def test_the_written_module_keeps_every_version_and_its_held_out_cars(tmp_path, monkeypatch) -> None:
    """``write_module`` rewrites one version's car and its leave-one-log-out cars and keeps the rest, as
    importable Python (the env reads it at import time)."""
    out = tmp_path / "car_calibration.py"
    new = CarParams.for_simulator("5").with_values(max_braking=5.5)
    without = {"drfc-june-pro": CarParams.for_simulator("5").with_values(max_braking=6.5)}
    calibration_module.write_module(
        "5",
        new,
        {"drfc-4workers": []},
        ["a report line"],
        without,
        out,
        "tools/fit_car_model.py --simulator 5",
    )
    spec = importlib.util.spec_from_file_location("written_calibration", out)
    assert spec is not None and spec.loader is not None
    written = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(written)
    assert written.SIMULATORS["5"]["max_braking"] == 5.5
    assert written.SIMULATORS["4"]["command_delay"] == CarParams.for_simulator("4").command_delay
    assert list(written.HELD_OUT["5"]) == ["drfc-june-pro"]
    assert written.HELD_OUT["5"]["drfc-june-pro"]["max_braking"] == 6.5
    assert "a report line" in written.SOURCES["5"]
    assert "drfc-2023-02-4workers" in written.SOURCES["5"]
    assert "tools/fit_car_model.py --simulator 5" in written.SOURCES["5"]


def test_a_fit_leaves_out_what_it_is_told_and_says_which_logs_it_knows(monkeypatch, capsys) -> None:
    """``--without`` names a log of the version; anything else stops with one sentence naming the logs."""
    if not LOGS.is_dir():
        pytest.skip(f"{LOGS} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo")
    fit = _fit_module()
    monkeypatch.setattr(
        sys, "argv", ["fit_car_model.py", "--simulator", "5", "--without", "console-reinvent_base"]
    )
    with pytest.raises(SystemExit) as stop:
        fit.main()
    assert stop.value.code == 2
    said = capsys.readouterr().err.strip()
    assert said.startswith("--without console-reinvent_base is not a log of simulator 5; use one of ")
    assert "drfc-4workers" in said and said.count("\n") == 0


def test_bad_fit_arguments_end_in_one_sentence_and_exit_2(tmp_path, monkeypatch, capsys) -> None:
    """An unknown constant or an --output in a missing folder stops before any fit, with exit code 2,
    and the calibration module is left as it was."""
    fit = _fit_module()
    before = fit.OUTPUT.read_text()
    for argv, wanted in (
        (["--fix", "grip=1"], "unknown constant 'grip'; use one of command_delay"),
        (["--free", "grip"], "unknown constant 'grip'"),
        (["--start", "max_braking=fast"], "'max_braking=fast' is not NAME=NUMBER"),
        (["--logs", str(tmp_path / "nowhere")], "no DeepRacer logs under"),
        (["--output", str(tmp_path / "missing" / "cal.py")], "its folder does not exist"),
    ):
        monkeypatch.setattr(sys, "argv", ["fit_car_model.py", "--simulator", "5", *argv])
        with pytest.raises(SystemExit) as stop:
            fit.main()
        assert stop.value.code == 2
        said = capsys.readouterr().err.strip()
        assert wanted in said and said.count("\n") == 0
    assert fit.OUTPUT.read_text() == before


def test_a_short_fit_runs_on_one_log_and_moves_the_car() -> None:
    """``fit_car`` on a slice of one log, three evaluations: the car it returns differs from the start in
    the fitted constants and keeps the held ones."""
    if not LOGS.is_dir():
        pytest.skip(f"{LOGS} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo")
    fit = _fit_module()
    episodes = shared_log_sets(LOGS)["drfc-june-pro"][:6]
    settings = core.FIT_SETTINGS["5"]
    options = core.FitOptions(
        simulator="5", stride=4, fix=dict(map(fit._assignment, settings["fix"])),
        start=dict(map(fit._assignment, settings["start"])), speed_map="fit", speed_weight=1.0,
        steady_weight=0.0, fast_weight=2.0, max_evaluations=3,
    )  # fmt: skip
    result = core.fit_car({"drfc-june-pro": episodes}, options, verbose=0)
    assert result.car.wheel_speed_limit == options.fix["wheel_speed_limit"]
    assert "wheel_speed_limit" not in result.names
    moved = [n for n in result.names if getattr(result.car, n) != pytest.approx(options.start[n], rel=1e-6)]
    assert moved
    assert result.residual_after_cm <= result.residual_before_cm
