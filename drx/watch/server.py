"""``drx watch``'s web server: one page, its figures as server-sent events, its pictures as MJPEG.

The standard library's threading HTTP server is enough here: one person's browser on this
machine, a handful of long-lived connections (two picture streams and one event stream per
open page), each on its own thread. It listens on 127.0.0.1 only.

Routes:

- ``/``: the page (``static/index.html``); ``/static/<file>``: its script, style and uPlot;
- ``/api/state[?model=NAME]``: the state as JSON (:func:`drx.watch.state.snapshot`);
- ``/events[?model=NAME]``: the same state, once a second, as ``text/event-stream``;
- ``/stream/top.mjpg`` and ``/stream/camera.mjpg`` ``?model=NAME``: ``multipart/x-mixed-replace``
  JPEG streams of the top-down and camera views;
- ``/frame/top.jpg`` and ``/frame/camera.jpg`` ``?model=NAME``: the newest single pictures.

Like deepracer-for-cloud's stream viewer (``scripts/viewer/index.template.html``: MJPEG streams of
each worker's camera topics through ROS's ``web_video_server``), the pictures are MJPEG, which an
``<img>`` shows without any script.

Without ``?model=`` the server's own choice applies: the model given to ``drx watch``, else the
model of the newest running job (looked up again on every request, so an open page follows the
next job).
"""

from __future__ import annotations

import contextlib
import json
import mimetypes
import socket
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from drx.errors import DrxError, SettingError
from drx.watch import state
from drx.watch.frames import Frames, FrameSource

STATIC = Path(__file__).with_name("static")
HOST = "127.0.0.1"
EVENT_SECONDS = 1.0  # [s] between two state events
KEEPALIVE_SECONDS = 2.0  # [s] a stream repeats its last picture this often when nothing moves
STATE_CACHE_SECONDS = 0.5  # [s] state read from the registry at most this often per model
MAX_SOURCES = 16  # models drawn at once (one thread each)
BOUNDARY = "drxframe"


class WatchServer(ThreadingHTTPServer):
    """The HTTP server, with the frame sources and a short-lived state cache shared by all requests.

    :param port: TCP port on 127.0.0.1 (0: any free port).
    :param model: the model to show by default (``None``: follow the newest running job).
    """

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, port: int, model: str | None = None) -> None:
        self.model = model
        self.closing = threading.Event()
        self._lock = threading.Lock()
        self._sources: dict[str, FrameSource] = {}
        self._states: dict[str | None, tuple[float, dict[str, Any]]] = {}
        super().__init__((HOST, port), WatchHandler)  # after the fields: a failed bind calls server_close

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://{HOST}:{self.server_address[1]}/"

    def target(self, asked: str | None) -> str | None:
        """The model a request is about: ``?model=``, else the server's (see the module's text)."""
        return state.resolve_model(asked or self.model)

    def state(self, name: str | None) -> dict[str, Any]:
        """The state of ``name`` (cached for :data:`STATE_CACHE_SECONDS`)."""
        now = time.monotonic()
        with self._lock:
            cached = self._states.get(name)
        if cached is not None and now - cached[0] < STATE_CACHE_SECONDS:
            return cached[1]
        snap = state.snapshot(name)
        source = self._sources.get(name) if name else None
        snap["frames_error"] = source.error if source is not None else None
        snap["default_model"] = self.model
        with self._lock:
            self._states[name] = (now, snap)
        return snap

    def source(self, name: str) -> FrameSource:
        """The frame source of model ``name``, started on first use."""
        with self._lock:
            src = self._sources.get(name)
            if src is None:
                if len(self._sources) >= MAX_SOURCES:  # drop the oldest model's drawing
                    oldest = next(iter(self._sources))
                    self._sources.pop(oldest).stop()
                track = state.snapshot(name)["track"]
                src = self._sources[name] = FrameSource(state.model_folder(name), track).start()
            return src

    def server_close(self) -> None:
        """Stop the frame sources and every stream, then close the socket."""
        self.closing.set()
        with self._lock:
            for src in self._sources.values():
                src.stop()
        super().server_close()


class WatchHandler(BaseHTTPRequestHandler):
    """One request (the server gives each its own thread)."""

    server: WatchServer
    server_version = "drx-watch"

    def log_message(self, format: str, *args: Any) -> None:
        """Quiet: the terminal shows the URL, not every request."""

    # ----- routing -----------------------------------------------------------------------------
    def do_GET(self) -> None:  # noqa: N802 (the standard library's name)
        """Answer a GET."""
        parts = urlsplit(self.path)
        query = {k: v[-1] for k, v in parse_qs(parts.query).items()}
        route = parts.path
        try:
            if route in ("/", "/index.html"):
                self._file(STATIC / "index.html")
            elif route.startswith("/static/"):
                self._static(route.removeprefix("/static/"))
            elif route == "/api/state":
                self._json(self.server.state(self.server.target(query.get("model"))))
            elif route == "/events":
                self._events(query.get("model"))
            elif route in ("/stream/top.mjpg", "/stream/camera.mjpg"):
                self._stream(query.get("model"), "top" if "top" in route else "camera")
            elif route in ("/frame/top.jpg", "/frame/camera.jpg"):
                self._frame(query.get("model"), "top" if "top" in route else "camera")
            else:
                self._error(HTTPStatus.NOT_FOUND, f"No page {route}; open / for the watch page.")
        except DrxError as exc:
            self._error(HTTPStatus.NOT_FOUND, str(exc))
        except (BrokenPipeError, ConnectionResetError):  # the browser went away
            pass

    # ----- plain answers -----------------------------------------------------------------------
    def _send(self, status: int, body: bytes, content_type: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, data: Any, status: int = HTTPStatus.OK) -> None:
        self._send(status, json.dumps(data, default=str).encode(), "application/json")

    def _error(self, status: int, message: str) -> None:
        self._json({"error": message}, status)

    def _file(self, path: Path) -> None:
        kind = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        if kind.startswith("text/") or kind.endswith("javascript"):
            kind += "; charset=utf-8"
        self._send(HTTPStatus.OK, path.read_bytes(), kind)

    def _static(self, name: str) -> None:
        files = {p.name: p for p in STATIC.iterdir() if p.is_file()}  # nothing outside the folder
        if name not in files:
            self._error(HTTPStatus.NOT_FOUND, f"No static file {name!r}.")
            return
        self._file(files[name])

    def _frame(self, asked: str | None, view: str) -> None:
        name = self.server.target(asked)
        if name is None:
            self._error(HTTPStatus.NOT_FOUND, "There is no model to watch yet.")
            return
        frames = self.server.source(name).wait(0, timeout=5.0)
        if frames is None:
            self._error(HTTPStatus.SERVICE_UNAVAILABLE, "No picture yet; try again in a moment.")
            return
        self._send(HTTPStatus.OK, getattr(frames, view), "image/jpeg")

    # ----- streams -----------------------------------------------------------------------------
    def _open_stream(self, content_type: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", content_type)
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True

    def _events(self, asked: str | None) -> None:
        """The state once a second until the browser leaves or the server closes."""
        self._open_stream("text/event-stream")
        self.wfile.write(b"retry: 2000\n\n")
        while not self.server.closing.is_set():
            try:
                data = self.server.state(self.server.target(asked))
            except DrxError as exc:
                data = {"error": str(exc)}
            self.wfile.write(b"data: " + json.dumps(data, default=str).encode() + b"\n\n")
            self.wfile.flush()
            self.server.closing.wait(EVENT_SECONDS)

    def _stream(self, asked: str | None, view: str) -> None:
        """MJPEG: every new picture of ``view`` as one part of a ``multipart/x-mixed-replace`` answer.

        Each part is followed at once by the next boundary, so a browser shows a picture as soon
        as it has arrived rather than when the next one starts.
        """
        name = self.server.target(asked)
        if name is None:
            self._error(HTTPStatus.NOT_FOUND, "There is no model to watch yet.")
            return
        source = self.server.source(name)
        self._open_stream(f"multipart/x-mixed-replace; boundary={BOUNDARY}")
        self.wfile.write(f"--{BOUNDARY}\r\n".encode())
        seq = 0
        while not self.server.closing.is_set() and not source.stopped:
            frames: Frames | None = source.wait(seq, timeout=KEEPALIVE_SECONDS)
            if frames is None:
                continue
            seq = frames.seq
            jpeg = getattr(frames, view)
            head = f"Content-Type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n\r\n".encode()
            self.wfile.write(head + jpeg + f"\r\n--{BOUNDARY}\r\n".encode())
            self.wfile.flush()


def port_free(port: int) -> bool:
    """Whether ``port`` on 127.0.0.1 can be listened on now."""
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((HOST, port))
        except OSError:
            return False
    return True


def make_server(port: int, model: str | None = None) -> WatchServer:
    """A :class:`WatchServer` on ``port`` (checked: the model exists, the port is free).

    :raises DrxError: no such model, or the port is taken or not allowed.
    """
    if model is not None:
        state.resolve_model(model)
    if not 0 <= port <= 65535:
        raise SettingError(
            "{field} {value} is not a TCP port; give 1024-65535, or 0 for any free port.", "port", value=port
        )
    try:
        return WatchServer(port, model)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise SettingError(
            "Cannot listen on {host}:{value} ({reason}); "
            "give another {field}, or {field} 0 for any free one.",
            "port",
            host=HOST,
            value=port,
            reason=reason,
        ) from None


def serve_in_thread(server: WatchServer) -> threading.Thread:
    """Serve ``server`` on a daemon thread (tests; the CLI serves on its main thread)."""
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True)
    thread.start()
    return thread


def shutdown(server: WatchServer) -> None:
    """Stop serving and close every stream."""
    server.closing.set()
    server.shutdown()
    server.server_close()
