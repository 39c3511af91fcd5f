"""The fitting script replays the logs through the batched step exactly as drx sim replay does."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from drx.sim.deepracer_logs import shared_log_sets
from drx.sim.dynamics import CarParams
from drx.sim.replay import replay, windows

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
    fit = _fit_module()
    episodes = shared_log_sets(LOGS)["drfc-4workers"][:12]
    car = CarParams()
    wins = windows(episodes, fit.HORIZON)
    assert len(wins) > 50
    errors, heading, speed = fit.BatchReplay(episodes, wins, fit.HORIZON).residuals(car)
    scalar = replay(episodes, car, fit.HORIZON, chosen=wins)
    assert errors[:, -1] == pytest.approx(scalar.position_error, abs=1e-9)
    assert np.degrees(np.abs(heading)) == pytest.approx(scalar.heading_error, abs=1e-6)
    assert speed.shape == (len(wins), len(fit.SPEED_STEPS))
    assert np.median(np.abs(speed)) < 0.5  # [m/s] the calibrated car's speed stays near the log's
