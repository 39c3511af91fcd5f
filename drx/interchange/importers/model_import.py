"""``drx model import``: which importer a file needs (a car's ``model_metadata.json``, a DeepRacer
model package or a ``drx model export`` package).

It sits above both importers (:mod:`~drx.interchange.importers.importer`,
:mod:`~drx.interchange.importers.deepracer_import`), so neither imports the other's caller.
"""

from __future__ import annotations

from pathlib import Path

from drx.errors import DrxError, not_a_file
from drx.interchange.importers.importer import ImportResult, import_metadata, import_package
from drx.services import garage


def import_file(
    path: Path, name: str | None = None, track: str | None = None, trust_reward: bool = False
) -> ImportResult | garage.GarageEntry:
    """``drx model import``: a ``.json`` file is a bare model_metadata.json (a garage car), an archive
    with a ``.pb`` and no drx manifest a DeepRacer model (:mod:`~.deepracer_import`, which
    alone takes ``track``; its reward file is never run), else a ``drx model export`` package (its
    reward runs only with ``trust_reward``)."""
    from drx.interchange.importers.deepracer_import import import_deepracer_package, is_deepracer_package

    path = Path(path)
    if not path.is_file():
        raise not_a_file(path, "File", "give a model package .tar.gz or a model_metadata.json")
    if path.suffix.lower() == ".json":
        return import_metadata(path, name)
    if is_deepracer_package(path):
        return import_deepracer_package(path, name, track)
    if track is not None:
        raise DrxError(
            "--track applies to DeepRacer model packages (model.pb); a drx package brings its track."
        )
    return import_package(path, name, trust_reward)
