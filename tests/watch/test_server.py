"""The watch server over HTTP (no browser): state, events, pictures, streams, and bad input."""

from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import IO

import pytest

from drx.watch.server import BOUNDARY, WatchServer, make_server, serve_in_thread, shutdown
from tests.cli.helpers import fails, ok
from tests.watch.simulated import SimulatedJob


@pytest.fixture
def server(job: SimulatedJob) -> Iterator[WatchServer]:
    srv = make_server(0, "wm")
    serve_in_thread(srv)
    try:
        yield srv
    finally:
        shutdown(srv)


def get(srv: WatchServer, path: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(srv.url.rstrip("/") + path, timeout=30) as r:
            return r.status, r.headers["Content-Type"], r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers["Content-Type"], exc.read()


def read_part(stream: IO[bytes]) -> bytes:
    """The next JPEG of a multipart stream positioned after a boundary line."""
    length = None
    while (line := stream.readline().strip()) != b"":
        name, _, value = line.decode().partition(":")
        if name.lower() == "content-length":
            length = int(value)
    assert length is not None
    data = stream.read(length)
    assert stream.readline() == b"\r\n" and stream.readline().strip() == f"--{BOUNDARY}".encode()
    return data


def test_page_static_files_and_state(server: WatchServer, job: SimulatedJob) -> None:
    status, kind, body = get(server, "/")
    assert status == 200 and kind.startswith("text/html") and b"/static/watch.js" in body
    for name in ("watch.js", "watch.css", "uPlot.iife.min.js", "uPlot.min.css"):
        assert get(server, f"/static/{name}")[0] == 200
    assert get(server, "/static/..%2Fserver.py")[0] == 404
    assert get(server, "/nothing")[0] == 404
    job.end_iteration()
    status, kind, body = get(server, "/api/state")
    data = json.loads(body)
    assert data["model"] == "wm" and data["track"] == "oval" and data["graph"]["iteration"] == [0]
    status, _, body = get(server, "/api/state?model=nosuch")
    assert status == 404 and "No model named 'nosuch'" in json.loads(body)["error"]


def test_events_repeat_the_state(server: WatchServer, job: SimulatedJob) -> None:
    with urllib.request.urlopen(server.url + "events", timeout=30) as r:
        assert r.headers["Content-Type"] == "text/event-stream"
        events = []
        while len(events) < 2:
            line = r.readline()
            if line.startswith(b"data: "):
                events.append(json.loads(line[6:]))
                job.end_iteration()
    assert events[0]["model"] == "wm"
    assert len(events[1]["graph"]["iteration"]) > len(events[0]["graph"]["iteration"])


def test_the_stream_shows_the_car_moving(server: WatchServer, job: SimulatedJob) -> None:
    status, kind, still = get(server, "/frame/top.jpg")
    assert status == 200 and kind == "image/jpeg" and still[:2] == b"\xff\xd8"  # the track, no car yet
    job.drive("training")
    with urllib.request.urlopen(server.url + "stream/camera.mjpg?model=wm", timeout=30) as r:
        assert r.headers["Content-Type"] == f"multipart/x-mixed-replace; boundary={BOUNDARY}"
        assert r.readline().strip() == f"--{BOUNDARY}".encode()
        frames = {read_part(r) for _ in range(6)}
    assert all(f[:2] == b"\xff\xd8" for f in frames)
    assert len(frames) >= 3  # new pictures as the car drives


def test_cli_refuses_bad_input() -> None:
    fails("watch", "nosuch", "--no-browser", contains="No model named 'nosuch'")
    fails("watch", "--port", "70000", "--no-browser", contains="--port 70000 is not a TCP port")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        expected = (f"Cannot listen on 127.0.0.1:{port}", "--port 0")
        fails("watch", "--port", str(port), "--no-browser", contains=expected)


def test_help_describes_every_option() -> None:
    out = ok("watch", "--help").output
    for text in ("[model]", "--port", "--no-browser", "127.0.0.1"):
        assert text in out


def test_the_cli_serves_until_interrupted(job: SimulatedJob) -> None:
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "drx.cli.main", "watch", "--port", "0", "--no-browser"],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        assert line.startswith("drx watch: http://127.0.0.1:"), line
        url = line.split()[2]
        deadline = time.monotonic() + 30
        while True:
            try:
                with urllib.request.urlopen(url + "api/state", timeout=10) as r:
                    assert json.loads(r.read())["model"] == "wm"
                break
            except urllib.error.URLError:
                assert time.monotonic() < deadline
                time.sleep(0.2)
        proc.send_signal(2)  # Ctrl-C
        assert proc.wait(timeout=30) == 130
    finally:
        proc.kill()
