"""DeepRacer's world around a track: surface colours, the walled field and the lighting.

Figures are the DeepRacer simulator's (aws-deepracer-community/deepracer-simapp):

* colours: the mean RGB of the track textures in ``bundle/meshes/reinvent/textures``
  (``road.png`` 36,49,64; ``outerLine.png`` 194,194,190 for both border lines;
  ``centerLine.png`` 194,117,0; ``field.png`` 95,136,104; ``wall.png`` 36,70,81);
* sizes: the meshes of ``bundle/meshes/reinvent/reinvent_base.dae``: the border lines are
  7.62 cm wide and lie inside the road, from the route's border inwards (``ilShape``/``olShape``);
  the centre line is dashes 5.08 cm long and 2.54 cm wide every 10.16 cm (``clShape``, 174
  quads); the field is the tracks' bounding box grown by 0.91 m on every side, enclosed by a
  wall 1 m high (``fieldShape``/``wallShape``); reinvent_base has no start line mesh;
* lighting: ``bundle/worlds/reinvent_base.world``: scene ambient 0.5, a directional sun of
  diffuse colour (1, 1, 0.8) shining along (-0.5, 0.1, -0.9), no shadows; the sky is Gazebo's
  default background (SDF ``<background>`` 0.7 grey), seen only above the far walls.

:class:`Lighting` shades a surface of a given normal relative to the default lighting of a
horizontal surface, so with the default lighting the ground shows its texture's own colour
(DeepRacer's camera images show the road at about its texture colour) and DeepRacer's
domain randomisation (the sun's colour) darkens or tints it; walls facing away from the
sun are darker.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RGB = tuple[int, int, int]

# DeepRacer's grayscale conversion (OpenCV's BGR-to-grey: 0.299 R + 0.587 G + 0.114 B).
GRAY_WEIGHTS = (0.2989, 0.5870, 0.1140)

# Ground markings [m] (reinvent_base.dae, see the module docstring).
BORDER_LINE_WIDTH = 0.0762  # painted inside the road, from the route's border inwards
CENTER_LINE_WIDTH = 0.0254
CENTER_DASH = 0.0508  # painted length of one dash
CENTER_GAP = 0.0508  # gap between dashes (period 0.1016 m)
START_LINE_WIDTH = 0.05  # drx's own start line (for people; reinvent_base has none)

# The field and its wall (reinvent_base.dae's fieldShape / wallShape).
WALL_MARGIN = 0.91  # [m] from the track's bounding box to the wall, on every side
WALL_HEIGHT = 1.0  # [m]


def to_gray(color: RGB | tuple[float, float, float]) -> int:
    """Grey level of an RGB colour with DeepRacer's weights."""
    r, g, b = color
    return int(round(GRAY_WEIGHTS[0] * r + GRAY_WEIGHTS[1] * g + GRAY_WEIGHTS[2] * b))


@dataclass(frozen=True)
class SceneColors:
    """RGB colours of the scene (texture colours, before lighting); the camera sees their grey.

    Grey levels with the defaults (DeepRacer's reinvent textures): road 47, border lines 193,
    centre line 126, field 120 (+/- a few of mottle), wall 61 before shading, sky 179.
    """

    road: RGB = (36, 49, 64)
    border: RGB = (194, 194, 190)
    center: RGB = (194, 117, 0)
    start: RGB = (230, 230, 230)
    ground: RGB = (95, 136, 104)
    ground_texture: int = 5  # amplitude [grey levels] of the field's mottle (field.png: std ~9)
    wall: RGB = (36, 70, 81)
    sky: RGB = (179, 179, 179)
    box: RGB = (220, 140, 50)


DEFAULT_COLORS = SceneColors()


@dataclass(frozen=True)
class Lighting:
    """Ambient light plus one directional sun, no shadows (DeepRacer's reinvent_base world).

    :param ambient: ambient light colour (0-1 per channel).
    :param sun: the sun's diffuse colour (0-1 per channel); domain randomisation varies it.
    :param sun_direction: the direction the sunlight travels (x east, y north, z up).
    """

    ambient: tuple[float, float, float] = (0.5, 0.5, 0.5)
    sun: tuple[float, float, float] = (1.0, 1.0, 0.8)
    sun_direction: tuple[float, float, float] = (-0.5, 0.1, -0.9)

    def irradiance(self, normal: tuple[float, float, float]) -> np.ndarray:
        """Light falling on a surface of unit ``normal``, per RGB channel."""
        d = np.asarray(self.sun_direction, float)
        cos = max(0.0, -float(np.dot(normal, d)) / float(np.linalg.norm(d)))
        return np.asarray(self.ambient, float) + np.asarray(self.sun, float) * cos

    def shade(self, color: RGB, normal: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> RGB:
        """``color`` lit by this light on a surface of ``normal``, relative to the default
        lighting of the ground (so the default ground shows its texture colour)."""
        rel = self.irradiance(normal) / _GROUND_IRRADIANCE
        return tuple(int(round(min(255.0, c * k))) for c, k in zip(color, rel, strict=True))  # type: ignore[return-value]


DEFAULT_LIGHTING = Lighting()
_GROUND_IRRADIANCE = DEFAULT_LIGHTING.irradiance((0.0, 0.0, 1.0))

# Inward normals of the four walls (x east, y north): west, east, south, north.
WALL_NORMALS = {
    "west": (1.0, 0.0, 0.0),
    "east": (-1.0, 0.0, 0.0),
    "south": (0.0, 1.0, 0.0),
    "north": (0.0, -1.0, 0.0),
}


@dataclass(frozen=True)
class Scene:
    """What the camera sees besides the track's shape: colours and lighting."""

    colors: SceneColors = DEFAULT_COLORS
    lighting: Lighting = DEFAULT_LIGHTING

    def lit(self) -> dict[str, RGB]:
        """Each surface's colour as lit: ground surfaces, the four walls, and the sky (unlit)."""
        c, light = self.colors, self.lighting
        out = {k: light.shade(getattr(c, k)) for k in ("road", "border", "center", "start", "ground")}
        for side, normal in WALL_NORMALS.items():
            out[f"wall_{side}"] = light.shade(c.wall, normal)
        out["sky"] = c.sky
        return out

    def lit_colors(self) -> SceneColors:
        """The ground colours as lit, as :class:`SceneColors` (for the ground painter)."""
        lit = self.lit()
        return SceneColors(
            road=lit["road"], border=lit["border"], center=lit["center"], start=lit["start"],
            ground=lit["ground"], ground_texture=self.colors.ground_texture,
            wall=self.lighting.shade(self.colors.wall, WALL_NORMALS["north"]), sky=self.colors.sky,
            box=self.colors.box,
        )  # fmt: skip


DEFAULT_SCENE = Scene()


@dataclass(frozen=True)
class FieldBox:
    """The walled field around a track: an axis-aligned rectangle [m] and the wall's height."""

    x0: float
    y0: float
    x1: float
    y1: float
    height: float = WALL_HEIGHT

    @classmethod
    def around(cls, points: np.ndarray, margin: float = WALL_MARGIN) -> FieldBox:
        """The field DeepRacer builds around a track: its bounding box grown by ``margin``."""
        pts = np.asarray(points, float).reshape(-1, 2)
        lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
        return cls(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def side_of(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """For points outside the field, which wall lies between them and the field.

        Returns an int array: -1 inside, 0 west, 1 east, 2 south, 3 north (by the largest
        overshoot, i.e. split along the diagonals at the corners).
        """
        over = np.stack([self.x0 - x, x - self.x1, self.y0 - y, y - self.y1])
        side = np.argmax(over, axis=0)
        return np.where(over.max(axis=0) > 0, side, -1)


def wall_sides() -> tuple[str, ...]:
    """Wall names in :meth:`FieldBox.side_of`'s order."""
    return ("west", "east", "south", "north")


__all__ = [
    "BORDER_LINE_WIDTH",
    "CENTER_DASH",
    "CENTER_GAP",
    "CENTER_LINE_WIDTH",
    "DEFAULT_COLORS",
    "DEFAULT_LIGHTING",
    "DEFAULT_SCENE",
    "FieldBox",
    "GRAY_WEIGHTS",
    "Lighting",
    "RGB",
    "START_LINE_WIDTH",
    "Scene",
    "SceneColors",
    "WALL_HEIGHT",
    "WALL_MARGIN",
    "to_gray",
    "wall_sides",
]
