"""Lap videos of a time trial: MP4 or GIF, one frame per simulated step.

Each frame is the top-down view (:class:`drx.sim.pictures.TopDownRenderer`)
with the car, the path it drove this lap (orange; earlier stretches of the
lap before a reset thinner), the theoretical racing line (thin cyan, when
given), red crosses where it left the road, the camera frame inset, and an
overlay: lap number, lap and total time, speed and steering (with a bar for
each), progress, off-tracks and the finished laps' times. Off-tracks flash a
red banner with the penalty, finished laps a green one with the time, so a
clean lap and a sloppy one look different at a glance.

MP4 (H.264 via imageio-ffmpeg) plays in real time at 15 frames/s. GIF is
written at half size and every second step (7.5 frames/s) to stay small.
The writer is a trial observer (:data:`drx.evaluate.time_trial.Observer`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from drx.errors import SettingError
from drx.evaluate.time_trial import StepView
from drx.sim.episode_status import EpisodeStatus
from drx.sim.pictures import TopDownRenderer

FPS = 15  # [frames/s] one frame per simulated step
GIF_STRIDE = 2  # GIFs keep every second frame
GIF_SCALE = 0.5
BANNER_FRAMES = 20  # how long an event banner stays
HOLD_FRAMES = 15  # the final frame is held this long (1 s)
GAUGES_HEIGHT = 40  # [px] the speed and steering bars along the bottom edge, with their labels
RACING_LINE_COLOR = (120, 220, 255)
TRAIL_COLOR = (255, 120, 0)  # drx.sim.pictures draws the car's path in this colour
FORMATS = (".mp4", ".gif")


class TrialVideo:
    """Write a trial's frames to a video file as the trial runs.

    Use as a context manager and pass it as the trial's observer::

        with TrialVideo("lap.mp4", track) as video:
            run_time_trial(env, policy, rules, observer=video)

    :param path: ``.mp4`` or ``.gif`` file.
    :param track: the track (for the top-down view).
    :param title: a line shown at the top of the overlay (e.g. the model's name).
    :param racing_line: ``(m, 2)`` points [m] to draw as the racing line, or ``None``.
    :param best_lap: [s] the theoretical best lap; finished laps then show their ratio to it.
    :param laps: the laps the race has (shown as "lap 2/3").
    :param size: (width, height) [px] of an MP4 frame.
    :param top_speed: [m/s] the car's top speed: a full speed bar (default 4, DeepRacer's highest).
    :param max_steering: [deg] the car's largest steering angle: a full steering bar.
    """

    def __init__(
        self,
        path: str | Path,
        track: Any,
        title: str = "",
        racing_line: np.ndarray | None = None,
        best_lap: float | None = None,
        laps: int | None = None,
        size: tuple[int, int] = (800, 608),
        top_speed: float = 4.0,
        max_steering: float = 30.0,
    ) -> None:
        self.path = Path(path)
        self.suffix = self.path.suffix.lower()
        if self.suffix not in FORMATS:
            raise SettingError("{field} {value} must end in .mp4 or .gif.", "video", value=self.path)
        self.renderer = TopDownRenderer(track, size=size)
        self.renderer.bottom_reserve = GAUGES_HEIGHT  # the readout and the inset stay off the gauges
        self.title = title
        self.racing_line = None if racing_line is None else np.asarray(racing_line, dtype=float)
        self.best_lap = best_lap
        self.laps_planned = laps
        self.top_speed = max(float(top_speed), 0.1)
        self.max_steering = max(float(max_steering), 1.0)
        self.frames_written = 0
        self._writer: Any = None
        self._calls = 0
        self._segments: list[list[tuple[float, float]]] = [[]]
        self._offs: list[tuple[float, float]] = []
        self._lap = 0
        self._banner: tuple[str, tuple[int, int, int], int] | None = None
        self._last: np.ndarray | None = None

    # ----- life cycle --------------------------------------------------------------------------
    def __enter__(self) -> TrialVideo:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close(hold=exc[0] is None)

    def open(self) -> None:
        """Open the file for writing."""
        import imageio.v2 as imageio

        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.suffix == ".mp4":
            self._writer = imageio.get_writer(
                self.path, fps=FPS, codec="libx264", quality=7, pixelformat="yuv420p", macro_block_size=16
            )
        else:
            self._writer = imageio.get_writer(self.path, mode="I", duration=1000.0 * GIF_STRIDE / FPS, loop=0)

    def close(self, hold: bool = True) -> None:
        """Hold the last frame for a second (MP4, when ``hold``) and finish the file."""
        if self._writer is None:
            return
        if hold and self._last is not None and self.suffix == ".mp4":  # a GIF merges equal frames anyway
            for _ in range(HOLD_FRAMES):
                self._append(self._last, force=True)
        self._writer.close()
        self._writer = None

    # ----- observer ------------------------------------------------------------------------------
    def __call__(self, view: StepView) -> None:
        """Draw and write the frame of one step (the trial's observer)."""
        if view.lap != self._lap:  # a new lap: a fresh trail
            self._lap = view.lap
            self._segments = [[]]
            self._offs = []
        if view.event == "reset":
            self._segments.append([])
        self._segments[-1].append((view.x, view.y))
        finished = [lap for lap in view.laps if lap.complete]
        if view.event == EpisodeStatus.OFF_TRACK:
            self._offs.append((view.x, view.y))
            penalty = view.laps[-1].penalty_seconds
            self._banner = (f"OFF TRACK  (penalties {penalty:g} s)", (200, 30, 30), BANNER_FRAMES)
        elif view.event == EpisodeStatus.CRASHED:
            self._offs.append((view.x, view.y))
            penalty = view.laps[-1].penalty_seconds
            self._banner = (f"CRASH  (penalties {penalty:g} s)", (200, 30, 30), BANNER_FRAMES)
        elif view.event == EpisodeStatus.LAP_COMPLETE and finished:
            self._banner = (f"LAP {view.lap}  {finished[-1].time:.3f} s", (30, 150, 40), BANNER_FRAMES)
        if view.event == "end":
            return  # the state is the last step's; close() holds that frame
        frame = self.draw(view)
        self._last = frame
        self._append(frame)

    def draw(self, view: StepView) -> np.ndarray:
        """The frame for one step, (H, W, 3) uint8 RGB."""
        current = self._segments[-1]
        img = self.renderer.render(
            view.x,
            view.y,
            view.yaw,
            trail=current if len(current) >= 2 else None,
            camera_frame=_camera(view.observation),
            text_lines=self._text(view),
            boxes=None if view.bots or not view.objects else view.objects,
            cars=view.objects if view.bots and view.objects else None,
        )
        frame = self.renderer.frame
        if self.racing_line is not None:
            pts = np.round(frame.to_px(self.racing_line)).astype(np.int32)
            cv2.polylines(img, [pts], True, RACING_LINE_COLOR, 1, cv2.LINE_AA)
        for seg in self._segments[:-1]:
            if len(seg) >= 2:
                pts = np.round(frame.to_px(np.array(seg))).astype(np.int32)
                cv2.polylines(img, [pts], False, (255, 170, 60), 1, cv2.LINE_AA)
        for x, y in self._offs:
            cx, cy = (int(v) for v in np.round(frame.to_px(np.array([[x, y]])))[0])
            cv2.drawMarker(img, (cx, cy), (230, 20, 20), cv2.MARKER_TILTED_CROSS, 14, 3, cv2.LINE_AA)
        self._draw_gauges(img, view)
        self._draw_legend(img)
        if self._banner is not None:
            text, color, left = self._banner
            car = self.renderer.car_px((view.x, view.y))
            _banner(img, text, color, car, self.renderer.car_reach_px())
            self._banner = (text, color, left - 1) if left > 1 else None
        return img

    # ----- drawing helpers -----------------------------------------------------------------------
    def _text(self, view: StepView) -> list[str]:
        lap = view.laps[-1] if view.laps else None
        planned = self.laps_planned
        lines = [self.title] if self.title else []
        lines.append(f"lap {view.lap}{'/' + str(planned) if planned else ''}   {view.lap_time:6.2f} s")
        lines.append(f"total {view.total_time:6.2f} s   progress {view.progress:5.1f}%")
        lines.append(f"speed {view.speed:4.2f} m/s   steering {view.steering:+5.1f} deg")
        if lap is not None:
            crashes = f"   crashes {lap.crashes}" if view.objects else ""
            lines.append(
                f"off-track {lap.off_track_count}{crashes} (+{lap.penalty_seconds:g} s)   resets {lap.resets}"
            )
        done = [x for x in view.laps if x.complete]
        for x in done[-4:]:
            ratio = f"  x{x.time / self.best_lap:.2f} of best" if self.best_lap and x.time else ""
            lines.append(f"L{x.lap} {x.time:.3f} s{ratio}")
        return lines

    def _draw_gauges(self, img: np.ndarray, view: StepView) -> None:
        """A speed bar and a steering bar along the bottom edge."""
        h, w = img.shape[:2]
        bar_w, bar_h, pad = w // 3, 12, 10
        y = h - pad - bar_h
        # speed: fills from the left, full = the car's top speed
        x0 = pad
        cv2.rectangle(img, (x0, y), (x0 + bar_w, y + bar_h), (40, 40, 40), -1)
        fill = int(bar_w * min(max(view.speed / self.top_speed, 0.0), 1.0))
        cv2.rectangle(img, (x0, y), (x0 + fill, y + bar_h), (60, 200, 90), -1)
        label = f"speed (full {self.top_speed:g} m/s)"
        cv2.putText(img, label, (x0, y - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
        # steering: from the middle, left = + (DeepRacer), full = the car's largest angle
        x1 = w - pad - bar_w
        mid = x1 + bar_w // 2
        cv2.rectangle(img, (x1, y), (x1 + bar_w, y + bar_h), (40, 40, 40), -1)
        reach = int(bar_w / 2 * min(max(view.steering / self.max_steering, -1.0), 1.0))
        a, b = sorted((mid, mid - reach))
        cv2.rectangle(img, (a, y), (max(b, a + 1), y + bar_h), (80, 160, 255), -1)
        cv2.line(img, (mid, y - 2), (mid, y + bar_h + 2), (255, 255, 255), 1)
        label = f"steering (full {self.max_steering:g} deg)"
        cv2.putText(img, label, (x1, y - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)

    def _draw_legend(self, img: np.ndarray) -> None:
        """Name the lines between the gauges: the car's path this lap, and the racing line."""
        h, w = img.shape[:2]
        entries = [("path this lap", TRAIL_COLOR, 2)]
        if self.racing_line is not None:
            entries.append(("racing line", RACING_LINE_COLOR, 1))
        font, scale = cv2.FONT_HERSHEY_SIMPLEX, 0.4
        widths = [22 + cv2.getTextSize(text, font, scale, 1)[0][0] for text, _, _ in entries]
        gap = 14
        x = (w - sum(widths) - gap * (len(entries) - 1)) // 2
        y = h - 16
        for (text, color, thickness), width in zip(entries, widths, strict=True):
            cv2.line(img, (x, y - 4), (x + 16, y - 4), color, thickness + 1, cv2.LINE_AA)
            cv2.putText(img, text, (x + 22, y), font, scale, (255, 255, 255), 1, cv2.LINE_AA)
            x += width + gap

    def _append(self, frame: np.ndarray, force: bool = False) -> None:
        self._calls += 1
        if self.suffix == ".gif":
            if not force and (self._calls - 1) % GIF_STRIDE:
                return
            h, w = frame.shape[:2]
            frame = cv2.resize(frame, (int(w * GIF_SCALE), int(h * GIF_SCALE)), interpolation=cv2.INTER_AREA)
        if self._writer is None:
            raise RuntimeError("TrialVideo: open() it (or use it as a context manager) before the trial.")
        self._writer.append_data(frame)
        self.frames_written += 1


def _camera(observation: Any) -> np.ndarray | None:
    """The camera image of an observation (a dict with ``camera`` when the car has a lidar)."""
    if isinstance(observation, dict):
        observation = observation.get("camera")
    return None if observation is None else np.asarray(observation)


def _banner(
    img: np.ndarray,
    text: str,
    color: tuple[int, int, int],
    car: tuple[float, float] | None = None,
    reach: float = 0.0,
) -> tuple[int, int]:
    """A coloured banner with ``text``, centred across the picture at the first height (the middle,
    usually the infield; the lower middle; the upper middle) where it does not cover the car at
    ``car`` (column, row) [px], drawn ``reach`` px around it. Returns its (top, bottom) rows."""
    h, w = img.shape[:2]
    scale = max(0.6, w / 900)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 2)
    x0 = max(0, (w - tw) // 2 - 12)
    x1 = min(w, x0 + tw + 24)
    tall = th + base + 16
    tops = [int(h * f) - tall // 2 for f in (0.5, 0.72, 0.28)]
    y0 = tops[0]
    if car is not None:
        c, r = car
        near = x0 - reach <= c <= x1 + reach
        clear = [t for t in tops if not (near and t - reach <= r <= t + tall + reach)]
        y0 = clear[0] if clear else max(tops, key=lambda t: abs(t + tall / 2 - r))
    y1 = y0 + tall
    img[y0:y1, x0:x1] = (0.35 * img[y0:y1, x0:x1] + 0.65 * np.array(color)).astype(np.uint8)
    cv2.putText(
        img, text, (x0 + 12, y1 - base - 8), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 2, cv2.LINE_AA
    )
    return y0, y1


def frames_expected(steps: int, resets: int, gif: bool = False) -> int:
    """Frames a finished trial's video holds: the start, every step and reset, the final hold (MP4)."""
    drawn = 1 + steps + resets
    if gif:
        return math.ceil(drawn / GIF_STRIDE)
    return drawn + HOLD_FRAMES
