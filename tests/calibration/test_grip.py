"""The grip envelope (drx.calibration.grip, tools/grip_envelope.py): the lateral acceleration the car holds
at speed, read from logged poses, against drx's car replaying the same steps."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from drx.calibration.grip import GripSamples, car_limit, envelope, grip_samples, lateral_motion
from drx.calibration.logs import LoggedEpisode, read_traces
from drx.sim.dynamics import CarParams, steady_state, step_car

ROOT = Path(__file__).resolve().parents[2]
LOGS = ROOT.parent / "shared" / "deepracer-logs"


def test_lateral_motion_reads_v_squared_over_r_on_a_circle() -> None:
    """On a circle of 1.5 m driven at 2 m/s, read every 1/15 s: 2 m/s and 2^2 / 1.5 m/s^2, to the left."""
    t = np.arange(30) / 15.0
    angle = 2.0 * t / 1.5
    speed, lateral = lateral_motion(1.5 * np.sin(angle), 1.5 * (1.0 - np.cos(angle)), 1.0 / 15.0)
    assert len(speed) == 30 - 6
    # within 1 %: what a 7-point quadratic's fit to an arc of 0.53 rad leaves of the true motion
    assert speed == pytest.approx(2.0, rel=0.01)
    assert lateral == pytest.approx(4.0 / 1.5, rel=0.01)


def _circling(car: CarParams, command: float, steering_deg: float, steps: int = 60) -> LoggedEpisode:
    """A log of drx's own car holding one command from a steady turn: the reference point as logged."""
    state = steady_state(command, math.radians(steering_deg), car, seconds=4.0)
    xs, ys, yaws = [], [], []
    for _ in range(steps):
        xs.append(state.x + car.reference_offset * math.cos(state.yaw))
        ys.append(state.y + car.reference_offset * math.sin(state.yaw))
        yaws.append(state.yaw)
        step_car(state, command, math.radians(steering_deg), car)
    n = steps
    return LoggedEpisode(0, np.array(xs), np.array(ys), np.unwrap(np.array(yaws)), np.full(n, steering_deg),
                         np.full(n, command), np.zeros(n), np.arange(n) / 15.0, ("in_progress",) * n,
                         "synthetic")  # fmt: skip


def test_drx_replaying_its_own_steady_turn_reads_what_the_log_shows() -> None:
    """A log made by drx's car holding 30 deg at 2 m/s: every sample steady, the logged and the replayed
    lateral acceleration alike, and at the car's full-lock limit (car_limit)."""
    car = CarParams()
    s = grip_samples([_circling(car, 2.0, 30.0)], car)
    assert len(s) > 30 and s.steady.all()
    assert np.abs(s.drx) == pytest.approx(np.abs(s.log), rel=0.02)
    speed = float(np.median(s.speed))
    assert float(np.median(np.abs(s.log))) == pytest.approx(car_limit(car, speed), rel=0.03)
    rows = envelope(s, car)
    lo, hi = (float(v) for v in rows[0].band.removesuffix(" m/s").split("-"))
    assert len(rows) == 1 and lo <= speed < hi and rows[0].limit is not None  # the band the car held


@pytest.fixture(scope="module")
def fast_logs() -> dict[str, list[LoggedEpisode]]:
    """deepracer-for-cloud's 2022_june_pro run (1.3-4 m/s) and the console's 2025 vitor run (to 4 m/s)."""
    runs = {
        "drfc-june-pro": sorted((LOGS / "drfc-2022-june-pro").glob("*_robomaker.*.log")),
        "console-2025-vitor": sorted((LOGS / "console-2025-10-continuous" / "vitor").glob("*robomaker.log")),
    }
    if not all(runs.values()):
        pytest.skip(
            f"{LOGS} lacks the fast logs: DeepRacer's logs live in ../shared/deepracer-logs beside the repo"
        )
    return {name: read_traces(list(paths)) for name, paths in runs.items()}


def test_simapp5_turns_reach_near_friction_at_speed(fast_logs: dict[str, list[LoggedEpisode]]) -> None:
    """The logs' turns at 1.5-2.5 m/s reach 3.3-4.5 m/s^2 at their 99th percentile (friction 0.5 allows
    4.9): the edge of the envelope a best lap is made at (docs/DYNAMICS.md, issue 34)."""
    car = CarParams.for_simulator("5")
    checked = 0
    for name, eps in fast_logs.items():
        s = grip_samples(eps, car, stride=2)
        for row in envelope(s, car):
            if row.band in ("1.5-2 m/s", "2-2.5 m/s") and row.samples >= 200:
                assert 3.3 < row.log[2] < 4.5, (name, row)
                checked += 1
    assert checked >= 2


def test_driving_slip_leaves_the_grip_braking_slip_takes(fast_logs: dict[str, list[LoggedEpisode]]) -> None:
    """In the fast logs the car turns as hard with its wheels driven 30 % or more faster than it moves
    as with no slip (99th percentile), and less when they turn 30 % or more slower (braking): the
    evidence that DeepRacer's grip does not fall with driving slip, as drx's car's does today
    (CarParams.grip_slip), and a refit's starting point (branch refit-v5-2025)."""
    car = CarParams.for_simulator("5")
    s = GripSamples.join([grip_samples(eps, car, stride=2) for eps in fast_logs.values()])
    rows = {r.band: r for r in envelope(s, by="slip")}
    none, driving, braking = rows["slip -0.1..0.05"], rows["slip 0.3..1"], rows["slip -1..-0.3"]
    assert driving.log[2] > 0.97 * none.log[2]
    assert braking.log[2] < 0.97 * none.log[2]


def test_the_tool_prints_every_band_and_refuses_a_bad_stride(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, fast_logs: dict
) -> None:
    spec = importlib.util.spec_from_file_location("grip_envelope", ROOT / "tools" / "grip_envelope.py")
    assert spec is not None and spec.loader is not None
    tool = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("grip_envelope", tool)
    spec.loader.exec_module(tool)
    vitor = sorted((LOGS / "console-2025-10-continuous" / "vitor").glob("*robomaker.log"))
    monkeypatch.setattr(sys, "argv", ["grip_envelope.py", str(vitor[0]), "--stride", "4"])
    assert tool.main() == 0
    out = capsys.readouterr().out
    for wanted in ("by speed, every sample:", "by wheel slip", "1.5-2 m/s", "drx limit", "all 1 logs"):
        assert wanted in out
    monkeypatch.setattr(sys, "argv", ["grip_envelope.py", str(vitor[0]), "--stride", "0"])
    assert tool.main() == 2
    assert capsys.readouterr().err.strip() == "--stride 0 is below 1; give 1 or more."
