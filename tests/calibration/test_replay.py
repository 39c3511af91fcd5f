"""Reading DeepRacer's logs and replaying them through drx's car (``drx sim replay``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from drx.calibration.logs import (
    SHARED_LOG_SETS,
    SIMULATOR_OF_SET,
    LoggedEpisode,
    read_trace,
    shared_log_sets,
)
from drx.calibration.replay import hard_braking, held_commands, replay, windows
from drx.calibration.step_jitter import beat_jitter, step_length_jitter
from drx.cli.main import app
from drx.errors import DrxError
from drx.sim import car_calibration
from drx.sim.dynamics import CarParams

LOGS = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-logs"
CONSOLE_CSV = (
    LOGS / "console-reinvent_base-2022-06/logs/sample-console-logs/sim-trace/training/training-simtrace"
)
DRFC_LOG = LOGS / "drfc-2023-02-4workers/deepracer-0_robomaker.1.qwctpyyzmr74z3u19kc8pskvh.log"


def _need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"{path} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo")
    return path


def test_both_layouts_read_to_the_same_columns(tmp_path: Path) -> None:
    csv_eps = read_trace(_need(CONSOLE_CSV) / "0-iteration.csv")
    log_eps = read_trace(_need(DRFC_LOG))
    for eps in (csv_eps, log_eps):
        assert eps and all(len(e.x) == len(e.status) == len(e.tstamp) for e in eps)
        first = eps[0]
        assert first.status[0] == "prepare" and "in_progress" in first.status
        assert np.all(np.diff(first.tstamp) > 0)
        assert np.all(np.abs(first.yaw) <= np.pi + 1e-9)  # radians
    # the console CSV's first row, as written: 3.19989..., 0.68312..., 0.18796... deg
    assert csv_eps[0].x[0] == pytest.approx(3.1998969552234997)
    assert np.degrees(csv_eps[0].yaw[0]) == pytest.approx(0.18796826230461333)
    assert set(np.unique(log_eps[0].throttle)) <= {1.0, 1.5, 2.0, 3.0, 4.0}
    # a continuous action's "[steer speed]" field holds no comma, so the rest still parses
    row = "SIM_TRACE_LOG:0,1,1.0,2.0,90.0,10.0,1.5,[10.0 1.5],1.0,False,True,0.5,1,20.0,3.2,prepare,0.0"
    row2 = row.replace("0,1,1.0", "0,2,1.1").replace("3.2,prepare", "3.27,in_progress")
    f = tmp_path / "c.log"
    f.write_text(f"noise\n{row}\n{row2}\n")
    (ep,) = read_trace(f)
    assert ep.throttle.tolist() == [1.5, 1.5] and ep.status == ("prepare", "in_progress")


def test_unreadable_logs_are_refused(tmp_path: Path) -> None:
    with pytest.raises(DrxError, match="does not exist"):
        read_trace(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("hello\nworld\n")
    with pytest.raises(DrxError, match="no DeepRacer trace rows"):
        read_trace(bad)


def test_calibrated_car_replays_the_logs_far_better_than_extrapolation() -> None:
    """A guard on the calibration: the figures benchmarks/replay_fidelity.py reports, loosely."""
    sets = shared_log_sets(_need(LOGS))
    for name, eps in sets.items():
        version = SIMULATOR_OF_SET[name]
        r = replay(eps, CarParams.for_simulator(version), stride=4)
        med = float(np.median(r.position_error))
        fitted = SHARED_LOG_SETS[name] in car_calibration.SOURCES[version]  # else held out of the fit
        assert med < (0.25 if fitted else 0.30), f"{name}: median {med:.3f} m after 15 steps"
        assert med < 0.5 * float(np.median(r.baseline_error))
        assert r.errors_by_step is not None and np.all(np.median(r.errors_by_step, axis=0)[1:] >= 0)


def test_windows_skip_resets_and_starts() -> None:
    eps = read_trace(_need(DRFC_LOG))
    for w in windows(eps, 15):
        ep = eps[w.episode]
        assert all(s == "in_progress" for s in ep.status[w.start - 1 : w.start + 16])


def test_held_commands_turn_wider_than_a_bicycle_as_deepracers_car() -> None:
    eps = read_trace(_need(DRFC_LOG))
    held = {(h.steering, h.speed): h for h in held_commands(eps)}
    turn = held[(-30.0, 1.0)]
    assert 0.6 < turn.log_radius < 1.2  # DeepRacer: 0.8-1.0 m, not the bicycle's 0.28 m
    assert turn.drx_radius == pytest.approx(turn.log_radius, rel=0.2)


def test_cli_replay_prints_json_and_a_picture(tmp_path: Path) -> None:
    runner = CliRunner()
    png = tmp_path / "replay.png"
    result = runner.invoke(app, ["sim", "replay", str(_need(DRFC_LOG)), "--horizon", "10", "--png", str(png),
                                 "--json"])  # fmt: skip
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["horizon_steps"] == 10 and data["overall"]["windows"] > 100
    assert {"fast_commands", "hard_steering", "by_speed", "by_steering"} <= set(data)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, words",
    [
        (["nope.csv"], "does not exist"),
        (["LOG", "--horizon", "0"], "--horizon 0 is out of range"),
        (["LOG", "--simulator", "9"], "--simulator 9 is not a DeepRacer simulator version drx has a car for"),
        (["LOG", "--png", "paths.txt"], "--png paths.txt must end in .png"),
    ],
)
def test_cli_replay_bad_input(args: list[str], words: str) -> None:
    args = [str(_need(DRFC_LOG)) if a == "LOG" else a for a in args]
    result = CliRunner().invoke(app, ["sim", "replay", *args])
    assert result.exit_code == 2
    assert words in result.stderr and "Traceback" not in result.output


def test_the_car_steps_to_a_steady_beat_not_to_the_logged_clock() -> None:
    """DeepRacer logs the clock the agent last heard, not the car's (drx.calibration.logs): the
    distance driven follows the step count better than the logged time, a step varies by 5-15 %,
    and the replay drives every sane step for the episode's mean."""
    sets = shared_log_sets(_need(LOGS))
    for name, eps in sets.items():
        jitter = step_length_jitter(eps)
        if name.startswith("console-continuous") and jitter.steps < 500:
            continue  # sampled continuous actions are seldom held for the runs the beat is read from
        assert jitter.steps > 500, name
        assert jitter.clock_ratio > 1.3, f"{name}: {jitter}"  # below 1 if the logged clock were the car's
        # 5-9 % in most logs; the stereo-camera and lidar run of 2022 (drfc-june-pro) steps less evenly
        assert 0.04 < jitter.relative_sd < 0.16, f"{name}: {jitter}"
        ep = max(eps, key=len)
        logged = np.diff(ep.tstamp)
        assert np.std(logged[ep.sane_steps]) > 0.005  # the logged clock jitters ...
        assert np.all(ep.step_times[ep.sane_steps] == ep.step_time)  # ... the replay's steps do not
        assert ep.step_time == pytest.approx(float(np.mean(logged[ep.sane_steps])))
        paused = next(e for e in eps if not e.sane_steps.all())  # a pause or reset inside an episode
        gaps = ~paused.sane_steps
        assert np.all(paused.step_times[gaps] == 1.0 / 15.0)  # replayed as one nominal step


def _runs(rng: np.random.Generator, beat: bool, sigma: float = 0.04, count: int = 3000) -> list:
    """Runs of 8 steps of a car accelerating gently, read on a jittered beat (``beat``: readings off by
    ``sigma`` steps, the logged clock saying nothing of it) or at exactly the logged times."""
    runs = []
    for _ in range(count):
        v, a = rng.uniform(0.05, 0.25), rng.uniform(-0.005, 0.005)  # [m/step], [m/step^2]
        readings = np.arange(9.0) + rng.normal(0.0, sigma, 9)
        logged = np.arange(9.0) + rng.normal(0.0, sigma, 9) if beat else readings
        driven = v * readings + a * readings**2
        runs.append((driven - driven[0], logged - logged[0]))
    return runs


def test_the_step_jitter_estimate_recovers_a_known_beat() -> None:
    """beat_jitter on simulated runs: a beat jittered by 0.04 steps reads as 0.04 (a step varies by
    0.057); a logged clock that tells the true reading moments fits better than the beat."""
    rng = np.random.default_rng(3)
    beat = beat_jitter(_runs(rng, beat=True))
    assert beat.reading_sd == pytest.approx(0.04, rel=0.05)
    assert beat.relative_sd == pytest.approx(0.04 * np.sqrt(2.0), rel=0.05)
    assert beat.clock_ratio > 1.3
    true_clock = beat_jitter(_runs(rng, beat=False))
    assert true_clock.clock_ratio < 0.1


def test_held_speeds_pool_every_steering() -> None:
    eps = read_trace(_need(DRFC_LOG))
    car = CarParams.for_simulator("5")
    turns = held_commands(eps, car)
    speeds = held_commands(eps, car, same_steering=False)
    assert all(np.isnan(h.steering) for h in speeds)
    for speed in {h.speed for h in turns}:
        (pooled,) = [h for h in speeds if h.speed == speed]
        assert pooled.samples >= sum(h.samples for h in turns if h.speed == speed)


def _braking_episode(deceleration: float, dt: float = 1.0 / 15.0) -> LoggedEpisode:
    """A straight run: 10 steps holding 4 m/s at 3.6 m/s, then 12 steps commanding 1 m/s while the car
    slows by ``deceleration`` [m/s^2] down to 1 m/s."""
    speeds = [3.6] * 10
    while len(speeds) < 22:
        speeds.append(max(speeds[-1] - deceleration * dt, 1.0))
    x = np.concatenate([[0.0], np.cumsum(np.array(speeds[:-1]) * dt)])
    n = len(x)
    throttle = np.array([4.0] * 10 + [1.0] * (n - 10))
    return LoggedEpisode(
        episode=0, x=x, y=np.zeros(n), yaw=np.zeros(n), steer=np.zeros(n), throttle=throttle,
        progress=np.linspace(0.0, 10.0, n), tstamp=np.arange(n) * dt, status=("in_progress",) * n,
        source="synthetic",
    )  # fmt: skip


def test_hard_braking_reads_the_logged_deceleration_and_drives_drx_from_it() -> None:
    """A log slowing at 4 m/s^2 reads as 4; drx's car started there brakes at its own cap when that binds."""
    episode = _braking_episode(4.0)
    capped = CarParams.for_simulator("5").with_values(max_braking=2.0)
    braking = hard_braking([episode], capped)
    assert braking is not None and braking.samples == 1
    assert braking.log_deceleration == pytest.approx(4.0, rel=1e-6)
    # at its cap throughout but for the first step's start (the command delay): a little under 2
    assert braking.drx_deceleration == pytest.approx(2.0, rel=0.05)
    assert hard_braking([_braking_episode(4.0)], capped, fast=5.0) is None  # no command that fast
