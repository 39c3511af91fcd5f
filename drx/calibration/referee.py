"""The DART referee from drx's side: windows of DeepRacer's logs driven by simapp's own car in DART.

DART (``dartpy``) is a check tool in its own environment (``.venv-dart``, ``tools/dart_check/setup.sh``),
never a drx dependency: :func:`run_referee` writes the windows to a request file, runs
``tools/dart_check/referee.py`` under that environment and reads the poses back. The referee builds
the car from deepracer-simapp's URDF and meshes (``../shared/deepracer-car``) and drives it by each
version's controller laws (version 6: gz_ros2_control's 60 Hz position law and velocity servo; 5:
gazebo_ros_control's PID effort laws at 1 kHz); its docstrings cite the sources.

A window (:class:`RefereeWindow`) starts where the log was at row ``k``: the car's origin 0.14 m
behind the logged reference point, moving at the logged speed and bend (:func:`drx.calibration.replay.
logged_motion`), its hinges where the version's steering law left them after the episode's earlier
commands (:func:`hinge_angle`), and is driven by the logged commands, each step the episode's mean
step rounded to whole 1 ms physics steps. The same windows drive drx's car (:func:`drive_car`) from the
same start, so drx's car can be held to the referee (version 6, which has no published log) as well
as to the log (version 5, where the referee itself is judged).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from drx.calibration.logs import SHARED_LOG_SETS, LoggedEpisode, read_traces
from drx.calibration.replay import logged_motion, windows
from drx.errors import DrxError
from drx.sim.dynamics import CarParams, CarState, step_car
from drx.sim.dynamics_batch import BatchState, step_cars

REPO = Path(__file__).resolve().parents[2]
REFEREE_SCRIPT = REPO / "tools" / "dart_check" / "referee.py"
DART_PYTHON = REPO / ".venv-dart" / "bin" / "python"
DEFAULT_CAR_DIR = REPO.parent / "shared" / "deepracer-car"
REFERENCE_AHEAD = 0.14  # [m] simapp's RELATIVE_POSITION_OF_FRONT_OF_CAR: the log's x, y ahead of the origin
# gz_ros2_control's position law (tools/dart_check/controllers.py): 10 % of the hinge's error closes
# each 17 ms control period (position_proportional_gain 0.1 x update_rate 60, read every 1/60 s)
V6_HINGE_CLOSE_PER_PERIOD = 0.1
V6_CONTROL_PERIOD = 0.017  # [s]


@dataclass(frozen=True)
class RefereeWindow:
    """One open-loop window: the start state and the commands.

    :param pose: the car's origin ``(x, y, yaw)`` [m, m, rad] at the start.
    :param speed: forward speed [m/s] at the start.
    :param yaw_rate: [rad/s] at the start.
    :param steering: the hinges' angle [rad] at the start.
    :param commands: ``(speed m/s, steering rad)`` per step.
    :param step_ms: each step's length in 1 ms physics steps.
    :param prior: the command ``(speed m/s, steering rad)`` of the step before the window.
    :param control_phase_ms: how far into its 17 ms control period version 6's controller manager is
        when the window starts (the agent's steps and the 60 Hz controllers do not share a clock).
    :param logged: the log's reference point ``(x, y, yaw)`` at the start and after each step
        (``(steps + 1, 3)``), or ``None`` for a window made by hand.
    :param source: where it came from (``log name:episode:row``).
    """

    pose: tuple[float, float, float]
    speed: float
    yaw_rate: float
    steering: float
    commands: tuple[tuple[float, float], ...]
    step_ms: tuple[int, ...]
    prior: tuple[float, float] = (0.0, 0.0)
    control_phase_ms: int = 0
    logged: np.ndarray | None = None
    source: str = ""

    def request(self) -> dict:
        """The window as the referee script reads it."""
        return {"pose": list(self.pose), "speed": self.speed, "yaw_rate": self.yaw_rate,
                "steering": self.steering, "commands": [list(c) for c in self.commands],
                "step_ms": list(self.step_ms), "prior": list(self.prior),
                "control_phase_ms": self.control_phase_ms}  # fmt: skip

    @property
    def mean_command(self) -> float:
        """The window's mean commanded speed [m/s]."""
        return float(np.mean([c[0] for c in self.commands]))


def step_lengths_ms(step_time: float, steps: int) -> tuple[int, ...]:
    """``steps`` whole-millisecond step lengths whose running total follows ``step_time`` [s] (66, 67, 67,
    ... for 1/15 s)."""
    ends = [round((i + 1) * step_time * 1000.0) for i in range(steps)]
    return tuple(int(b - a) for a, b in zip([0, *ends[:-1]], ends, strict=True))


def hinge_angle(steer_deg: Sequence[float], step_times: Sequence[float], version: str) -> float:
    """The hinges' angle [rad] after the commands ``steer_deg`` (one per step, oldest first), each held
    for its step: version 6 closes 10 % of the error every 17 ms control period (gz_ros2_control's
    law); version 5's PID moves a change within a few milliseconds (the command ramps at 100 rad/s and
    the effort saturates at 10 N m on a 0.1 kg hinge), so its hinges stand at the last command."""
    if not len(steer_deg):
        return 0.0
    if version != "6":
        return math.radians(float(steer_deg[-1]))
    angle = 0.0
    for cmd, dt in zip(steer_deg, step_times, strict=True):
        keep = (1.0 - V6_HINGE_CLOSE_PER_PERIOD) ** (dt / V6_CONTROL_PERIOD)
        angle = math.radians(float(cmd)) + (angle - math.radians(float(cmd))) * keep
    return angle


# The shared logs whose action sequences the referee drives (``../shared/deepracer-logs``): every log of
# :data:`drx.calibration.logs.SHARED_LOG_SETS` and the console's four 2025 runs, name -> glob.
REFEREE_LOGS = {
    **SHARED_LOG_SETS,
    **{f"2025 {run}": f"console-2025-10-continuous/{run}/*-robomaker.*"
       for run in ("vitor", "deepModel-clone", "deepModel-clone3-clone", "reinvencementModel")},
}  # fmt: skip


def referee_log_sets(root: Path, names: Sequence[str] | None = None) -> dict[str, list[LoggedEpisode]]:
    """The episodes of each log of :data:`REFEREE_LOGS` (or of ``names``) found under ``root``."""
    out = {}
    for name in names or REFEREE_LOGS:
        files = sorted(root.glob(REFEREE_LOGS[name]))
        if files:
            out[name] = read_traces(list[str | Path](files))
    return out


def log_windows(
    episodes: Sequence[LoggedEpisode], version: str, horizon: int = 15, stride: int = 1, name: str = ""
) -> list[RefereeWindow]:
    """Every ``stride``-th replayable window of ``episodes`` (as :func:`drx.calibration.replay.windows`
    chooses them) as referee windows for simulator ``version``'s steering law."""
    out = []
    for w in windows(episodes, horizon, stride):
        ep = episodes[w.episode]
        k = w.start
        speed, curvature = logged_motion(ep, k, REFERENCE_AHEAD)
        yaw = float(ep.yaw[k])
        ox = float(ep.x[k]) - REFERENCE_AHEAD * math.cos(yaw)
        oy = float(ep.y[k]) - REFERENCE_AHEAD * math.sin(yaw)
        dts = ep.step_times
        first = max(0, k - 12)  # the hinge's memory: 0.9^(12 steps x 4 periods) is nothing
        steering = hinge_angle(ep.steer[first:k].tolist(), dts[first:k].tolist(), version)
        commands = tuple(
            (float(v), math.radians(float(s)))
            for v, s in zip(ep.throttle[k : k + horizon], ep.steer[k : k + horizon], strict=True)
        )
        rows = slice(k, k + horizon + 1)
        logged = np.column_stack([ep.x[rows], ep.y[rows], ep.yaw[rows]])
        prior = (float(ep.throttle[k - 1]), math.radians(float(ep.steer[k - 1])))
        phase = int(round(float(ep.tstamp[k]) * 1000.0)) % 17
        out.append(RefereeWindow(
            (ox, oy, yaw), speed, speed * (curvature or 0.0), steering, commands,
            step_lengths_ms(ep.step_time, horizon), prior, phase, logged, f"{name}:{ep.episode}:{k}",
        ))  # fmt: skip
    return out


def referee_available() -> str | None:
    """Why the referee cannot run here (``None`` when it can)."""
    if not DART_PYTHON.exists():
        return f"{DART_PYTHON} is absent: run tools/dart_check/setup.sh (make test does)"
    return None


def referee_answer(wins: Sequence[RefereeWindow], version: str, car_dir: Path = DEFAULT_CAR_DIR) -> dict:
    """The referee script's whole answer for ``wins`` (``car_mass``, ``dartpy``, ``seconds``, and per
    window ``poses``, ``hinge``, ``speed``; ``tools/dart_check/referee.py``).

    :raises DrxError: when the referee's environment or the car's files are missing, or it fails.
    """
    why = referee_available()
    if why:
        raise DrxError(f"The DART referee cannot run: {why}.")
    if not (car_dir / f"v{version}").is_dir():
        raise DrxError(f"No simapp {version} car under {car_dir}; point it at shared/deepracer-car.")
    with tempfile.TemporaryDirectory(prefix="drx-referee-") as tmp:
        req, ans = Path(tmp) / "request.json", Path(tmp) / "answer.json"
        req.write_text(json.dumps({"windows": [w.request() for w in wins]}))
        cmd = [str(DART_PYTHON), str(REFEREE_SCRIPT), "--car-dir", str(car_dir), "--version", version,
               str(req), str(ans)]  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": ""})
        if done.returncode != 0 or not ans.exists():
            tail = (done.stdout + done.stderr).strip().splitlines()[-3:]
            raise DrxError(f"The DART referee failed (exit {done.returncode}): {' / '.join(tail)}")
        answer: dict = json.loads(ans.read_text())
    return answer


def run_referee(
    wins: Sequence[RefereeWindow], version: str, car_dir: Path = DEFAULT_CAR_DIR, cache: Path | None = None
) -> np.ndarray:
    """Drive ``wins`` through the DART referee of simapp ``version`` (:func:`referee_answer`), its
    answer kept in ``cache`` when given (keyed by the windows and the referee's own code).

    :return: ``(windows, steps, 3)``: the car's origin ``x, y, yaw`` after each step.
    """
    text = json.dumps({"windows": [w.request() for w in wins]}, sort_keys=True)
    key = hashlib.sha256((version + text + _referee_source_hash()).encode()).hexdigest()[:20]
    cached = cache / f"referee-v{version}-{key}.npy" if cache else None
    if cached and cached.exists():
        return np.load(cached)
    answer = referee_answer(wins, version, car_dir)
    poses = np.array([w["poses"] for w in answer["windows"]], dtype=float)
    if cached:
        cached.parent.mkdir(parents=True, exist_ok=True)
        np.save(cached, poses)
    return poses


# Version 6's controllers run at 60 Hz on their own clock: where in its 17 ms period a command lands
# is not in any log, and moves where the car ends (one 8 ms shift: 7.4 cm median, 24.3 cm p90 after 15
# steps on the shared logs' windows, 21.4 / 45.4 cm at >= 2.5 m/s; benchmarks/referee_fidelity.py).
# The referee's answer for version 6 is the mean over these phases; the spread about it is its floor.
V6_PHASES_MS = (0, 6, 12)


def run_referee_phases(
    wins: Sequence[RefereeWindow], version: str, car_dir: Path = DEFAULT_CAR_DIR, cache: Path | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The referee's mean answer over the control phases (:data:`V6_PHASES_MS`; version 5's 1 kHz
    controllers have none) and every phase's own ``(phases, windows, steps, 3)``."""
    if version != "6":
        one = run_referee(wins, version, car_dir, cache)
        return one, one[None]
    runs = np.stack([
        run_referee([replace(w, control_phase_ms=phase) for w in wins], version, car_dir, cache)
        for phase in V6_PHASES_MS
    ])  # fmt: skip
    mean = runs.mean(axis=0)
    mean[..., 2] = np.angle(np.exp(1j * runs[..., 2]).mean(axis=0))
    return mean, runs


def _referee_source_hash() -> str:
    """The referee's own code, so a cached answer is never reused across a change to it."""
    h = hashlib.sha256()
    for path in sorted(REFEREE_SCRIPT.parent.glob("*.py")):
        h.update(path.read_bytes())
    return h.hexdigest()


def drive_car(window: RefereeWindow, car: CarParams) -> np.ndarray:
    """drx's ``car`` driven through ``window`` from the referee's start state (the scalar step, as the
    env drives it).

    :return: ``(steps, 3)``: the car's origin ``x, y, yaw`` after each step.
    """
    x, y, yaw = window.pose
    back = car.origin_offset
    bend = window.yaw_rate / window.speed if window.speed > 0.05 else 0.0
    state = CarState(x - back * math.cos(yaw), y - back * math.sin(yaw), yaw, window.speed,
                     window.steering, [window.prior] * 3, bend)  # fmt: skip
    out = np.empty((len(window.commands), 3))
    for i, ((v, s), ms) in enumerate(zip(window.commands, window.step_ms, strict=True)):
        step_car(state, v, s, car, ms / 1000.0)
        out[i] = (state.x + back * math.cos(state.yaw), state.y + back * math.sin(state.yaw), state.yaw)
    return out


class WindowBatch:
    """Windows of one horizon as arrays, driven through drx's batched step for a candidate car (the
    fit's inner loop: :func:`drx.sim.dynamics_batch.step_cars`, equal to the scalar step)."""

    def __init__(self, wins: Sequence[RefereeWindow]) -> None:
        self.pose = np.array([w.pose for w in wins], dtype=float)
        self.speed = np.array([w.speed for w in wins], dtype=float)
        rate = np.array([w.yaw_rate for w in wins], dtype=float)
        self.bend = np.where(self.speed > 0.05, rate / np.maximum(self.speed, 0.05), 0.0)
        self.steering = np.array([w.steering for w in wins], dtype=float)
        self.prior = np.array([w.prior for w in wins], dtype=float)
        self.commands = np.array([w.commands for w in wins], dtype=float)  # (W, S, 2)
        self.dt = np.array([w.step_ms for w in wins], dtype=float) / 1000.0  # (W, S)

    def drive(self, car: CarParams) -> np.ndarray:
        """``(windows, steps, 3)``: the car's origin ``x, y, yaw`` after each step."""
        back = car.origin_offset
        yaw = self.pose[:, 2].copy()
        state = BatchState(
            self.pose[:, 0] - back * np.cos(yaw), self.pose[:, 1] - back * np.sin(yaw), yaw,
            self.speed.copy(), self.steering.copy(), np.repeat(self.prior[:, None, :], 3, axis=1),
            self.bend.copy(),
        )  # fmt: skip
        n, steps = self.dt.shape
        out = np.empty((n, steps, 3))
        for i in range(steps):
            step_cars(state, self.commands[:, i, 0], self.commands[:, i, 1], car, self.dt[:, i])
            out[:, i, 0] = state.x + back * np.cos(state.yaw)
            out[:, i, 1] = state.y + back * np.sin(state.yaw)
            out[:, i, 2] = state.yaw
        return out


def reference_points(origins: np.ndarray) -> np.ndarray:
    """``(..., 2)``: the reward params' point, 0.14 m ahead of each origin pose ``(..., 3)``."""
    heading = np.stack([np.cos(origins[..., 2]), np.sin(origins[..., 2])], -1)
    return origins[..., :2] + REFERENCE_AHEAD * heading


def distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(windows, steps)`` [m]: the distance between the reference points of two origin-pose arrays."""
    return np.hypot(*(reference_points(a) - reference_points(b)).transpose(2, 0, 1))


def logged_origins(wins: Sequence[RefereeWindow]) -> np.ndarray:
    """``(windows, steps, 3)``: the log's origin poses after each step of each window."""
    out = []
    for w in wins:
        if w.logged is None:
            raise DrxError("a window made by hand has no log to compare with")
        log = w.logged[1:]
        ox = log[:, 0] - REFERENCE_AHEAD * np.cos(log[:, 2])
        oy = log[:, 1] - REFERENCE_AHEAD * np.sin(log[:, 2])
        out.append(np.column_stack([ox, oy, log[:, 2]]))
    return np.array(out)


def median_p90_cm(dist: np.ndarray) -> tuple[float, float]:
    """Median and 90th percentile [cm] of distances [m]."""
    return round(100.0 * float(np.median(dist)), 1), round(100.0 * float(np.percentile(dist, 90)), 1)
