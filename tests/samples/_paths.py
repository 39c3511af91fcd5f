"""Where the sample files live, and a loader for the sample reward functions and tracks/design.py."""

from __future__ import annotations

import functools
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
TRACKS_DIR = ROOT / "tracks"  # tracks/design.py and the README's table of drx's own tracks
TRACK_FILES_DIR = ROOT / "drx" / "tracks" / "drx"  # the route files design.py writes (package data)
REWARDS_DIR = ROOT / "rewards"
GARAGE_DIR = ROOT / "garage"
SHARED_TRACKS = ROOT / "drx" / "tracks" / "deepracer"  # DeepRacer's routes (from ../shared/tracks), shipped

TRACK_FILES = sorted(TRACK_FILES_DIR.glob("*.npy"))
REWARD_FILES = sorted(REWARDS_DIR.glob("*.py"))
GARAGE_FILES = sorted(GARAGE_DIR.glob("*.toml"))


@functools.cache
def load_module(path: Path) -> ModuleType:
    """Import a Python file by path, as DeepRacer imports a reward function file."""
    name = f"drx_sample_{path.parent.name}_{path.stem.replace('-', '_')}"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the file runs
    spec.loader.exec_module(module)
    return module
