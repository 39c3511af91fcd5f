"""Domain randomisation: a new look of the world every episode, for models that must transfer.

DeepRacer's simulator does this when ``ENABLE_DOMAIN_RANDOMIZATION`` is true
(deepracer-for-cloud's ``DR_ENABLE_DOMAIN_RANDOMIZATION``; deepracer-simapp
``bundle/markov/environments/deepracer_racetrack_env.py`` calls
``RandomizerManager.randomize()`` on every episode reset, and
``bundle/markov/rollout_utils.py`` registers a ``LightRandomizer`` per light, which
``bundle/markov/domain_randomizations/visual/light_randomizer.py`` gives a diffuse colour
drawn uniformly in [0, 1] per channel). drx draws, per episode:

* the sun's colour: each channel uniform in :attr:`Ranges.sun` (DeepRacer's [0, 1]); the
  ambient light stays (DeepRacer's randomiser leaves it), so the ground shows between 36% and
  100% of its usual red and green (42-115% of its blue: the usual sun is yellowish);
* each surface's colour (road, border lines, centre line, field, wall): its brightness times a
  factor uniform in :attr:`Ranges.brightness`, each channel times a factor uniform in
  :attr:`Ranges.tint` (DeepRacer's track meshes keep their textures, but drx's users ask for
  robustness to other tracks' and real floors' colours, as the issue asks).

Everything comes from the generator it is given (the env's seeded ``np_random``), so seeded
episodes repeat.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drx.sim.scene import DEFAULT_SCENE, RGB, Scene

SURFACES = ("road", "border", "center", "ground", "wall")


@dataclass(frozen=True)
class Ranges:
    """Uniform ranges of the per-episode draws (see the module docstring)."""

    sun: tuple[float, float] = (0.0, 1.0)
    brightness: tuple[float, float] = (0.75, 1.25)
    tint: tuple[float, float] = (0.9, 1.1)


DEFAULT_RANGES = Ranges()


def _vary(color: RGB, rng: np.random.Generator, ranges: Ranges) -> RGB:
    scale = rng.uniform(*ranges.brightness) * rng.uniform(*ranges.tint, size=3)
    return tuple(int(v) for v in np.clip(np.round(np.asarray(color, float) * scale), 0, 255))  # type: ignore[return-value]


def randomized_scene(
    rng: np.random.Generator, base: Scene = DEFAULT_SCENE, ranges: Ranges = DEFAULT_RANGES
) -> Scene:
    """A scene with the sun's colour and the surfaces' colours drawn from ``rng`` around ``base``."""
    sun = tuple(float(v) for v in rng.uniform(*ranges.sun, size=3))
    varied: dict[str, Any] = {name: _vary(getattr(base.colors, name), rng, ranges) for name in SURFACES}
    colors = replace(base.colors, **varied)
    return Scene(colors=colors, lighting=replace(base.lighting, sun=sun))  # type: ignore[arg-type]


__all__ = ["DEFAULT_RANGES", "Ranges", "SURFACES", "randomized_scene"]
