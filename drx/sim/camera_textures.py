"""The camera's textures: the ground and the ceiling, painted once per track and scene.

* :func:`ground_textures`: the anti-aliased ground texture (road, lines, field, and the walls'
  colour beyond the field), its mipmap levels and the ceiling texture (the plane at the walls'
  height: sky inside the field, walls outside), shared by identical renderers in a process;
* :func:`recolored_textures`: the same for another scene (domain randomisation, once per
  episode) from label textures painted once per track, by one lookup table (a few ms).

See :mod:`drx.sim.camera` for how the renderer samples them.
"""

from __future__ import annotations

import hashlib
import math
from typing import TYPE_CHECKING

import cv2
import numpy as np

from drx.sim.camera_painter import (
    GroundFrame,
    TrackLike,
    ground_texture,
    paint_track,
    paint_walls,
    track_points,
)
from drx.sim.scene import FieldBox, Scene, SceneColors, to_gray, wall_sides

if TYPE_CHECKING:
    from drx.sim.camera_config import CameraConfig

CEILING_RESOLUTION = 0.02  # [m/px] of the ceiling texture (it carries only the walls' top edges)
Textures = tuple[GroundFrame, list[np.ndarray], GroundFrame, np.ndarray]

_PYRAMIDS: dict[str, Textures] = {}
_PYRAMID_CACHE_SIZE = 4  # textures kept per process (several envs on one track share one)


def ground_textures(track: TrackLike, cfg: CameraConfig, scene: Scene) -> Textures:
    """The painted ground texture, its mipmap levels and the ceiling texture (read-only).

    Shared by identical renderers (keyed by the track's geometry, the texture settings and the
    scene), so vectorised envs on one track in one process paint it once and share its cache
    footprint.
    """
    key = repr(
        (
            _track_digest(track),
            cfg.texture_resolution,
            cfg.max_texture_pixels,
            cfg.texture_margin,
            cfg.mip_levels,
            scene,
        )
    )
    hit = _PYRAMIDS.get(key)
    if hit is not None:
        return hit
    lit = scene.lit()
    colors = scene.lit_colors()
    field = FieldBox.around(track_points(track))
    walls = [lit[f"wall_{side}"] for side in wall_sides()]
    frame = _texture_frame(track, cfg)
    tex = ground_texture((frame.height, frame.width), frame.res, colors)
    paint_walls(tex, frame, field, walls)
    paint_track(tex, track, frame, colors, start_line=False)
    levels = [tex]
    for _ in range(max(0, cfg.mip_levels)):
        if min(levels[-1].shape) < 8:
            break
        levels.append(cv2.pyrDown(levels[-1]))
    ceil_frame = _ceiling_frame(frame)
    ceiling = np.full((ceil_frame.height, ceil_frame.width), to_gray(lit["sky"]), np.uint8)
    paint_walls(ceiling, ceil_frame, field, walls)
    for level in (*levels, ceiling):
        level.setflags(write=False)
    result = (frame, levels, ceil_frame, ceiling)
    while len(_PYRAMIDS) >= _PYRAMID_CACHE_SIZE:
        _PYRAMIDS.pop(next(iter(_PYRAMIDS)))
    _PYRAMIDS[key] = result
    return result


# Codes of the label textures that domain randomisation recolours with one lookup table per
# episode (painting anew with anti-aliasing costs ~10x more); the field's mottle is coded as
# FIELD_CODE +/- its amplitude in grey levels.
_LABELS = {
    "road": 1, "border": 2, "center": 3, "start": 4,
    "wall_west": 5, "wall_east": 6, "wall_south": 7, "wall_north": 8, "sky": 9,
}  # fmt: skip
_FIELD_CODE = 120
_LABEL_TEXTURES: dict[str, tuple[GroundFrame, np.ndarray, GroundFrame, np.ndarray]] = {}


def _label_textures(
    track: TrackLike, cfg: CameraConfig, amplitude: int
) -> tuple[GroundFrame, np.ndarray, GroundFrame, np.ndarray]:
    """The ground and ceiling textures painted with :data:`_LABELS` codes (no anti-aliasing)."""
    key = repr(
        (_track_digest(track), cfg.texture_resolution, cfg.max_texture_pixels, cfg.texture_margin, amplitude)
    )
    hit = _LABEL_TEXTURES.get(key)
    if hit is not None:
        return hit
    codes = SceneColors(
        road=(1, 1, 1), border=(2, 2, 2), center=(3, 3, 3), start=(4, 4, 4),
        ground=(_FIELD_CODE,) * 3, ground_texture=amplitude,
    )  # fmt: skip
    field = FieldBox.around(track_points(track))
    walls = [_LABELS[f"wall_{side}"] for side in wall_sides()]
    frame = _texture_frame(track, cfg)
    label = ground_texture((frame.height, frame.width), frame.res, codes)
    paint_walls(label, frame, field, walls)
    paint_track(label, track, frame, codes, start_line=False, antialias=False)
    ceil_frame = _ceiling_frame(frame)
    ceiling = np.full((ceil_frame.height, ceil_frame.width), _LABELS["sky"], np.uint8)
    paint_walls(ceiling, ceil_frame, field, walls)
    while len(_LABEL_TEXTURES) >= _PYRAMID_CACHE_SIZE:
        _LABEL_TEXTURES.pop(next(iter(_LABEL_TEXTURES)))
    _LABEL_TEXTURES[key] = (frame, label, ceil_frame, ceiling)
    return frame, label, ceil_frame, ceiling


def recolored_textures(track: TrackLike, cfg: CameraConfig, scene: Scene) -> Textures:
    """The textures of ``scene`` from the label textures: one lookup table, then the mipmaps."""
    frame, label, ceil_frame, ceil_label = _label_textures(track, cfg, scene.colors.ground_texture)
    lit = scene.lit()
    field = to_gray(lit["ground"])
    codes = np.arange(256, dtype=np.float64)
    # the field's mottle scales with its brightness
    lut = np.clip(np.round(field + (codes - _FIELD_CODE) * field / _FIELD_CODE), 0, 255).astype(np.uint8)
    for name, code in _LABELS.items():
        lut[code] = to_gray(lit[name])
    levels = [cv2.LUT(label, lut)]
    for _ in range(max(0, cfg.mip_levels)):
        if min(levels[-1].shape) < 8:
            break
        levels.append(cv2.pyrDown(levels[-1]))
    return frame, levels, ceil_frame, cv2.LUT(ceil_label, lut)


def _track_digest(track: TrackLike) -> str:
    digest = hashlib.blake2b(digest_size=16)
    for arr in (track.center, track.inner, track.outer):
        digest.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    return f"{digest.hexdigest()}-{bool(track.closed)}"


def _ceiling_frame(ground: GroundFrame) -> GroundFrame:
    """The ceiling texture's frame: the ground texture's area and origin, at a coarser resolution."""
    res = max(CEILING_RESOLUTION, ground.res)
    width = int(math.ceil((ground.width - 1) * ground.res / res)) + 1
    height = int(math.ceil((ground.height - 1) * ground.res / res)) + 1
    return GroundFrame(ground.x0, ground.y1, res, width, height)


def _texture_frame(track: TrackLike, cfg: CameraConfig) -> GroundFrame:
    """The ground texture's frame: the track plus a margin, coarser if it would be too big."""
    frame = GroundFrame.fit(track, cfg.texture_resolution, cfg.texture_margin)
    pixels = frame.width * frame.height
    # cv2's remap needs coordinates below 32767 px; keep well inside.
    longest = max(frame.width, frame.height)
    factor = max(math.sqrt(pixels / cfg.max_texture_pixels), longest / 30000, 1.0)
    if factor > 1.0:
        frame = GroundFrame.fit(track, cfg.texture_resolution * factor, cfg.texture_margin)
    return frame


__all__ = ["CEILING_RESOLUTION", "Textures", "ground_textures", "recolored_textures"]
