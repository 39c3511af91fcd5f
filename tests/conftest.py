"""Shared test fixtures: a private data home for every test, and the real DeepRacer tracks."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from _servers import Postgres, S3Server, Unavailable, start_postgres, start_s3

from drx.registry.testing import TEST_URL_ENV

# ../shared/tracks beside the checkout: real DeepRacer routes; drx ships copies of them in
# drx/tracks/deepracer (tools/sync_deepracer_routes.py), which the tests read.
SHARED_TRACKS = Path(__file__).resolve().parents[1].parent / "shared" / "tracks"
SHARED_LOGS = SHARED_TRACKS.parent / "deepracer-logs"

# What each data folder beside the checkout lets the tests check; printed once when it is absent.
SHARED_DATA = {
    SHARED_TRACKS: "the check that the DeepRacer routes drx ships (drx/tracks/deepracer) are those of "
    "the shared folder, byte for byte",
    SHARED_LOGS: "real DeepRacer traces: drx's car replayed against DeepRacer's simtrace logs",
}


def pytest_report_header(config: pytest.Config) -> list[str]:
    """Say at the start of the run which data folders are missing (shown unless -q)."""
    return [
        f"{folder} is absent; the tests of {what} will skip." for folder, what in SHARED_DATA.items()
        if not folder.is_dir()
    ]  # fmt: skip


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int, config: pytest.Config) -> None:
    """Say once why tests skipped: per missing data folder, how many tests and what they check;
    then every other skip reason with its count."""
    per_folder: Counter[Path] = Counter()
    others: Counter[str] = Counter()
    for report in terminalreporter.stats.get("skipped", []):
        longrepr = report.longrepr
        reason = (longrepr[2] if isinstance(longrepr, tuple) else str(longrepr)).removeprefix("Skipped: ")
        folder = next((f for f in SHARED_DATA if str(f) in reason), None)
        if folder is not None:
            per_folder[folder] += 1
        else:
            others[reason] += 1
    missing = [f for f in SHARED_DATA if not f.is_dir()]
    if not (missing or per_folder or others):
        return
    terminalreporter.section("why tests skipped", sep="-")
    for folder in dict.fromkeys([*missing, *per_folder]):
        state = "is absent" if not folder.is_dir() else "lacks some files"
        terminalreporter.write_line(
            f"{folder} {state}: {per_folder[folder]} tests skipped, leaving untested {SHARED_DATA[folder]}."
        )
    for reason, count in others.most_common():
        terminalreporter.write_line(f"{count} skipped: {reason}")


@pytest.fixture(autouse=True)
def _drx_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Point ``DRX_HOME`` at a fresh temporary folder so tests never touch ``~/.drx``."""
    home = tmp_path / "drx_home"
    monkeypatch.setenv("DRX_HOME", str(home))
    monkeypatch.delenv("DRX_ARTIFACTS_URL", raising=False)  # artifacts in the data home unless a test says
    # evaluations without --seed repeat from run to run in tests (the simulator's noise is seeded)
    monkeypatch.setenv("DRX_EVALUATION_SEED", "0")
    return home


def shared_track_path(name: str) -> Path:
    """Path of a real DeepRacer route in ``../shared/tracks``; skips the test when it is absent."""
    path = SHARED_TRACKS / f"{name}.npy"
    if not path.is_file():
        pytest.skip(f"{path} is absent: the real DeepRacer tracks live in ../shared/tracks beside the repo")
    return path


@pytest.fixture
def shared_tracks() -> Path:
    """The ``../shared/tracks`` folder; skips the test when it is absent."""
    if not SHARED_TRACKS.is_dir():
        pytest.skip(f"{SHARED_TRACKS} is absent: the real DeepRacer tracks live in ../shared/tracks")
    return SHARED_TRACKS


# ----- servers started by the tests on 127.0.0.1 (tests/_servers.py) ----------------------------
@pytest.fixture(scope="session")
def postgres_server() -> Iterator[Postgres]:
    """A throw-away PostgreSQL for the session; skips (saying why) where none can start."""
    try:
        server = start_postgres()
    except Unavailable as exc:
        pytest.skip(f"no PostgreSQL server can start here: {exc}")
    try:
        yield server
    finally:
        from drx.registry.engine import dispose_engines

        dispose_engines()
        server.stop()


@pytest.fixture(scope="session")
def s3_server() -> Iterator[S3Server]:
    """A throw-away S3-compatible server (moto) for the session; skips (saying why) where none can start."""
    try:
        server = start_s3()
    except Unavailable as exc:
        pytest.skip(f"no S3-compatible server can start here: {exc}")
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture(params=["sqlite", "postgresql"])
def registry_backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Runs a test on SQLite and again on the PostgreSQL server (``DRX_TEST_DATABASE_URL``)."""
    if request.param == "postgresql":
        monkeypatch.setenv(TEST_URL_ENV, request.getfixturevalue("postgres_server").url)
    return str(request.param)


_buckets = iter(range(1, 1_000_000))


@pytest.fixture
def s3_artifacts(s3_server: S3Server, monkeypatch: pytest.MonkeyPatch) -> str:
    """``DRX_ARTIFACTS_URL`` at a new bucket of the S3 server (and the AWS variables to reach it)."""
    from drx.storage import reset_stores

    bucket = f"drx-test-{next(_buckets)}"
    s3_server.make_bucket(bucket)
    for key, value in s3_server.env().items():
        monkeypatch.setenv(key, value)
    url = f"s3://{bucket}/team"
    monkeypatch.setenv("DRX_ARTIFACTS_URL", url)
    reset_stores()
    return url
