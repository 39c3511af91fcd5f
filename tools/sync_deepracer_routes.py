"""Copy DeepRacer's route files into the package, so that ``pip install drx`` ships them.

Copies every ``*.npy`` of a folder (default ``../shared/tracks`` beside the checkout) into
``drx/tracks/deepracer/``, byte for byte and under its upstream file name, and touches nothing
else: not drx's own tracks, not the notice beside the routes, not the display names
(:mod:`drx.sim.track_names`). Routes already there are replaced when their bytes differ; none
is removed. Run it when the folder gains routes (the whole ``bundle/routes/`` set of
deepracer-simapp, say), then update the counts in ``drx/tracks/deepracer/NOTICE.md`` if the
sources changed and run ``tests/sim/test_shipped_tracks.py``, which walks every shipped route.

Usage (from the repository root)::

    python tools/sync_deepracer_routes.py                 # from ../shared/tracks
    python tools/sync_deepracer_routes.py ~/simapp/bundle/routes --dry-run
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SOURCE = ROOT.parent / "shared" / "tracks"
DESTINATION = ROOT / "drx" / "tracks" / "deepracer"


def plan(source: Path, destination: Path) -> dict[str, list[Path]]:
    """What a sync would do: the route files to ``add``, to ``replace`` and those ``unchanged``.

    :param source: the folder holding the ``.npy`` routes.
    :param destination: the package folder of DeepRacer's routes.
    :raises SystemExit: the source folder is missing or holds no route.
    """
    if not source.is_dir():
        raise SystemExit(f"{source} is not a folder; give the folder that holds DeepRacer's .npy routes.")
    routes = sorted(source.glob("*.npy"))
    if not routes:
        raise SystemExit(f"{source} holds no .npy route; give the folder that holds DeepRacer's routes.")
    out: dict[str, list[Path]] = {"add": [], "replace": [], "unchanged": []}
    for route in routes:
        target = destination / route.name
        if not target.exists():
            out["add"].append(route)
        elif target.read_bytes() != route.read_bytes():
            out["replace"].append(route)
        else:
            out["unchanged"].append(route)
    return out


def sync(source: Path, destination: Path, dry_run: bool = False) -> dict[str, list[Path]]:
    """Copy the new and changed routes of ``source`` into ``destination`` (see :func:`plan`)."""
    todo = plan(source, destination)
    if not dry_run:
        destination.mkdir(parents=True, exist_ok=True)
        for route in todo["add"] + todo["replace"]:
            shutil.copyfile(route, destination / route.name)
    return todo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("source", nargs="?", type=Path, default=DEFAULT_SOURCE, help="folder of .npy routes")
    parser.add_argument("--dry-run", action="store_true", help="say what would be copied, copy nothing")
    args = parser.parse_args()
    done = sync(args.source.expanduser(), DESTINATION, args.dry_run)
    verb = "would copy" if args.dry_run else "copied"
    for kind in ("add", "replace"):
        for route in done[kind]:
            print(f"{verb} {route.name} ({'new' if kind == 'add' else 'changed'})")
    print(
        f"{len(done['add'])} new, {len(done['replace'])} changed, {len(done['unchanged'])} unchanged; "
        f"{len(list(DESTINATION.glob('*.npy')))} routes in {DESTINATION.relative_to(ROOT)}."
    )


if __name__ == "__main__":
    main()
