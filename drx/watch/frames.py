"""The watch page's pictures: drx's own renderers drawing the car at its latest pose.

A :class:`FrameSource` follows one model's live pose files (:mod:`drx.watch.live`) in a thread
and, whenever a new pose lands, draws the track from above with the car, its trail and the
obstacles (:class:`drx.sim.pictures.TopDownRenderer`) and what the car's camera sees
(:class:`drx.sim.camera.CameraRenderer`, the same renderer the simulator's observations come
from; the default scene: a domain-randomised episode's colours are not in the pose file), then
keeps both as JPEG for the MJPEG streams. At most :data:`FPS` frames a second; nothing is drawn
while the car stands still.
"""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from drx.watch.live import read_poses

FPS = 15.0  # [1/s] DeepRacer's camera rate; the page needs no more
TOP_SIZE = (800, 600)  # [px] the top-down picture
CAMERA_SCALE = 4  # screen pixels per camera pixel (160 x 120 -> 640 x 480)
JPEG_QUALITY = 85
TRAIL_POINTS = 5000  # positions of the current episode kept for its trail
STICKY_SECONDS = 0.5  # [s] the env drawn keeps the picture while its pose is younger than this
IDLE_SECONDS = 5.0  # [s] no viewer for this long: stop drawing until one comes back


@dataclass
class Frames:
    """The latest pictures: JPEG bytes of each view and a counter that grows with every new pair."""

    seq: int
    top: bytes
    camera: bytes


def _jpeg(rgb_or_gray: np.ndarray) -> bytes:
    image = rgb_or_gray if rgb_or_gray.ndim == 2 else cv2.cvtColor(rgb_or_gray, cv2.COLOR_RGB2BGR)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise RuntimeError("JPEG encoding failed")
    return data.tobytes()


def _waiting_camera(text: str) -> np.ndarray:
    """A dark camera-sized picture with a line of text (before the first pose)."""
    h, w = 120 * CAMERA_SCALE, 160 * CAMERA_SCALE
    img = np.full((h, w, 3), (24, 28, 36), np.uint8)
    size, _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.8, 2)
    cv2.putText(img, text, ((w - size[0]) // 2, h // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.8,
                (150, 160, 175), 2, cv2.LINE_AA)  # fmt: skip
    return img


REVERSED = "_reversed"  # how a track driven against its route is named (drx.sim.track.Track.reversed)


def driven_track(name: str) -> Any:
    """The track a pose names, as driven: a route (id or display name), or ``<route>_reversed``
    for one driven the other way (a several-track model's episode, ``--alternate-direction``).

    :raises DrxError: neither names a known track.
    """
    from drx.errors import DrxError
    from drx.services.tracks import load_track_by_name

    try:
        return load_track_by_name(name)
    except DrxError:
        if not name.endswith(REVERSED):
            raise
        return load_track_by_name(name[: -len(REVERSED)]).reversed()


class Scenery:
    """A track's two renderers, made once per track (painting the textures takes ~0.1-1 s)."""

    def __init__(self, track_name: str) -> None:
        from drx.sim.camera import CameraRenderer
        from drx.sim.pictures import TopDownRenderer

        self.track = driven_track(track_name)
        self.top = TopDownRenderer(self.track, size=TOP_SIZE, min_car_length_px=18.0)
        self.camera = CameraRenderer(self.track)

    def draw(self, pose: dict[str, Any] | None, trail: list[tuple[float, float]]) -> tuple[bytes, bytes]:
        """JPEGs of the top-down view and the camera view with the car at ``pose`` (none: the track)."""
        if pose is None:
            return _jpeg(self.top.background), _jpeg(_waiting_camera("waiting for the car"))
        x, y, yaw = float(pose["x"]), float(pose["y"]), float(pose["yaw"])
        boxes = pose.get("boxes") or None
        bots = pose.get("bots") or None
        top = self.top.render(x, y, yaw, trail=np.asarray(trail) if len(trail) > 1 else None,
                              boxes=boxes, cars=bots)  # fmt: skip
        cam = self.camera.render(x, y, yaw, boxes=boxes or bots)
        big = cv2.resize(cam, (cam.shape[1] * CAMERA_SCALE, cam.shape[0] * CAMERA_SCALE),
                         interpolation=cv2.INTER_NEAREST)  # fmt: skip
        return _jpeg(top), _jpeg(big)


class FrameSource:
    """Draws one model's car whenever its pose changes, in a thread, for any number of viewers.

    :param folder: the model's artifacts folder (its live pose files).
    :param track_name: the model's (first) track, drawn until a pose names the track of the
        episode in progress, which is drawn then (a several-track model's changes between episodes).
    :param fps: most frames drawn per second.
    """

    def __init__(self, folder: Path, track_name: str, fps: float = FPS) -> None:
        self.folder = Path(folder)
        self.track_name = track_name
        self.interval = 1.0 / fps
        self._sceneries: dict[str, Scenery] = {}
        self._cond = threading.Condition()
        self._frames: Frames | None = None
        self._key: tuple[Any, ...] | None = None
        self._episode: tuple[Any, ...] | None = None
        self._trail: list[tuple[float, float]] = []
        self._last_step = -1
        self._source: Any = None  # the env drawn last (its pose's ``source``)
        self.drawn: str | None = None  # the track of the pictures drawn last
        self._wanted = time.monotonic()  # when a viewer last asked for pictures
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"drx-watch-{folder.name}", daemon=True)
        self.error: str | None = None

    def start(self) -> FrameSource:
        """Start following the pose files."""
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread and wake every viewer."""
        self._stop.set()
        with self._cond:
            self._cond.notify_all()

    @property
    def stopped(self) -> bool:
        """Whether :meth:`stop` was called."""
        return self._stop.is_set()

    def wait(self, after: int, timeout: float) -> Frames | None:
        """The first pictures newer than ``after`` (their ``seq``), or the newest ones after ``timeout``."""
        self._wanted = time.monotonic()
        deadline = self._wanted + timeout
        with self._cond:
            while not self._stop.is_set() and (self._frames is None or self._frames.seq <= after):
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            return self._frames

    def _scenery(self, name: str) -> Scenery:
        scenery = self._sceneries.get(name)
        if scenery is None:
            scenery = self._sceneries[name] = Scenery(name)
        return scenery

    def choose(self, now: float | None = None) -> dict[str, Any] | None:
        """The pose to draw: the env drawn last while it keeps writing, else the newest.

        Sticking to one env keeps the car from jumping between envs that step at the same time
        (rollout workers in several processes); the training env hands over to the evaluation env
        when it stops for the update.
        """
        now = time.time() if now is None else now
        poses = read_poses(self.folder, now)
        if not poses:
            return None
        for pose in poses:
            if pose.get("source") == self._source:
                if now - float(pose.get("time", 0.0)) < STICKY_SECONDS:
                    return pose
                break
        return poses[0]

    def poll(self) -> bool:
        """Read the pose to draw and draw it when it is new; whether new pictures were made."""
        pose = self.choose()
        key = None if pose is None else (pose.get("source"), pose.get("time"))
        if self._frames is not None and key == self._key:
            return False
        track = self.track_name
        if pose is not None:
            self._source = pose.get("source")
            episode = (pose.get("source"), pose.get("episode"))
            if episode != self._episode:
                self._episode, self._trail, self._last_step = episode, [], -1
            for row in pose.get("path") or []:
                if int(row[0]) > self._last_step:  # steps not drawn yet
                    self._last_step = int(row[0])
                    self._trail.append((float(row[1]), float(row[2])))
            del self._trail[:-TRAIL_POINTS]
            track = str(pose.get("track") or track)
        try:
            scenery = self._scenery(track)
        except Exception:  # a pose naming a track this registry does not know: draw the model's
            track = self.track_name
            scenery = self._scenery(track)
        self.drawn = track
        top, camera = scenery.draw(pose, self._trail)
        with self._cond:
            seq = self._frames.seq + 1 if self._frames is not None else 1
            self._frames = Frames(seq, top, camera)
            self._key = key
            self._cond.notify_all()
        return True

    def _run(self) -> None:
        while not self._stop.is_set():
            started = time.monotonic()
            try:
                if self._frames is None or started - self._wanted < IDLE_SECONDS:  # else nobody watches
                    self.poll()
                self.error = None
            except Exception as exc:  # keep serving the last pictures; the page shows the error
                self.error = f"{type(exc).__name__}: {exc}"
            with contextlib.suppress(Exception):
                self._stop.wait(max(0.0, self.interval - (time.monotonic() - started)))
