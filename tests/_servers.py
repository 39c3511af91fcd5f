"""Throw-away servers the tests start on 127.0.0.1: PostgreSQL and an S3-compatible store.

- PostgreSQL: the server binaries of the ``pgserver`` wheel (``pip install pgserver``, in the
  ``dev`` extra), else the system's (``pg_config --bindir``, Debian's ``/usr/lib/postgresql``).
  PostgreSQL refuses to run as root, so under root ``initdb`` and ``pg_ctl`` run as ``nobody``.
- S3: moto's server mode (``python -m moto.server``, the ``moto[server]`` package in ``dev``),
  the same S3 REST API that MinIO and AWS answer.

Each ``start_*`` returns a handle with ``stop()``, or raises :class:`Unavailable` with the
reason, which the fixtures print when they skip.
"""

from __future__ import annotations

import contextlib
import glob
import importlib.util
import os
import pwd
import shutil
import socket
import stat
import subprocess
import sys
import tempfile
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path

S3_ACCESS_KEY = "drx-test-key"
S3_SECRET_KEY = "drx-test-secret"
S3_REGION = "us-east-1"
PG_PASSWORD = "drx-test-password"


class Unavailable(RuntimeError):
    """The server cannot start here (the message says why)."""


def free_port() -> int:
    """A TCP port on 127.0.0.1 nobody listens on right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ----- PostgreSQL ---------------------------------------------------------------------
def postgres_bin_dir() -> Path:
    """The folder holding ``initdb`` and ``pg_ctl``.

    :raises Unavailable: no PostgreSQL server is installed.
    """
    spec = importlib.util.find_spec("pgserver")  # located, not imported (it sets up more than binaries)
    if spec is not None and spec.submodule_search_locations:
        bundled = Path(next(iter(spec.submodule_search_locations))) / "pginstall" / "bin"
        if (bundled / "initdb").is_file():
            return bundled
    with contextlib.suppress(OSError, subprocess.CalledProcessError):
        out = subprocess.run(["pg_config", "--bindir"], capture_output=True, text=True, check=True)
        if (Path(out.stdout.strip()) / "initdb").is_file():
            return Path(out.stdout.strip())
    for found in sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), reverse=True):
        return Path(found).parent
    raise Unavailable("no PostgreSQL server binaries (pip install pgserver, or apt-get install postgresql)")


@dataclass
class Postgres:
    """A running PostgreSQL; :attr:`url` is its SQLAlchemy URL (psycopg 3)."""

    url: str
    port: int
    folder: Path
    bin_dir: Path
    user: str | None

    def stop(self) -> None:
        """Stop the server at once and delete its files."""
        with contextlib.suppress(Exception):
            pg_ctl = [str(self.bin_dir / "pg_ctl"), "-D", str(self.folder / "data")]
            _run_as(self.user, [*pg_ctl, "-m", "immediate", "-w", "stop"], timeout=30)
        shutil.rmtree(self.folder, ignore_errors=True)


def _reachable_by_others(path: Path) -> bool:
    """Whether every folder above ``path`` lets other users through (``nobody`` must run the binaries)."""
    return all(p.stat().st_mode & stat.S_IXOTH for p in [path, *path.parents])


def _copy_install(bin_dir: Path, folder: Path) -> Path:
    """Copy the PostgreSQL installation holding ``bin_dir`` into ``folder``, readable by everyone.

    pgserver's binaries find their libraries at ``$ORIGIN/../../../pgserver.libs`` (auditwheel),
    so the folder above the installation and a ``<package>.libs`` beside it keep their places.
    """
    install, package = bin_dir.parent, bin_dir.parent.parent
    target = folder / "install"
    shutil.copytree(install, target / package.name / install.name, symlinks=True)
    for libs in package.parent.glob(f"{package.name}.libs"):
        shutil.copytree(libs, target / libs.name, symlinks=True)
    for path in [target, *target.rglob("*")]:
        if not path.is_symlink():
            path.chmod(path.stat().st_mode | stat.S_IROTH | (stat.S_IXOTH if path.is_dir() else 0))
    return target / package.name / install.name / bin_dir.name


def _run_as(user: str | None, cmd: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    kwargs: dict[str, object] = {}
    if user is not None:
        entry = pwd.getpwnam(user)
        kwargs = {"user": entry.pw_uid, "group": entry.pw_gid, "extra_groups": []}
    return subprocess.run(
        cmd,
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd="/",
        check=False,
        **kwargs,  # type: ignore[arg-type]
    )


def start_postgres() -> Postgres:
    """initdb a new cluster in a temporary folder and start it on 127.0.0.1 (trust auth, no fsync).

    :raises Unavailable: no binaries, or the server did not start (the reason is in the message).
    """
    bin_dir = postgres_bin_dir()
    user = None
    if os.geteuid() == 0:  # postgres will not run as root
        try:
            user = pwd.getpwnam("nobody").pw_name
        except KeyError:
            raise Unavailable("running as root and there is no 'nobody' user to run PostgreSQL as") from None
    folder = Path(tempfile.mkdtemp(prefix="drx-pg-"))
    data = folder / "data"
    if user is not None and not _reachable_by_others(bin_dir):
        bin_dir = _copy_install(bin_dir, folder)  # e.g. a virtualenv under /root, closed to others
    (folder / "pw").write_text(PG_PASSWORD + "\n")
    if user is not None:
        entry = pwd.getpwnam(user)
        for path in (folder, folder / "pw"):
            os.chown(path, entry.pw_uid, entry.pw_gid)
    # Connections over TCP need the password (so a wrong one is refused, as on a real server).
    auth = ["--auth-local=trust", "--auth-host=scram-sha-256", f"--pwfile={folder / 'pw'}"]
    initdb = [str(bin_dir / "initdb"), "-D", str(data), "-U", "postgres", *auth, "-E", "UTF8", "--no-sync"]
    init = _run_as(user, initdb, timeout=120)
    if init.returncode != 0:
        shutil.rmtree(folder, ignore_errors=True)
        raise Unavailable(f"initdb failed: {(init.stderr or init.stdout).strip()[-300:]}")
    port = free_port()
    options = f"-h 127.0.0.1 -p {port} -k {folder} -c fsync=off -c synchronous_commit=off"
    pg_ctl = [str(bin_dir / "pg_ctl"), "-D", str(data), "-l", str(folder / "log"), "-o", options]
    start = _run_as(user, [*pg_ctl, "-w", "-t", "60", "start"], timeout=90)
    if start.returncode != 0:
        log = (folder / "log").read_text(errors="replace")[-300:] if (folder / "log").is_file() else ""
        shutil.rmtree(folder, ignore_errors=True)
        raise Unavailable(f"pg_ctl start failed: {(start.stderr or start.stdout).strip()[-200:]} {log}")
    url = f"postgresql+psycopg://postgres:{PG_PASSWORD}@127.0.0.1:{port}/postgres"
    return Postgres(url, port, folder, bin_dir, user)


# ----- S3 ---------------------------------------------------------------------------
@dataclass
class S3Server:
    """A running S3-compatible server: :attr:`endpoint` and the credentials it accepts."""

    endpoint: str
    process: subprocess.Popen[bytes]

    def env(self) -> dict[str, str]:
        """The standard AWS variables pointing boto3 (and so drx) at this server."""
        return {
            "AWS_ENDPOINT_URL": self.endpoint,
            "AWS_ACCESS_KEY_ID": S3_ACCESS_KEY,
            "AWS_SECRET_ACCESS_KEY": S3_SECRET_KEY,
            "AWS_DEFAULT_REGION": S3_REGION,
        }

    def make_bucket(self, name: str) -> None:
        """Create a bucket."""
        import boto3

        client = boto3.client(
            "s3",
            endpoint_url=self.endpoint,
            aws_access_key_id=S3_ACCESS_KEY,
            aws_secret_access_key=S3_SECRET_KEY,
            region_name=S3_REGION,
        )
        client.create_bucket(Bucket=name)

    def stop(self) -> None:
        """Stop the server."""
        self.process.terminate()
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(10)


def start_s3(require_auth: bool = False) -> S3Server:
    """moto's S3 server on 127.0.0.1 (in-memory).

    :param require_auth: check credentials (moto's IAM emulation): every key drx has is refused.
    :raises Unavailable: moto's server mode is not installed or did not answer.
    """
    try:
        import flask  # noqa: F401  (moto[server]'s extra)
        import moto  # noqa: F401
    except ImportError:
        raise Unavailable("moto's S3 server is not installed (pip install 'moto[server]')") from None
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("AWS_")}
    if require_auth:
        env["INITIAL_NO_AUTH_ACTION_COUNT"] = "0"
    process = subprocess.Popen(
        [sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    endpoint = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise Unavailable(f"moto's S3 server exited with code {process.returncode}")
        with contextlib.suppress(OSError):
            urllib.request.urlopen(f"{endpoint}/moto-api/", timeout=2).close()
            return S3Server(endpoint, process)
        time.sleep(0.2)
    process.kill()
    raise Unavailable("moto's S3 server did not answer within 60 s")
