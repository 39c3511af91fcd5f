"""Reading and writing model packages (``.tar.gz``) without ever writing outside a folder.

Extraction never uses ``tarfile``'s own extract: every member is checked first
(regular files and folders only; no absolute paths, no ``..``, no links or devices,
no name clashes, at most :data:`MAX_MEMBERS` members), then each file is copied by
hand to a path proven to lie inside the target folder. One bad member rejects the
whole archive before anything is written.

Archive bombs: the bytes actually unpacked are counted while copying (not only the
sizes the headers declare) and capped at :data:`MAX_TOTAL_BYTES`; reading the members
and extracting them must each end within :data:`MAX_SECONDS`. A drx package has seven
members and a few MB.
"""

from __future__ import annotations

import os
import tarfile
import time
import zlib
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

from drx.atomic import atomic_write
from drx.errors import DrxError, not_a_file

MAX_TOTAL_BYTES = 512 << 20  # [bytes] an archive unpacking to more is refused (a package is a few MB)
MAX_MEMBERS = 64  # a drx package has 7
MAX_SECONDS = 60.0  # [s] listing, and then extracting, the members


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def _member_path(name: str, archive: str) -> PurePosixPath:
    if not name or name.startswith(("/", "\\")) or (len(name) > 1 and name[1] == ":"):
        raise DrxError(f"{archive} has an absolute member path {name!r}; refusing to extract it.")
    parts = PurePosixPath(name.replace("\\", "/")).parts
    if ".." in parts:
        raise DrxError(
            f"{archive} has a member {name!r} that points outside its folder ('..'); refusing to extract it."
        )
    clean = [p for p in parts if p not in ("", ".")]
    if not clean:
        raise DrxError(f"{archive} has a member with an empty path; refusing to extract it.")
    return PurePosixPath(*clean)


def checked_members(tar: tarfile.TarFile, archive: str) -> dict[str, tarfile.TarInfo]:
    """The archive's regular files by normalised relative path, after checking every member.

    :raises DrxError: an unsafe or unsupported member, or an archive too large to unpack.
    """
    files: dict[str, tarfile.TarInfo] = {}
    total = 0
    deadline = time.monotonic() + MAX_SECONDS
    for count, member in enumerate(_members(tar, archive), start=1):
        if count > MAX_MEMBERS:
            raise DrxError(
                f"{archive} has more than {MAX_MEMBERS} members (a drx package has 7); refusing it."
            )
        if time.monotonic() > deadline:
            raise DrxError(f"{archive} takes longer than {MAX_SECONDS:g} s to list; refusing to extract it.")
        path = _member_path(member.name, archive)
        if member.isdir():
            continue
        if not member.isfile():
            kind = "link" if member.issym() or member.islnk() else "special file"
            raise DrxError(
                f"{archive} has a {kind} {member.name!r}; a model package holds regular files only."
            )
        key = str(path)
        if key in files:
            raise DrxError(f"{archive} holds {key!r} twice; refusing an ambiguous archive.")
        total += member.size
        if total > MAX_TOTAL_BYTES:
            raise _too_big(archive)
        files[key] = member
    return files


def _too_big(archive: str) -> DrxError:
    return DrxError(
        f"{archive} unpacks to more than {MAX_TOTAL_BYTES >> 20} MiB (a drx package is a few MB); "
        "refusing to extract it."
    )


def _members(tar: tarfile.TarFile, archive: str) -> Iterator[tarfile.TarInfo]:
    """The members one by one (a damaged stream is a DrxError, not a traceback)."""
    try:
        yield from tar
    except (tarfile.TarError, OSError, EOFError, zlib.error) as exc:
        raise DrxError(f"{archive} is damaged ({_first_line(exc)}); export it again.") from exc


def open_archive(path: Path) -> tarfile.TarFile:
    """Open a ``.tar.gz`` (or plain tar) for reading.

    :raises DrxError: the file is missing or not a tar archive.
    """
    path = Path(path)
    if not path.is_file():
        raise not_a_file(path, "Archive", "give a .tar.gz file")
    try:
        return tarfile.open(path, "r:*")
    except (tarfile.TarError, OSError, EOFError) as exc:
        raise DrxError(
            f"{path.name} is not a tar.gz archive; give a file written by `drx model export`."
        ) from exc


def extract_files(
    tar: tarfile.TarFile, files: dict[str, tarfile.TarInfo], target: Path, archive: str
) -> None:
    """Copy the checked ``files`` into ``target`` (which must exist), proving each path lies inside it."""
    root = Path(target).resolve()
    total = 0
    deadline = time.monotonic() + MAX_SECONDS
    for key, member in files.items():
        dest = (root / key).resolve()
        if os.path.commonpath([root, dest]) != str(root):
            raise DrxError(f"{archive} member {key!r} would be written outside the target folder; refusing.")
        dest.parent.mkdir(parents=True, exist_ok=True)
        source = tar.extractfile(member)
        if source is None:
            raise DrxError(f"{archive} member {key!r} cannot be read.")
        try:
            with source, open(dest, "xb") as out:
                while chunk := source.read(1 << 20):
                    total += len(chunk)
                    if total > MAX_TOTAL_BYTES:
                        raise _too_big(archive)
                    if time.monotonic() > deadline:
                        raise DrxError(
                            f"{archive} takes longer than {MAX_SECONDS:g} s to unpack; refusing it."
                        )
                    out.write(chunk)
        except (tarfile.TarError, OSError, EOFError, zlib.error) as exc:
            raise DrxError(f"{archive} is damaged: {key!r} cannot be read ({_first_line(exc)}).") from exc


def write_archive(out: Path, files: dict[str, Path]) -> Path:
    """Write ``{member name: file}`` as a gzipped tar to ``out`` (through a temporary file)."""
    out = Path(out)
    with atomic_write(out, "wb") as archive, tarfile.open(fileobj=archive, mode="w:gz") as tar:
        for name, path in files.items():
            info = tar.gettarinfo(str(path), arcname=name)
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            info.mode = 0o644
            with open(path, "rb") as f:
                tar.addfile(info, f)
    return out
