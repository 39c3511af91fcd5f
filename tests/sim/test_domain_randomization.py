"""Domain randomisation: seeded, varied, within its ranges, and off unless asked for."""

from __future__ import annotations

import time

import numpy as np

from drx.sim.camera import CameraRenderer
from drx.sim.domain_randomization import DEFAULT_RANGES, SURFACES, randomized_scene
from drx.sim.env import DeepRacerEnv
from drx.sim.scene import DEFAULT_SCENE, to_gray


def test_scenes_are_seeded_and_varied_within_ranges() -> None:
    a = [randomized_scene(np.random.default_rng(7)) for _ in range(2)]
    assert a[0] == a[1], "the same seed draws the same scene"
    rng = np.random.default_rng(0)
    scenes = [randomized_scene(rng) for _ in range(200)]
    assert len({s.colors.road for s in scenes}) > 150 and len({s.lighting.sun for s in scenes}) == 200
    lo_b, hi_b = DEFAULT_RANGES.brightness
    lo_t, hi_t = DEFAULT_RANGES.tint
    for s in scenes:
        assert all(0.0 <= c <= 1.0 for c in s.lighting.sun)
        assert s.lighting.ambient == DEFAULT_SCENE.lighting.ambient
        for name in SURFACES:
            base, got = (
                np.array(getattr(DEFAULT_SCENE.colors, name), float),
                np.array(getattr(s.colors, name)),
            )
            ratio = got[base > 20] / base[base > 20]
            assert (ratio >= lo_b * lo_t - 0.03).all() and (ratio <= hi_b * hi_t + 0.03).all(), (name, ratio)
    # the sun's draws span DeepRacer's [0, 1] per channel
    suns = np.array([s.lighting.sun for s in scenes])
    assert suns.min() < 0.05 and suns.max() > 0.95


def test_recoloured_frames_follow_the_scene() -> None:
    """A randomised scene's frame shows its own greys (label textures + lookup table), quickly."""
    from tests.sim.test_camera import stadium

    cam = CameraRenderer(stadium())
    plain = cam.render(-1.0, 0.0, 0.0)
    scene = randomized_scene(np.random.default_rng(3))
    start = time.perf_counter()
    cam.set_scene(scene)
    took = time.perf_counter() - start
    img = cam.render(-1.0, 0.0, 0.0)
    lit = scene.lit()
    assert abs(int(np.median(img[-10:, 20:60])) - to_gray(lit["road"])) <= 1  # the near road
    assert not np.array_equal(img, plain)
    assert took < 0.5, f"recolouring took {took * 1e3:.0f} ms"
    # recolouring the default scene's colours from the labels gives nearly the anti-aliased frame
    cam2 = CameraRenderer(stadium())
    cam2._install(DEFAULT_SCENE, recolor=True)
    assert np.abs(cam2.render(-1.0, 0.0, 0.0).astype(int) - plain).mean() < 1.0


def test_env_randomises_per_episode_seeded_and_only_when_asked() -> None:
    def frames(env: DeepRacerEnv, seed: int, episodes: int = 3) -> list[np.ndarray]:
        out = [env.reset(seed=seed)[0]]
        out += [env.reset()[0] for _ in range(episodes - 1)]
        return out

    env = DeepRacerEnv("oval", domain_randomization=True)
    first = frames(env, seed=5)
    again = frames(env, seed=5)
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)  # seeded
    plain_env = DeepRacerEnv("oval")
    plain = frames(plain_env, seed=5)
    assert all(not np.array_equal(a, b) for a, b in zip(first, plain, strict=True)), "varied"
    assert env.camera.scene != DEFAULT_SCENE and plain_env.camera.scene == DEFAULT_SCENE
    evaluation = DeepRacerEnv("oval", mode="evaluation")
    assert not evaluation.domain_randomization  # off unless asked for
    evaluation.reset(seed=1)
    assert evaluation.camera.scene == DEFAULT_SCENE
