"""Small synthetic DeepRacer logs, as the simulator writes them: a robomaker log (start-up noise, the
``simapp_version`` line, ``SIM_TRACE_LOG`` steps) and the console's sim-trace CSV; and where the shared
real logs are (``../shared/deepracer-logs``, never copied into the repo)."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED_LOGS = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-logs"
CONSOLE_RUN = SHARED_LOGS / "console-reinvent_base-2022-06/logs/sample-console-logs"
CONSOLE_CSV = CONSOLE_RUN / "sim-trace/training/training-simtrace/3-iteration.csv"
DRFC_LOG = SHARED_LOGS / "drfc-2023-02-4workers/deepracer-0_robomaker.1.74she0uhr3drkcy411ceh6144.log"
JUNE_PRO_LOG = SHARED_LOGS / "drfc-2022-june-pro/deepracer-0_robomaker.1.ms8k1onrrixaxt7giqyk835nv.log"
CONTINUOUS_CSV = SHARED_LOGS / "console-continuous-2021/reinvent_base-0.5-4/05-iteration.csv"

CSV_HEADER = (
    "episode,steps,X,Y,yaw,steer,throttle,action,reward,done,all_wheels_on_track,progress,"
    "closest_waypoint,track_len,tstamp,episode_status"
)


def need(path: Path) -> Path:
    """``path`` among the shared logs, or skip the test saying which folder is missing."""
    if not path.exists():
        pytest.skip(f"{path} is absent: DeepRacer's logs live in ../shared/deepracer-logs beside the repo")
    return path


def trace_rows(steps: int = 40, speed: float = 1.0) -> list[str]:
    """One episode driving straight along x at ``speed`` m/s, 15 steps a second: sim-trace fields."""
    rows = []
    for i in range(steps):
        status = "prepare" if i == 0 else "in_progress"
        x, t = 0.5 + speed * i / 15.0, 10.0 + i / 15.0
        rows.append(
            f"0,{i + 1},{x:.4f},1.0000,0.0,0.0,{speed},3,1.0,False,True,{i * 0.5:.2f},{i},"
            f"20.0,{t:.4f},{status}"
        )
    return rows


def sensor_line(version: str = "5.0", py2: bool = False) -> str:
    """deepracer-simapp's start-up line naming the model's metadata (``py2``: as simapp 4 wrote it)."""
    sensors = "[u'FRONT_FACING_CAMERA']" if py2 else "['FRONT_FACING_CAMERA']"
    return (
        f"Sensor list {sensors}, network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, simapp_version {version}, "
        "training_algorithm clipped_ppo, action_space_type discrete lidar_config {'num_sectors': 8}"
    )


def write_robomaker_log(
    path: Path, version: str | None = "5.0", noise_lines: int = 200, py2: bool = False
) -> Path:
    """A robomaker log: ``noise_lines`` of start-up output, the ``simapp_version`` line (none when
    ``version`` is ``None``), then the steps."""
    lines = [f"11/02/2023 17:14:13 start-up line {i}" for i in range(noise_lines)]
    if version is not None:
        lines.append(sensor_line(version, py2))
    lines += [f"SIM_TRACE_LOG:{row}" for row in trace_rows()]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def write_sim_trace(path: Path) -> Path:
    """A console sim-trace CSV (``N-iteration.csv``)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join([CSV_HEADER, *trace_rows()]) + "\n")
    return path
