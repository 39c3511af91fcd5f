"""The car's latest pose in a small file, so ``drx watch`` can show it driving from another process.

The training trace (:mod:`drx.train.trace`) reaches the disk only when an episode ends, and the
evaluation episodes run after each iteration write none, so neither is live enough to watch. A
:class:`LivePoseWriter` wraps a job's environment and, at most :data:`WRITE_HZ` times a second of
wall time, replaces ``<model folder>/live/<pid>-<n>-<mode>.json`` with the car's pose, the positions of
the episode's last :data:`PATH_STEPS` steps (the page's trail), the episode's figures and the
obstacles. The
file is written to a temporary file then renamed (a reader never sees half of one) on a thread of
its own (a step never waits on the disk). A step costs a clock read and an append; a ~1 kB JSON
text is made 15 times a second.

:func:`latest_pose` reads the freshest of those files. Each env has its own file (a training job has
a training env and an evaluation env; rollout workers in several processes would each have theirs),
and a file is removed when its env closes or its process exits.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import threading
import time
import weakref
from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import gymnasium as gym

from drx.sim.episode_status import EpisodeStatus

if TYPE_CHECKING:
    from drx.sim.env import DeepRacerEnv

LIVE_DIR = "live"
WRITE_HZ = 15.0  # [1/s] at most this many pose files per second and env: the page draws 15 frames/s
STALE_SECONDS = 2.0  # [s] a pose older than this is not "live" any more (the env stopped stepping)
PATH_STEPS = 128  # the last steps in each file: a reader polling 15 times a second misses none below 1,900/s
GONE_SECONDS = 600.0  # [s] a file this old is left over from a process that died; ignored


def live_dir(model_folder: Path) -> Path:
    """The folder of a model's live pose files."""
    return Path(model_folder) / LIVE_DIR


_numbers = itertools.count()


def _alive(pid: int) -> bool:
    try:  # Linux: a killed process nobody has reaped yet is a zombie, not alive
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        pass
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process (PermissionError): alive
        return True
    return True


def remove_leftovers(folder: Path) -> list[Path]:
    """Delete the pose files, and their half-written temporaries, of processes that died on this host.

    A process killed with ``kill -9`` cannot remove its pose file, and may die between writing the
    temporary file and renaming it; the next writer in the folder clears them (names start with the
    writer's pid: ``<pid>-<n>-<mode>.json``, ``.<pid>-<n>-<mode>.json.tmp``).
    """
    removed = []
    for path in folder.glob("*.json*"):
        pid = path.name.lstrip(".").split("-", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed


class _LatestFile:
    """Writes the newest text it was given to ``path`` on its own thread, atomically.

    A rename can block for milliseconds on a busy disk (ext4 flushes the new file's data when it
    replaces another); the env's step only hands the text over. Texts not written yet are dropped
    for newer ones: only the latest pose matters.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._tmp = path.with_name(f".{path.name}.tmp")
        self._cond = threading.Condition()
        self._text: str | None = None
        self._busy = False
        self._closed = False
        self._thread: threading.Thread | None = None

    def put(self, text: str) -> None:
        """Write ``text`` soon (replacing any text still waiting)."""
        with self._cond:
            if self._closed:
                return
            self._text = text
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="drx-live-pose", daemon=True)
                self._thread.start()
            self._cond.notify()

    def flush(self, timeout: float = 5.0) -> None:
        """Wait until every text given so far is on disk."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while (self._text is not None or self._busy) and time.monotonic() < deadline:
                self._cond.wait(0.01)

    def close(self) -> None:
        """Stop writing and remove the file."""
        with self._cond:
            self._closed = True
            self._text = None
            self._cond.notify_all()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)
        for path in (self.path, self._tmp):
            with contextlib.suppress(OSError):
                path.unlink()

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._text is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                text, self._text, self._busy = self._text, None, True
                assert text is not None  # the loop above waits for a text or returns
            try:
                self._tmp.write_text(text)
                os.replace(self._tmp, self.path)
            except OSError:  # watching must never stop a job (a full disk...): the next pose tries again
                pass
            with self._cond:
                self._busy = False
                self._cond.notify_all()


class LivePoseWriter(gym.Wrapper):
    """Writes the car's latest pose to ``<model folder>/live/<pid>-<n>-<mode>.json`` while the env steps.

    :param env: a ``drx/DeepRacer-v0`` env (or a wrapper of one).
    :param model_folder: the model's artifacts folder.
    :param mode: ``training`` or ``evaluation`` (the phase ``drx watch`` shows).
    :param hz: most writes per second of wall time.
    """

    def __init__(self, env: gym.Env, model_folder: Path, mode: str, hz: float = WRITE_HZ) -> None:
        super().__init__(env)
        self.mode = mode
        self._base = cast("DeepRacerEnv", env.unwrapped)  # drx's env: the pose is its car's state
        self.interval = 1.0 / hz
        folder = live_dir(model_folder)
        folder.mkdir(parents=True, exist_ok=True)
        remove_leftovers(folder)
        # n tells apart envs of one process (two envs of one mode would otherwise share a file)
        self.path = folder / f"{os.getpid()}-{next(_numbers)}-{mode}.json"
        self._file = _LatestFile(self.path)
        self._next = 0.0
        self._episode = -1
        self._step = 0  # steps into the episode (a put-back after an off-track does not restart it)
        self._recent: deque[tuple[int, float, float]] = deque(maxlen=PATH_STEPS)
        self._started = time.time()
        # The file goes when the env is closed or collected, or at the latest when the process exits.
        self._finalizer = weakref.finalize(self, self._file.close)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Reset the env (a new episode: the trail starts again)."""
        obs, info = self.env.reset(seed=seed, options=options)
        if not (options or {}).get("resume"):  # an evaluation's put-back continues the same lap
            self._episode += 1
            self._step = -1
            self._recent.clear()
        self._write(info, 0.0)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        """Step the env; write the pose when the last write is old enough."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._write(info, float(reward))
        return obs, float(reward), terminated, truncated, info

    def close(self) -> None:
        """Close the env and remove the pose file."""
        self._finalizer()
        super().close()

    def _write(self, info: dict[str, Any], reward: float) -> None:
        # Rate-limited alone (not also at episode ends, which come every few steps early in training).
        state = self._base.car_state
        self._step += 1
        self._recent.append((self._step, state.x, state.y))
        now = time.monotonic()
        if now < self._next:
            return
        self._next = now + self.interval
        with contextlib.suppress(TypeError, ValueError):  # watching must never stop a job (an odd value)
            self._file.put(json.dumps(self.pose(info, reward), separators=(",", ":")))

    def flush(self) -> None:
        """Wait until the latest pose is on disk (tests; the env never waits)."""
        self._file.flush()

    def pose(self, info: dict[str, Any], reward: float) -> dict[str, Any]:
        """The record written: rear-axle pose, figures of the step, obstacles, the track's name."""
        base = self._base
        state = base.car_state
        params = info.get("params") or {}
        scene = getattr(base, "scene", None)
        rows = [list(map(float, r)) for r in scene.rows()] if scene is not None else []
        return {
            "time": time.time(),
            "started": self._started,
            "pid": os.getpid(),
            "source": self.path.stem,  # this env's own name (one process may step several)
            "mode": self.mode,
            "track": getattr(base.track, "name", None),
            "episode": self._episode,
            "x": float(state.x),
            "y": float(state.y),
            "yaw": float(state.yaw),
            "speed": float(params.get("speed", state.speed)),
            "steering": float(params.get("steering_angle", 0.0)),
            "progress": float(info.get("progress", params.get("progress", 0.0))),
            "steps": int(info.get("steps", params.get("steps", 0))),
            "status": str(info.get("episode_status", EpisodeStatus.IN_PROGRESS)),
            "reward": reward,
            "stereo": getattr(getattr(base, "vehicle", None), "sensor", "camera") == "stereo",
            # [step, x, y] of the episode's last steps: a reader that missed a write still gets them
            "path": [[k, round(float(x), 4), round(float(y), 4)] for k, x, y in self._recent],
            "boxes": [] if scene is None or scene.moving else rows,
            "bots": rows if scene is not None and scene.moving else [],
        }


def read_poses(model_folder: Path, now: float | None = None) -> list[dict[str, Any]]:
    """Every pose file of a model younger than :data:`GONE_SECONDS`, newest first."""
    folder = live_dir(model_folder)
    now = time.time() if now is None else now
    poses = []
    with contextlib.suppress(OSError):
        for path in folder.glob("*.json"):
            try:
                pose = json.loads(path.read_text())
            except (OSError, ValueError):  # replaced or removed while read: the next poll gets it
                continue
            if isinstance(pose, dict) and now - float(pose.get("time", 0.0)) < GONE_SECONDS:
                poses.append(pose)
    return sorted(poses, key=lambda p: float(p.get("time", 0.0)), reverse=True)


def latest_pose(model_folder: Path, now: float | None = None) -> dict[str, Any] | None:
    """The newest pose any env of the model wrote, or ``None``."""
    poses = read_poses(model_folder, now)
    return poses[0] if poses else None


def is_live(pose: dict[str, Any] | None, now: float | None = None) -> bool:
    """Whether a pose was written in the last :data:`STALE_SECONDS`."""
    if pose is None:
        return False
    now = time.time() if now is None else now
    return now - float(pose.get("time", 0.0)) < STALE_SECONDS
