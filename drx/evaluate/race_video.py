"""The video of a head-to-head race: the track from above with every car, each car's camera below.

Each frame is :class:`drx.sim.pictures.TopDownRenderer`'s track with every car drawn in its own
colour and numbered (``racecar_<i>`` is number ``i + 1``), a panel with the race clock and each
car's lap, progress and state (``pause`` while it stands a penalty, ``done`` when finished), and a
strip along the bottom with each car's camera frame (its left eye for a stereo car) framed in the
car's colour. MP4 at 15 frames/s (one per step), or GIF at half size and every second step, as
:mod:`drx.evaluate.video` writes a time trial's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from drx.errors import SettingError
from drx.evaluate.head_to_head import RaceView
from drx.evaluate.video import FORMATS, FPS, GIF_SCALE, GIF_STRIDE, HOLD_FRAMES, _camera
from drx.sim.pictures import TopDownRenderer

COLORS = ((220, 30, 30), (30, 90, 230), (20, 160, 60), (240, 150, 0))  # RGB, per start place
TOP = (640, 480)  # [px] the top-down view
CAMERA = (160, 120)  # [px] one camera frame
LABEL = 24  # [px] the name above each camera frame (480 + 24 + 120: a multiple of 16)


def check_video_path(path: Path) -> None:
    """A race video is an ``.mp4`` or ``.gif`` file.

    :raises SettingError: another suffix.
    """
    if Path(path).suffix.lower() not in FORMATS:
        raise SettingError("{field} {value} must end in .mp4 or .gif.", "video", value=path)


class RaceVideo:
    """Write a race's frames as it runs (a :data:`~drx.evaluate.head_to_head.RaceObserver`).

    :param path: ``.mp4`` or ``.gif``.
    :param track: the track in the race's direction.
    :param names: the cars' names in start order.
    :param title: the first line of the panel.
    """

    def __init__(self, path: Path, track: Any, names: list[str], title: str = "") -> None:
        check_video_path(path)
        self.path = Path(path)
        self.gif = self.path.suffix.lower() == ".gif"
        self.renderer = TopDownRenderer(track, size=TOP)
        self.names = list(names)
        self.title = title
        self.frames_written = 0
        self._calls = 0
        self._writer: Any = None
        self._last: np.ndarray | None = None

    def open(self) -> None:
        """Open the file for writing."""
        import imageio.v2 as imageio

        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.gif:
            self._writer = imageio.get_writer(self.path, mode="I", duration=1000.0 * GIF_STRIDE / FPS, loop=0)
        else:
            self._writer = imageio.get_writer(
                self.path, fps=FPS, codec="libx264", quality=7, pixelformat="yuv420p", macro_block_size=16
            )

    def close(self, hold: bool = True) -> None:
        """Hold the last frame a second (MP4) and finish the file."""
        if self._writer is None:
            return
        if hold and self._last is not None and not self.gif:
            for _ in range(HOLD_FRAMES):
                self._writer.append_data(self._last)
        self._writer.close()
        self._writer = None

    def __call__(self, view: RaceView) -> None:
        frame = self.draw(view)
        self._last = frame
        self._calls += 1
        if self.gif:
            if (self._calls - 1) % GIF_STRIDE:
                return
            h, w = frame.shape[:2]
            frame = cv2.resize(frame, (int(w * GIF_SCALE), int(h * GIF_SCALE)), interpolation=cv2.INTER_AREA)
        if self._writer is None:
            raise RuntimeError("RaceVideo: open() it before the race.")
        self._writer.append_data(frame)
        self.frames_written += 1

    def draw(self, view: RaceView) -> np.ndarray:
        """One frame: the top-down view with every car, the panel, the camera strip."""
        r = self.renderer
        top = r.background.copy()
        for car in view.cars:
            if car.status == "parked":
                continue
            color = COLORS[car.index % len(COLORS)]
            r.draw_car(top, car.x, car.y, car.yaw, color)
            c, row = r.car_px((car.x, car.y))
            cv2.putText(top, str(car.index + 1), (int(c) + 8, int(row) - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                        (0, 0, 0), 3, cv2.LINE_AA)  # fmt: skip
            cv2.putText(top, str(car.index + 1), (int(c) + 8, int(row) - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                        color, 1, cv2.LINE_AA)  # fmt: skip
        lines = [f"{self.title}  t {view.race_time:6.2f} s" if self.title else f"t {view.race_time:6.2f} s"]
        for car in view.cars:
            res = car.result
            state = "done" if res.status == "finished" else car.status.replace("_", " ")
            lines.append(f"{car.index + 1} {self.names[car.index][:14]:14s} lap {min(res.laps + 1, 99)} "
                         f"{res.progress:3.0f}% {state}")  # fmt: skip
        _panel(top, lines)
        strip = np.full((CAMERA[1] + LABEL, TOP[0], 3), 30, np.uint8)
        for car in view.cars:
            x0 = car.index * CAMERA[0]
            color = COLORS[car.index % len(COLORS)]
            image = _camera(car.observation)
            if image is not None:
                gray = image[:, :, 0] if image.ndim == 3 else image
                gray = cv2.resize(gray, CAMERA, interpolation=cv2.INTER_AREA)
                strip[LABEL:, x0 : x0 + CAMERA[0]] = np.repeat(gray[:, :, None], 3, axis=2)
            cv2.rectangle(strip, (x0, LABEL), (x0 + CAMERA[0] - 1, LABEL + CAMERA[1] - 1), color, 2)
            cv2.putText(strip, f"{car.index + 1} {self.names[car.index][:16]}", (x0 + 4, LABEL - 4),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.42, color, 1, cv2.LINE_AA)  # fmt: skip
        return np.vstack([top, strip])


def _panel(img: np.ndarray, lines: list[str]) -> None:
    """Text lines on a dark box in the top-left corner."""
    font, scale, height = cv2.FONT_HERSHEY_SIMPLEX, 0.42, 16
    width = max(cv2.getTextSize(line, font, scale, 1)[0][0] for line in lines) + 12
    box = img[: height * len(lines) + 8, :width]
    box[:] = (box * 0.35).astype(np.uint8)
    for i, line in enumerate(lines):
        cv2.putText(img, line, (6, 16 + i * height), font, scale, (255, 255, 255), 1, cv2.LINE_AA)
